"""Candidate pairs of points and centres near each other horizontally, from a grid of squares.

:class:`SquareGrid` sorts centres by the square (of a side a little more than a reach) they
lie in; a point's candidates are the centres of its own square and the eight around it, found
with a few ``searchsorted`` passes over all the points at once (no tree, no per-point loop, no
``scipy.spatial`` import). Every pair within the reach is among them; the caller measures the
candidates and decides. :mod:`aion_cli.engine.sensor_reach` (a window's robot coverage) and
:class:`aion_cli.engine.nearest.BindIndex` (the cells new at a bind check) ask it.
"""

from __future__ import annotations

import numpy as np

from aion_cli.engine.types import F64, I64

WIDER = 1.0 + 2.0**-20
"""The grid's side over the reach: the margin covers the rounding of the squares' indices."""
MAX_INDEX = 1 << 26
"""The grid is used while the centres span fewer squares than this per axis, so an index's
rounding (about 2^-52 of it) stays far below the side's margin; else every pair is compared."""


_ROWS = np.array([-1, 0, 1], dtype=np.int64)
"""The rows of squares around a point's own, as offsets of its row index."""


class SquareGrid:
    """The centres sorted by the square of side ``side`` they lie in, so each point's
    candidates are the centres of its own and the eight adjacent squares: three runs of the
    sorted keys (one per row of squares), found for all the points at once (pairs by point,
    then row, then key).

    Why every pair within the reach ``b`` is a candidate: a pair found within it (by a
    squared distance ``d <= fl(b·b)``, which bounds ``fl(dx·dx)`` by it, or by ``hypot``,
    which is at least ``|dx|``) has the true ``|x₁ - x₂| <= b·(1 + 3·2^-53)``; a square's
    index is ``floor(fl(fl(x - x0) / side))``, within ``2·2^-53·2^27`` of ``(x - x0) / side``
    for indices below :data:`MAX_INDEX` (points farther out are clipped to just beyond the
    grid, where no centre is); two indices then differ by less than ``(1 + 3·2^-53) / (1 +
    2^-20) + 2^-24 < 1`` before flooring, so their floors by at most one."""

    def __init__(self, origin: F64, side: float, top: I64, keys: I64, index: I64) -> None:
        self.origin, self.side, self.top = origin, side, top
        self.width = int(top[0]) + 5  # a row's keys never reach the next row's (ix in -3..top+3)
        self.keys, self.index = keys, index

    @classmethod
    def of(cls, centres: F64, reach: float) -> SquareGrid | None:
        """The grid of ``centres`` for pairs within ``reach``; None when the centres span too
        many squares of that side (a tiny range, far-flung poses): every pair is compared."""
        side = reach * WIDER
        finite = np.flatnonzero(np.isfinite(centres[:, :2]).all(axis=1))
        xy = centres[finite, :2]
        if xy.size == 0:  # no centre can be in range of anything
            return cls(np.zeros(2), 1.0, np.zeros(2, np.int64), np.zeros(0, np.int64), finite)
        origin = xy.min(axis=0)
        cells = np.floor((xy - origin) / side)
        if not (np.isfinite(side) and side > 0) or not float(cells.max()) < MAX_INDEX:
            return None
        ij = cells.astype(np.int64)
        top = ij.max(axis=0)
        grid = cls(origin, side, top, np.zeros(0, np.int64), finite)
        keys = ij[:, 1] * grid.width + ij[:, 0]
        order = np.argsort(keys, kind="stable")
        grid.keys, grid.index = keys[order], finite[order]
        return grid

    def pairs(self, points: F64) -> tuple[I64, I64]:
        """Candidate pairs (index into ``points``, index into the centres) of ``points``."""
        n = len(points)
        cells = np.floor((points[:, :2] - self.origin) / self.side)
        ok = np.isfinite(cells[:, 0]) & np.isfinite(cells[:, 1])
        # clipped to two squares beyond the grid: no centre lies next to those
        low, high = np.full(2, -2.0), self.top.astype(np.float64) + 2.0
        ij = np.where(ok[:, None], np.clip(cells, low, high), -2.0).astype(np.int64)
        # per point its three rows of squares, each a run of keys (the squares ix - 1 .. ix + 1)
        row = (ij[:, 1:2] + _ROWS) * self.width + ij[:, 0:1]  # [n, 3]
        lo = np.searchsorted(self.keys, row - 1, side="left")
        hi = np.searchsorted(self.keys, row + 1, side="right")
        count = np.where(ok[:, None], hi - lo, 0)
        flat = count.ravel()
        total = int(flat.sum())
        starts = np.repeat(lo.ravel() - (np.cumsum(flat) - flat), flat)
        p: I64 = np.repeat(np.arange(n, dtype=np.int64), count.sum(axis=1))
        j: I64 = self.index[starts + np.arange(total, dtype=np.int64)]
        return p, j
