"""Lookups of a :class:`formats.tf.TfBuffer`: its stored edges interpolated and composed at
query times, and points, vectors and trajectories moved between frames with them.

:class:`TfLookup` is the part of the buffer that answers ``target_T_source`` at many times
(:meth:`TfLookup.lookup`: each dynamic edge interpolated between its bracketing samples like
tf2's ``TimeCache::interpolate``, the chain composed edge by edge over blocks of query times)
and what is built on it. It is apart from :mod:`formats.tf`, which ingests transforms and finds
the chain between two frames, because it only reads what the buffer stored: the edges
(``_dynamic``, ``_static``), the tolerances and the chain (``_path``), declared below.
"""

from __future__ import annotations

import itertools

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, I64, BoolA, Trajectory
from aion_cli.errors import TransformError
from aion_cli.formats.quaternions import quat_to_matrix, slerp
from aion_cli.formats.raw import normalize_frame
from aion_cli.formats.tf_parts import EdgeSeries, StaticEdge, TfBatch


class TfLookup:
    """The lookups of :class:`formats.tf.TfBuffer` (its base class; see the module docstring)."""

    tolerance_ns: int
    max_gap_ns: float
    block_rows: int
    _dynamic: dict[tuple[str, str], EdgeSeries]
    _static: dict[tuple[str, str], StaticEdge]

    def _path(self, target: str, source: str) -> list[str]:
        """Frames from target to source (inclusive): :meth:`formats.tf.TfBuffer._path`."""
        raise NotImplementedError

    def _edge(self, parent: str, child: str, t: I64) -> TfBatch:
        """``parent_T_child`` at times ``t`` (a single transform for a static edge)."""
        series = self._dynamic.get((parent, child))
        if series is None or series.n == 0:
            return self._static[(parent, child)].batch(t)
        stamps, trans, quats = series.arrays()
        first, last = stamps[0], stamps[-1]
        ok = (t >= first - self.tolerance_ns) & (t <= last + self.tolerance_ns)
        tc = np.minimum(np.maximum(t, first), last)  # within tolerance: the end sample
        hi = np.searchsorted(stamps, tc, side="left")  # first stamp >= tc, always valid
        lo = np.maximum(hi - 1, 0)  # at a sample stamp alpha is 1 (or span 0): the sample
        span = (stamps[hi] - stamps[lo]).astype(np.float64)
        # in a gap over max_gap_ns: only within tolerance of a sample, then that sample
        before, after, long_gap = tc - stamps[lo], stamps[hi] - tc, span > self.max_gap_ns
        ok &= ~long_gap | (np.minimum(before, after) <= self.tolerance_ns)
        alpha = np.where(long_gap, after < before, before / np.where(span > 0, span, 1.0))
        tr_out = trans[lo] + alpha[:, None] * (trans[hi] - trans[lo])
        return TfBatch(quat_to_matrix(slerp(quats[lo], quats[hi], alpha)), tr_out, ok)

    def _step(self, a: str, b: str, t: I64) -> TfBatch:
        """``a_T_b`` for neighbouring frames, inverting the stored edge when b is a's parent."""
        if (a, b) in self._dynamic or (a, b) in self._static:
            return self._edge(a, b, t)
        return self._edge(b, a, t).inverse()

    def lookup(self, target: str, source: str, t_ns: npt.ArrayLike) -> tuple[F64, F64, BoolA]:
        """``target_T_source`` at each time: (R f64[n,3,3], t f64[n,3], ok bool[n]).

        ``p_target = R @ p_source + t``. Rows with ``ok == False`` (outside a dynamic edge's
        recorded range plus tolerance) are NaN.

        Memory is bounded: the chain is composed edge by edge (never every edge's transforms
        at once) over blocks of at most ``block_rows`` query times, so a lookup costs the
        output plus about 1 KB per block row whatever the chain's length (a 1,000-frame chain
        queried at its 10,000 sample times needed about 1 GB when every step was held).
        """
        t = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
        n = len(t)
        path = self._path(normalize_frame(target), normalize_frame(source))
        pairs = list(itertools.pairwise(path))
        if not any(self._is_dynamic(a, b) for a, b in pairs):  # an all-static chain
            total = self._compose(pairs, t[:0])
            R = np.broadcast_to(total.R, (n, 3, 3)).copy()
            return R, np.broadcast_to(total.t, (n, 3)).copy(), np.ones(n, dtype=bool)
        R = np.empty((n, 3, 3))
        tr = np.empty((n, 3))
        ok = np.empty(n, dtype=bool)
        for start in range(0, n, self.block_rows):
            rows = slice(start, start + self.block_rows)
            total = self._compose(pairs, t[rows])
            R[rows], tr[rows] = total.R, total.t  # a static product broadcasts
            ok[rows] = True if total.ok is None else total.ok
        R[~ok] = np.nan
        tr[~ok] = np.nan
        return R, tr, ok

    def _is_dynamic(self, a: str, b: str) -> bool:
        """The edge between neighbouring frames a and b has time-varying samples (or static
        transforms whose value changed)."""
        for key in ((a, b), (b, a)):
            series = self._dynamic.get(key)
            if series is not None and series.n > 0:
                return True
            edge = self._static.get(key)
            if edge is not None and edge.varies:
                return True
        return False

    def _compose(self, pairs: list[tuple[str, str]], t: I64) -> TfBatch:
        """``path[0]_T_path[-1]`` at times ``t``: the steps composed left to right as each is
        computed, so only the running product and one step are alive."""
        total: TfBatch | None = None
        for a, b in pairs:
            step = self._step(a, b, t)
            total = step if total is None else total.compose(step)
        return total if total is not None else TfBatch(np.eye(3), np.zeros(3), None)

    def _lookup_rows(
        self, target: str, source: str, t_ns: npt.ArrayLike, n: int
    ) -> tuple[F64, F64, BoolA]:
        """Lookup for n rows; one scalar time is looked up once and broadcast."""
        t = np.asarray(t_ns, dtype=np.int64)
        if t.ndim == 0 or len(t) == 1:
            R, tr, ok = self.lookup(target, source, t.reshape(1))
            ok_n = np.broadcast_to(ok, (n,))
            return np.broadcast_to(R, (n, 3, 3)), np.broadcast_to(tr, (n, 3)), ok_n
        if len(t) != n:
            raise TransformError(f"got {len(t)} times for {n} rows")
        return self.lookup(target, source, t)

    def transform_points(
        self, target: str, source: str, t_ns: npt.ArrayLike, xyz: npt.ArrayLike
    ) -> tuple[F64, BoolA]:
        """Points float64[n,3] from ``source`` into ``target`` at their times; NaN where not ok."""
        p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        R, tr, ok = self._lookup_rows(target, source, t_ns, len(p))
        return np.einsum("nij,nj->ni", R, p) + tr, np.array(ok)

    def transform_vectors(
        self, target: str, source: str, t_ns: npt.ArrayLike, vec: npt.ArrayLike
    ) -> tuple[F64, BoolA]:
        """Free vectors (e.g. velocities) rotated from ``source`` into ``target``."""
        v = np.asarray(vec, dtype=np.float64).reshape(-1, 3)
        R, _, ok = self._lookup_rows(target, source, t_ns, len(v))
        return np.einsum("nij,nj->ni", R, v), np.array(ok)

    def trajectory(
        self, map_frame: str, base_frame: str, t_ns: npt.ArrayLike | None = None
    ) -> Trajectory:
        """Positions of ``base_frame``'s origin in ``map_frame``.

        Times: ``t_ns`` if given, else every sample stamp of the dynamic edges on the chain
        (empty for an all-static chain). Times that cannot be transformed are left out.
        """
        target, source = normalize_frame(map_frame), normalize_frame(base_frame)
        if t_ns is None:
            path = self._path(target, source)
            stamps = [
                self._dynamic[key].arrays()[0]
                for a, b in itertools.pairwise(path)
                for key in ((a, b), (b, a))
                if key in self._dynamic
            ]
            times = np.unique(np.concatenate(stamps)) if stamps else np.zeros(0, np.int64)
        else:
            times = np.unique(np.asarray(t_ns, dtype=np.int64).reshape(-1))
        if len(times) == 0:
            self._path(target, source)  # still report unknown frames
            return Trajectory.empty()
        _, tr, ok = self.lookup(target, source, times)
        return Trajectory(times[ok], np.ascontiguousarray(tr[ok]))
