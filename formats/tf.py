"""A small tf2-style transform buffer built from ``/tf`` and ``/tf_static``.

No maintained PyPI package offers a ROS-free tf2 buffer (``docs/FORMATS-NOTES.md``
§5), so this is our own: per frame edge (``parent_T_child``) sorted arrays of stamp, translation
and quaternion (x, y, z, w); static edges separately. A lookup finds the chain between two frames
by BFS over the undirected frame tree, interpolates every dynamic edge between its bracketing
samples exactly like tf2's ``TimeCache::interpolate`` (linear translation, quaternion slerp) and
composes the chain, all vectorized over the query times (:mod:`formats.tf_lookup`, the buffer's
base class).

Query times outside an edge's recorded range (plus a tolerance, 0.1 s by default), or inside a
gap of more than 10 s between two of its samples (beyond the tolerance of both), are flagged
``ok = False`` and their outputs are NaN: the caller counts the drops, nothing returns made-up
poses. Unknown frames or frames without a chain raise :class:`TransformError`.

Cost: a lookup is a fixed ~50 numpy calls plus about 1 µs per query time and chain edge, so
callers should transform the detections of many messages in one call (per-row times) rather
than per message. Memory is bounded whatever the chain: edges are composed one at a time over
blocks of query times (``TfBuffer(block_rows=...)``).
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, I64
from aion_cli.errors import TransformError
from aion_cli.formats.raw import normalize_frame
from aion_cli.formats.tf_lookup import TfLookup
from aion_cli.formats.tf_parts import EdgeSeries, StaticEdge
from aion_cli.formats.tf_tree import root, unusable_text

_PENDING_MAX = 4096  # queued TF messages ingested in one vectorized call
LOOKUP_BLOCK_ROWS = 16_384
"""Query times composed at once by :meth:`TfBuffer.lookup` (about 16 MB of temporaries)."""
MAX_GAP_S = 10.0
"""The longest gap between an edge's samples a lookup interpolates across (tf2's default
cache length): a longer one is time the transform was not known (``TfBuffer(max_gap_s=...)``)."""


def _stamp_ns(stamp: Any) -> int:
    """ns of a ROS time: ``sec/nanosec`` (ROS 2, rosbags) or ``secs/nsecs`` (genpy)."""
    if hasattr(stamp, "nanosec"):
        return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
    return int(stamp.secs) * 1_000_000_000 + int(stamp.nsecs)


class TfBuffer(TfLookup):
    """Frame transforms over time; see the module docstring.

    ``tolerance_s``: how far outside an edge's recorded time range a lookup still succeeds
    (using the nearest sample), like a short hold; beyond it, ``ok`` is False.
    ``max_gap_s``: the longest gap between two samples of an edge that is interpolated
    across (tf2's default cache length, 10 s); a time inside a longer gap, farther than
    ``tolerance_s`` from both samples, is not ``ok``, and one within it is the nearer
    sample, as at the ends of the range (localisation lost, TF stopped): a
    robot pose made up across it would place detections and count windows as observed
    where the robot may never have been.
    ``block_rows``: query times composed at once (bounds a lookup's temporaries; the results
    do not depend on it).
    """

    def __init__(
        self,
        tolerance_s: float = 0.1,
        *,
        block_rows: int = LOOKUP_BLOCK_ROWS,
        max_gap_s: float = MAX_GAP_S,
    ) -> None:
        if not np.isfinite(tolerance_s) or tolerance_s < 0:
            raise TransformError(f"TF tolerance must be >= 0 s, got {tolerance_s}")
        if not (max_gap_s > 0):  # inf allowed: interpolate across any gap
            raise TransformError(f"TF interpolation gap must be > 0 s, got {max_gap_s}")
        if not (isinstance(block_rows, int) and block_rows >= 1):
            raise TransformError(f"TF lookup block must be >= 1 row, got {block_rows!r}")
        self.tolerance_ns = round(tolerance_s * 1e9)
        self.max_gap_ns = float(max_gap_s) * 1e9
        self.block_rows = block_rows
        self._dynamic: dict[tuple[str, str], EdgeSeries] = {}
        self._static: dict[tuple[str, str], StaticEdge] = {}
        self._neighbours: dict[str, set[str]] = {}
        self._paths: dict[tuple[str, str], list[str]] = {}
        self._pending: list[tuple[Any, bool]] = []  # messages not yet ingested (batched)
        self._invalid = 0
        self._unusable: dict[tuple[str, str], int] = {}  # per edge: rows dropped as unusable

    @property
    def invalid_samples(self) -> int:
        """Samples dropped at ingest: unusable translation or quaternion, or (from messages) a
        frame that is empty or its own parent."""
        self._flush()
        return self._invalid

    # ------------------------------------------------------------------ ingest

    @classmethod
    def from_messages(
        cls, messages: Iterable[tuple[Any, bool]], tolerance_s: float = 0.1
    ) -> TfBuffer:
        """A buffer from decoded ``tf2_msgs/TFMessage`` objects paired with ``is_static``."""
        buf = cls(tolerance_s)
        batches: dict[bool, list[Any]] = {True: [], False: []}
        for msg, static in messages:
            batches[bool(static)].append(msg)
        buf.add_messages(batches[True], static=True)
        buf.add_messages(batches[False], static=False)
        return buf

    def add_message(self, msg: Any, static: bool = False) -> None:
        """Queue one decoded TFMessage (rosbags, mcap_ros2 or genpy object).

        Messages are ingested in batches (one vectorized call per :data:`_PENDING_MAX`
        messages, or at the next query): per-message numpy work would cost ~10x more.
        """
        self._pending.append((msg, static))
        if len(self._pending) >= _PENDING_MAX:
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        pending, self._pending = self._pending, []
        self._ingest([m for m, st in pending if st], static=True)
        self._ingest([m for m, st in pending if not st], static=False)

    def add_transforms(
        self,
        parent: Sequence[str] | npt.NDArray[Any] | str,
        child: Sequence[str] | npt.NDArray[Any] | str,
        t_ns: npt.ArrayLike,
        translation: npt.ArrayLike,
        quat_xyzw: npt.ArrayLike,
        static: bool = False,
    ) -> None:
        """Add n transforms ``parent_T_child`` at once (a str parent/child applies to all rows).

        Rows with a non-finite translation or a zero / non-finite quaternion are dropped and
        counted in ``invalid_samples``; a static row holds from its stamp ``t_ns`` on (the
        last one per edge and stamp wins; before its first stamp an edge takes its first):
        one transform for all times while an edge's static values agree.
        """
        self._flush()  # keep arrival order (static: the last one per stamp wins)
        t = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
        n = len(t)
        tr = np.asarray(translation, dtype=np.float64).reshape(n, 3)
        q = np.asarray(quat_xyzw, dtype=np.float64).reshape(n, 4)
        norm = np.sqrt(np.einsum("ij,ij->i", q, q))
        good = np.isfinite(tr).all(axis=1) & np.isfinite(norm) & (norm > 1e-9)
        n_good = int(np.count_nonzero(good))
        self._invalid += n - n_good
        given = q
        q = q / np.where(good, norm, 1.0)[:, None]
        if isinstance(parent, str) and isinstance(child, str):  # one edge: no grouping
            rows: Any = slice(None) if n_good == n else good
            p, c = (
                self._frames_column(parent, 1, "parent")[0],
                self._frames_column(child, 1, "child")[0],
            )
            if n_good:
                self._add_edge(p, c, t[rows], tr[rows], q[rows], static, given[rows])
            if n_good < n:
                self._unusable[(p, c)] = self._unusable.get((p, c), 0) + n - n_good
            return
        parents = self._frames_column(parent, n, "parent")
        children = self._frames_column(child, n, "child")
        for i in np.flatnonzero(~good).tolist():  # (rare: no vectorizing needed)
            key = (parents[i], children[i])
            self._unusable[key] = self._unusable.get(key, 0) + 1
        groups: dict[tuple[str, str], list[int]] = {}
        for i in np.flatnonzero(good).tolist():
            groups.setdefault((parents[i], children[i]), []).append(i)
        for (p, c), idx in groups.items():
            self._add_edge(p, c, t[idx], tr[idx], q[idx], static, given[idx])

    def add_messages(self, messages: Iterable[Any], static: bool = False) -> None:
        """Ingest many decoded TFMessages with one vectorized :meth:`add_transforms` call."""
        self._flush()
        self._ingest(list(messages), static)

    def _ingest(self, messages: list[Any], static: bool) -> None:
        """TFMessages -> arrays; transforms with an empty or self-referencing frame are counted
        as invalid (a log's bad transform must not stop a build)."""
        tfs = [
            tf
            for msg in messages
            for tf in msg.transforms
            if normalize_frame(tf.header.frame_id)
            and normalize_frame(tf.child_frame_id)
            and normalize_frame(tf.header.frame_id) != normalize_frame(tf.child_frame_id)
        ]
        self._invalid += sum(len(msg.transforms) for msg in messages) - len(tfs)
        if not tfs:
            return
        trans = [tf.transform.translation for tf in tfs]
        rots = [tf.transform.rotation for tf in tfs]
        self.add_transforms(
            [tf.header.frame_id for tf in tfs],
            [tf.child_frame_id for tf in tfs],
            np.array([_stamp_ns(tf.header.stamp) for tf in tfs], dtype=np.int64),
            np.array([(v.x, v.y, v.z) for v in trans], dtype=np.float64),
            np.array([(r.x, r.y, r.z, r.w) for r in rots], dtype=np.float64),
            static,
        )

    add = add_transforms  # the name docs/CONTRACTS.md uses

    @staticmethod
    def _frames_column(
        frames: Sequence[str] | npt.NDArray[Any] | str, n: int, what: str
    ) -> list[str]:
        if isinstance(frames, str):
            frames = [frames] * n
        names = [normalize_frame(str(f)) for f in frames]
        if len(names) != n:
            raise TransformError(f"{what} frames: expected {n} names, got {len(names)}")
        if any(not f for f in names):
            raise TransformError(f"empty {what} frame id in TF data")
        return names

    def _add_edge(
        self, parent: str, child: str, t: I64, tr: F64, q: F64, static: bool, given: F64
    ) -> None:
        if parent == child:
            raise TransformError(f"TF edge from frame {parent!r} to itself")
        key = (parent, child)
        if key not in self._static and key not in self._dynamic:
            self._neighbours.setdefault(parent, set()).add(child)
            self._neighbours.setdefault(child, set()).add(parent)
            self._paths.clear()
        if static:
            self._static.setdefault(key, StaticEdge()).add(t, tr, given, q)
        else:
            self._dynamic.setdefault(key, EdgeSeries()).append(t, tr, q)

    def static_transforms(self) -> list[tuple[str, str, int, F64, F64]]:
        """The static transforms as ``(parent, child, stamp, translation, quaternion)``
        where an edge's value changes (the quaternion as given, not normalised; one per edge
        whose values all agree): :meth:`add_transforms` of them with ``static=True`` gives
        another buffer exactly these static edges."""
        self._flush()
        return [
            (p, c, stamp, tr, q)
            for (p, c), edge in sorted(self._static.items())
            for stamp, tr, q in edge.steps()
        ]

    @property
    def unusable(self) -> dict[tuple[str, str], int]:
        """Per ``(parent, child)``: transforms dropped for a non-finite translation or a zero
        or non-finite quaternion (tf2 ignores them too)."""
        self._flush()
        return dict(self._unusable)

    @property
    def edges(self) -> list[tuple[str, str]]:
        """Every ``(parent, child)`` with a usable transform (static or not), sorted
        (:mod:`formats.tf_tree` says what shape they make)."""
        self._flush()
        return sorted(set(self._static) | set(self._dynamic))

    # ------------------------------------------------------------------ queries

    @property
    def frames(self) -> list[str]:
        """Every frame name seen, sorted."""
        self._flush()
        return sorted(self._neighbours)

    def time_range(self, parent: str, child: str) -> tuple[int, int] | None:
        """First and last stamp of a dynamic edge, None for static or unknown edges."""
        self._flush()
        series = self._dynamic.get((normalize_frame(parent), normalize_frame(child)))
        if series is None or series.n == 0:
            return None
        stamps, _, _ = series.arrays()
        return int(stamps[0]), int(stamps[-1])

    def chain_range(self, target: str, source: str) -> tuple[int, int] | None:
        """The stamps over which every ``/tf`` link of the chain has samples (the latest first
        stamp, the earliest last one); None for a ``/tf_static`` chain or none."""
        try:
            path = self._path(normalize_frame(target), normalize_frame(source))
        except TransformError:
            return None
        pairs = itertools.pairwise(path)
        ranges = [r for a, b in pairs if (r := self.time_range(a, b) or self.time_range(b, a))]
        return (max(r[0] for r in ranges), min(r[1] for r in ranges)) if ranges else None

    def _path(self, target: str, source: str) -> list[str]:
        """Frames from target to source (inclusive), by BFS over the undirected frame tree."""
        self._flush()
        cached = self._paths.get((target, source))
        if cached is not None:
            return cached
        for f in (target, source):
            if f not in self._neighbours:
                dropped = unusable_text(self._unusable, f)
                if dropped:
                    raise TransformError(
                        f"frame {f!r} is only in TF transforms that cannot be used: {dropped}; "
                        f"frames known: {', '.join(self.frames) or '(none)'}",
                        hint="a transform needs a finite translation and a non-zero "
                        "quaternion (x, y, z, w); fix the publisher of that transform (tf2 "
                        "ignores such transforms too)",
                    )
                if f == target and source in self._neighbours:  # no map->odom: name the root
                    top = root(self.edges, source)
                    raise TransformError(
                        f"unknown frame {f!r}: TF joins {source!r} only to "
                        f"{', '.join(sorted(self.connected(source) - {source}))}",
                        hint=f"the top of the TF tree of {source!r} is {top!r}: --map-frame "
                        f"{top} builds the map in that frame; or record the transform {f}->{top}",
                    )
                raise TransformError(
                    f"unknown frame {f!r}; frames known: {', '.join(self.frames) or '(none)'}",
                    hint="check --map-frame / the detections' frame_id, and that the log has /tf",
                )
        prev = self._search(target, source)
        if source not in prev:
            raise TransformError(
                f"no transform chain between {target!r} and {source!r}; frames connected to "
                f"{target!r}: {', '.join(sorted(prev))}; frames known: {', '.join(self.frames)}",
                hint="the log's TF tree is split; is map->odom (or odom->base) missing?",
            )
        path = [source]
        while path[-1] != target:
            step = prev[path[-1]]
            assert step is not None
            path.append(step)
        path.reverse()
        self._paths[(target, source)] = path
        return path

    def connected(self, frame: str) -> set[str]:
        """Every frame the transforms join to ``frame``, ``frame`` included (just it when the
        buffer does not know it)."""
        self._flush()
        return set(self._search(normalize_frame(frame), None))

    def dynamic_links(self, target: str, source: str) -> int:
        """How many links of the ``target``..``source`` chain are ``/tf`` transforms (0: the
        chain is ``/tf_static`` only); a :class:`TransformError` when there is no chain."""
        path = self._path(normalize_frame(target), normalize_frame(source))
        return sum(
            (a, b) in self._dynamic or (b, a) in self._dynamic
            for a, b in itertools.pairwise(path)
        )

    def _search(self, target: str, source: str | None) -> dict[str, str | None]:
        """Breadth-first from ``target`` over the undirected frame tree, until ``source`` is
        reached (every connected frame when None): each frame found, with the frame it was
        reached from (None for ``target``)."""
        prev: dict[str, str | None] = {target: None}
        queue = deque([target])
        while queue and source not in prev:
            frame = queue.popleft()
            for nxt in sorted(self._neighbours.get(frame, ())):
                if nxt not in prev:
                    prev[nxt] = frame
                    queue.append(nxt)
        return prev
