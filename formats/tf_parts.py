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
    over at its stamp, and a time before the first stamp takes the first."""

    def __init__(self) -> None:
        # stamp -> (translation, quaternion as given, unit quaternion)
        self.given: dict[int, tuple[F64, F64, F64]] = {}
        self._steps: tuple[I64, F64, F64] | None = None

    def add(self, t: I64, trans: F64, given: F64, unit: F64) -> None:
        for k, stamp in enumerate(t.tolist()):
            self.given[stamp] = (trans[k].copy(), given[k].copy(), unit[k].copy())
        self._steps = None

    def steps(self) -> tuple[I64, F64, F64]:
        """Stamps, rotations R[k,3,3] and translations t[k,3] where the value changes (one
        row when it never does: the last one given)."""
        if self._steps is None:
            stamps = sorted(self.given)
            rows = [self.given[s] for s in stamps]
            keep = [0]
            for k in range(1, len(rows)):
                a, b = rows[keep[-1]], rows[k]
                if not (np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])):
                    keep.append(k)
            if len(keep) == 1:
                keep = [len(rows) - 1]
            unit = np.array([rows[k][2] for k in keep])
            self._steps = (
                np.array([stamps[k] for k in keep], dtype=np.int64),
                quat_to_matrix(unit),
                np.array([rows[k][0] for k in keep]),
            )
        return self._steps

    @property
    def varies(self) -> bool:
        return len(self.steps()[0]) > 1

    def batch(self, t: I64) -> TfBatch:
        stamps, R, tr = self.steps()
        if len(stamps) == 1:
            return TfBatch(R[0], tr[0], None)
        at = np.maximum(np.searchsorted(stamps, t, side="right") - 1, 0)
        return TfBatch(R[at], tr[at], np.ones(len(t), dtype=bool))
