"""TF rotations that are not unit quaternions, tallied per topic and edge for one warning.

tf2 refuses a transform whose ``|q|² − 1`` is beyond ±0.01 ("Quaternion not properly
normalized", ``TF_DENORMALIZED_QUATERNION``). aion normalises every rotation it takes
(:meth:`formats.tf.TfBuffer.add_transforms`); this module finds the ones tf2 would have
refused, so that is said rather than done silently. Zero and non-finite quaternions are not
counted here: the buffer drops those (:attr:`formats.tf.TfBuffer.unusable`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aion_cli.formats.raw import normalize_frame
from aion_cli.listing import first_few

if TYPE_CHECKING:
    from aion_cli.formats.tf_fast import TfArrays

F64 = npt.NDArray[np.float64]
BoolA = npt.NDArray[np.bool_]

#: tf2's QUATERNION_NORMALIZATION_TOLERANCE on ``|q|² − 1`` (tf2/buffer_core.cpp).
TF2_TOLERANCE = 0.01


def off_unit(q: F64) -> BoolA:
    """Rows of quaternions float64[n,4] tf2 would refuse as not normalised: finite, not zero
    (those are dropped as unusable), and ``| |q|² − 1 | > 0.01``."""
    sq = np.einsum("ij,ij->i", q, q)
    return np.isfinite(sq) & (sq > 1e-18) & (np.abs(sq - 1.0) > TF2_TOLERANCE)


@dataclass
class NormTally:
    """Per ``(topic, parent, child)``: messages with a rotation tf2 would refuse, and the
    smallest and largest ``|q|`` among them."""

    edges: dict[tuple[str, str, str], list[float]] = field(default_factory=dict)

    def add(
        self,
        topics: Sequence[str],
        parents: Sequence[str],
        children: Sequence[str],
        norms: Sequence[float],
        messages: Sequence[int],
    ) -> None:
        """Rows found by :func:`off_unit`: each row's topic, frames, ``|q|`` and the index of
        its message (rows of one message on one edge count once)."""
        seen: set[tuple[str, str, str, int]] = set()
        for topic, parent, child, norm, msg in zip(
            topics, parents, children, norms, messages, strict=True
        ):
            key = (topic, parent, child)
            entry = self.edges.setdefault(key, [0, norm, norm])
            if (*key, msg) not in seen:
                seen.add((*key, msg))
                entry[0] += 1
            entry[1], entry[2] = min(entry[1], norm), max(entry[2], norm)

    def add_arrays(self, messages: Sequence[Any], arrays: TfArrays) -> None:
        """The rows of ``arrays`` (decoded from ``messages``, each with a ``topic``) whose
        rotation tf2 would refuse (rare: a loop over those rows only)."""
        bad = np.flatnonzero(off_unit(arrays.quat_xyzw) & arrays.usable())
        if not len(bad):
            return
        rows = arrays.select(bad)
        msgs = rows.msg_index.tolist()
        q = rows.quat_xyzw
        norms = np.sqrt(np.einsum("ij,ij->i", q, q)).tolist()
        self.add([messages[i].topic for i in msgs], rows.parent, rows.child, norms, msgs)

    def add_message(self, topic: str, msg: Any) -> None:
        """:meth:`add_arrays` for one decoded TFMessage (the generic decoder's path); a
        transform the buffer refuses for its frames (empty, or its own parent) is left out."""
        tfs = [
            (normalize_frame(tf.header.frame_id), normalize_frame(tf.child_frame_id), tf)
            for tf in msg.transforms
        ]
        tfs = [(p, c, tf) for p, c, tf in tfs if p and c and p != c]
        if not tfs:
            return
        rots = [tf.transform.rotation for _p, _c, tf in tfs]
        q = np.array([(r.x, r.y, r.z, r.w) for r in rots], dtype=np.float64)
        bad = np.flatnonzero(off_unit(q)).tolist()
        if bad:
            norms = np.sqrt(np.einsum("ij,ij->i", q[bad], q[bad])).tolist()
            picked = [tfs[i] for i in bad]
            self.add(
                [topic] * len(bad), [p for p, _c, _t in picked], [c for _p, c, _t in picked],
                norms, [0] * len(bad),
            )  # fmt: skip

    def text(self) -> str:
        """The warning, or "" when every rotation was a unit quaternion within tf2's
        tolerance."""
        if not self.edges:
            return ""
        parts = []
        for (topic, parent, child), (n, lo, hi) in sorted(self.edges.items()):
            size = f"{lo:.3g}" if f"{lo:.3g}" == f"{hi:.3g}" else f"{lo:.3g} to {hi:.3g}"
            parts.append(
                f"{parent}->{child} on {topic} in {int(n):,} message{'s' * (n != 1)} "
                f"(|q| {size})"
            )
        return (
            f"TF rotations that are not unit quaternions: {first_few(parts, 5)}; tf2 refuses "
            "them (|q|² − 1 beyond ±0.01: \"Quaternion not properly normalized\"), aion "
            "normalised them and used them; fix their publisher"
        )
