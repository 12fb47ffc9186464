"""The two parts a :class:`~aion_cli.formats.tf.TfBuffer` is built from: the growable,
lazily sorted samples of one dynamic edge (:class:`EdgeSeries`) and a batch of transforms at
many query times, static or per time, composed and inverted over the whole batch
(:class:`TfBatch`). Apart from the buffer, which finds chains, ingests messages and decides
which times a transform is known at: storage and arithmetic are jobs of their own."""

from __future__ import annotations

import numpy as np

from aion_cli.engine.types import F64, I64, BoolA
from aion_cli.formats.quaternions import quat_to_matrix


class EdgeSeries:
    """Growable, lazily sorted samples of one dynamic edge (amortised O(1) in-order appends)."""

    def __init__(self) -> None:
        self.n = 0
        self.stamps = np.empty(16, dtype=np.int64)
        self.trans = np.empty((16, 3))
        self.quats = np.empty((16, 4))
        self.sorted = True

    def append(self, t: I64, trans: F64, quats: F64) -> None:
        k = len(t)
        if self.n + k > len(self.stamps):
            cap = max(2 * len(self.stamps), self.n + k)
            self.stamps = np.resize(self.stamps, cap)
            self.trans = np.resize(self.trans, (cap, 3))
            self.quats = np.resize(self.quats, (cap, 4))
        last = self.stamps[self.n - 1] if self.n else np.iinfo(np.int64).min
        if t[0] < last or (k > 1 and bool((np.diff(t) < 0).any())):
            self.sorted = False
        self.stamps[self.n : self.n + k] = t
        self.trans[self.n : self.n + k] = trans
        self.quats[self.n : self.n + k] = quats
        self.n += k

    def arrays(self) -> tuple[I64, F64, F64]:
        if not self.sorted:
            order = np.argsort(self.stamps[: self.n], kind="stable")
            self.stamps[: self.n] = self.stamps[: self.n][order]
            self.trans[: self.n] = self.trans[: self.n][order]
            self.quats[: self.n] = self.quats[: self.n][order]
            self.sorted = True
        return self.stamps[: self.n], self.trans[: self.n], self.quats[: self.n]


class TfBatch:
    """A transform for one query batch: static (R[3,3], t[3], ok None) or per query time
    (R[n,3,3], t[n,3], ok[n]). Compositions use 3x3 matrix products over the whole batch
    (BLAS) whenever one side is static, which is the common sensor/base_link case."""

    __slots__ = ("R", "ok", "t")

    def __init__(self, R: F64, t: F64, ok: BoolA | None) -> None:
        self.R, self.t, self.ok = R, t, ok

    def inverse(self) -> TfBatch:
        if self.ok is None:
            return TfBatch(self.R.T, -self.R.T @ self.t, None)
        Rt = np.transpose(self.R, (0, 2, 1))
        return TfBatch(Rt, -np.einsum("nij,nj->ni", Rt, self.t), self.ok)

    def compose(self, other: TfBatch) -> TfBatch:
        """``self ∘ other`` (apply ``other`` first)."""
        if self.ok is None and other.ok is None:
            return TfBatch(self.R @ other.R, self.R @ other.t + self.t, None)
        if self.ok is None:  # static ∘ dynamic
            n = len(other.t)
            R = (self.R @ other.R.transpose(1, 0, 2).reshape(3, 3 * n)).reshape(3, n, 3)
            return TfBatch(R.transpose(1, 0, 2), other.t @ self.R.T + self.t, other.ok)
        if other.ok is None:  # dynamic ∘ static
            n = len(self.t)
            flat = self.R.reshape(3 * n, 3)
            t = (flat @ other.t).reshape(n, 3) + self.t
            return TfBatch((flat @ other.R).reshape(n, 3, 3), t, self.ok)
        t = np.einsum("nij,nj->ni", self.R, other.t) + self.t
        return TfBatch(np.einsum("nij,njk->nik", self.R, other.R), t, self.ok & other.ok)


class StaticEdge:
    """The ``/tf_static`` transforms of one edge: the last one given at each header stamp.
    When they all agree the edge is one transform (:meth:`batch` static, as tf2 keeps it);
    when its value changed (a sensor remounted, logs of two robots in one build) each takes
    over at its stamp, and a time before the first stamp takes the first. Rows are appended
    as given and sorted out with numpy when first asked (a log that re-sends ``/tf_static``
    all the time holds thousands of copies of one transform)."""

    def __init__(self) -> None:
        self._parts: list[tuple[I64, F64, F64, F64]] = []  # stamps, trans, given q, unit q
        self._steps: tuple[I64, F64, F64, F64, F64] | None = None

    def add(self, t: I64, trans: F64, given: F64, unit: F64) -> None:
        self._parts.append((t.copy(), trans.copy(), given.copy(), unit.copy()))
        self._steps = None

    def _changes(self) -> tuple[I64, F64, F64, F64, F64]:
        """Stamps, translations, given and unit quaternions, and rotations R[k,3,3] where
        the value changes, in stamp order (one row when it never does: the last one)."""
        if self._steps is None:
            t, tr, given, unit = (np.concatenate(c) for c in zip(*self._parts, strict=True))
            self._parts = [(t, tr, given, unit)]
            order = np.lexsort((np.arange(len(t)), t))  # by stamp, then as given
            last = np.r_[t[order][1:] != t[order][:-1], True]  # the last given per stamp
            keep = order[last]
            value = np.concatenate([tr[keep], given[keep]], axis=1)
            change = np.r_[True, (value[1:] != value[:-1]).any(axis=1)]
            rows = keep[change] if change.sum() > 1 else keep[-1:]
            self._steps = (t[rows], tr[rows], given[rows], unit[rows], quat_to_matrix(unit[rows]))
        return self._steps

    def steps(self) -> list[tuple[int, F64, F64]]:
        """``(stamp, translation, quaternion as given)`` where the value changes: given to
        another edge's :meth:`add` they make the same transform at every time."""
        t, tr, given, _, _ = self._changes()
        return list(zip(t.tolist(), tr, given, strict=True))

    @property
    def varies(self) -> bool:
        return len(self._changes()[0]) > 1

    def batch(self, t: I64) -> TfBatch:
        stamps, tr, _, _, R = self._changes()
        if len(stamps) == 1:
            return TfBatch(R[0], tr[0], None)
        at = np.maximum(np.searchsorted(stamps, t, side="right") - 1, 0)
        return TfBatch(R[at], tr[at], np.ones(len(t), dtype=bool))
