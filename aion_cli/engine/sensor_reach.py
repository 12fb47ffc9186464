"""Which points a robot's poses had within ``sensor_range``: numpy only, the KD-tree's answers.

A window's coverage (:meth:`aion_cli.engine.observation.ObservationSource.robot_observed` and
``robot_exposure``) asks, per entry, whether some pose of the window lay within the sensor's
range, and how many of the window's steps did. A build closes every window that way, and a
query closes the open window the same way to count its latest detections. ``scipy.spatial``'s
cKDTree answered both; importing it cost a query of a patrolled map about 0.4 s CPU, more
than half of ``aion predict MAP --top 10`` (docs/BENCHMARKS.md, 2026-12-07). The functions here
give the tree's answers to the bit, measured and compared as the tree does in two dimensions:

* a pair's squared distance is ``d = fl(fl(dx·dx) + fl(dy·dy))`` with ``dx = fl(x₁ - x₂)``
  (the tree's sum of two squares: the same in either order, and the sign of ``dx`` is lost);
* :func:`any_within` is ``cKDTree(centres).query(points, k=1, distance_upper_bound=b)[0] <=
  r`` with ``b = nextafter(r, inf)``: the nearest centre with ``d < fl(b·b)`` (the tree's
  strict bound), its ``sqrt(d)`` at most ``r``; so a point exactly ``r`` away is in range;
* :func:`count_within` is ``cKDTree(centres).query_ball_point(points, b,
  return_length=True)``: the centres with ``d <= fl(b·b)`` (inclusive), duplicates counted.

Candidates: every pair when there are few (a few points at a time against every centre),
else the pairs of a point and a centre in the same or adjacent squares of a grid whose side is
a little more than ``b`` (:class:`~aion_cli.engine.square_grid.SquareGrid`: every pair in
range is among them), a block of points at a time; each candidate's ``d`` then decides, so
the answer does not depend on the candidates. A build's window of the simulated office takes
about as long as the tree's query did (0.5-0.6 ms), without the tree's import.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from aion_cli.engine.nearest import all_pairs
from aion_cli.engine.square_grid import SquareGrid
from aion_cli.engine.types import F64, I64, BoolA

_ALL_PAIRS = 1 << 16
"""Up to this many point-centre pairs, every pair is compared (no grid)."""
_BROADCAST = 1 << 13
"""Pairs compared at once when every pair is (small arrays: cheaper than one large one)."""
_POINTS_PER_BLOCK = 1 << 12
"""Points paired with the grid's centres at a time (bounds the candidate pairs held at once)."""
_PAIRS_PER_BLOCK = 1 << 20
"""Pairs compared at a time when the grid cannot be used (every pair of a block of points)."""


def any_within(points: F64, centres: F64, sensor_range: float) -> BoolA:
    """Per point (``[n, 2+]``, horizontal position first), whether some centre (``[m, 2]``)
    lies within ``sensor_range`` of it horizontally, the range's edge included: the cKDTree
    query's answer (module docstring)."""
    n = len(points)
    out = np.zeros(n, dtype=bool)
    bound = math.nextafter(float(sensor_range), math.inf)
    bound_sq = bound * bound
    for p, d in _candidates(points, centres, bound):
        ok = (d < bound_sq) & (np.sqrt(d) <= sensor_range)
        out[p[ok]] = True
    return out


def count_within(points: F64, centres: F64, sensor_range: float) -> I64:
    """Per point (``[n, 2+]``), how many centres (``[m, 2]``, repeats counted) lie within
    ``sensor_range`` of it horizontally, inclusive as the cKDTree ball query with the bound
    ``nextafter(sensor_range, inf)`` counted them (module docstring)."""
    n = len(points)
    out = np.zeros(n, dtype=np.int64)
    bound = math.nextafter(float(sensor_range), math.inf)
    bound_sq = bound * bound
    for p, d in _candidates(points, centres, bound):
        out += np.bincount(p[d <= bound_sq], minlength=n)
    return out


def _squared(points: F64, centres: F64, p: I64, j: I64) -> F64:
    """Each pair's squared horizontal distance, as the tree sums it."""
    dx = points[p, 0] - centres[j, 0]
    dy = points[p, 1] - centres[j, 1]
    out: F64 = dx * dx + dy * dy
    return out


def _candidates(points: F64, centres: F64, reach: float) -> Iterator[tuple[I64, F64]]:
    """Blocks of candidate pairs: (the point's index, the pair's squared distance). Every
    pair with ``d <= fl(reach·reach)`` is in some block."""
    n, m = len(points), len(centres)
    if n == 0 or m == 0:
        return
    if n * m <= _ALL_PAIRS:  # every pair, a few points at a time against all the centres
        step = max(1, _BROADCAST // m)
        for a in range(0, n, step):
            block = points[a : a + step]
            dx = block[:, 0, None] - centres[None, :, 0]
            dy = block[:, 1, None] - centres[None, :, 1]
            p = np.repeat(np.arange(a, a + len(block), dtype=np.int64), m)
            yield p, (dx * dx + dy * dy).reshape(-1)
        return
    grid = SquareGrid.of(centres, reach)
    step = _POINTS_PER_BLOCK if grid is not None else max(1, _PAIRS_PER_BLOCK // m)
    for a in range(0, n, step):
        block = points[a : a + step]
        p, j = all_pairs(len(block), m) if grid is None else grid.pairs(block)
        yield a + p, _squared(block, centres, p, j)
