"""Differencing: heading and speed per detection from the neighbouring samples of its track.

Step 2 of :mod:`aion_cli.engine.tracking` (see its docstring): :func:`difference_tracks` takes
rows that already have track ids -- from :func:`~aion_cli.engine.tracking.link_tracks`, or
from a file that carries them (``formats.track_csv``) -- and needs nothing of the linking, so
it lives apart from it. Pure numpy; ``engine.tracking`` re-exports :func:`difference_tracks`.
"""

from __future__ import annotations

import numpy as np

from aion_cli.engine.types import F64, I64, BoolA

_NS = 1e-9


def _track_bounds(tid: I64) -> tuple[I64, I64]:
    """First and last row of each row's track, for rows sorted by track."""
    n = len(tid)
    idx = np.arange(n)
    change = tid[1:] != tid[:-1]
    first = np.maximum.accumulate(np.where(np.r_[True, change], idx, 0))
    last = np.minimum.accumulate(np.where(np.r_[change, True], idx, n - 1)[::-1])[::-1]
    return first, last


def _far_neighbour(
    t: I64, xy: F64, start: I64, bound: I64, direction: int, min_step: float, span_ns: int | None
) -> I64:
    """Per row, the nearest row of its track in ``direction`` (-1 back, +1 forward), from
    ``start`` on and not past ``bound``, at least ``min_step`` away and at most ``span_ns``
    apart in time; -1 where there is none. Rows that stand still search one more row per
    round, vectorized over all of them (walkers are usually resolved by ``start``)."""
    n = len(t)
    found = np.full(n, -1, np.int64)
    cand = start.copy()
    rows = np.flatnonzero((cand - bound) * direction <= 0)
    limit = min_step * min_step
    while rows.size:
        j = cand[rows]
        if span_ns is not None:
            near = np.abs(t[j] - t[rows]) <= span_ns
            rows, j = rows[near], j[near]
        d = xy[j] - xy[rows]
        with np.errstate(over="ignore"):  # a step of 1e300 m is far (inf), not a warning
            far = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] >= limit
        found[rows[far]] = j[far]
        rows, j = rows[~far], j[~far] + direction
        cand[rows] = j
        rows = rows[(j - bound[rows]) * direction <= 0]
    return found


def _velocity(t: I64, xy: F64, a: I64, b: I64) -> tuple[F64, BoolA]:
    """Velocity from row ``a`` to row ``b`` (per row), and where it is defined (dt > 0)."""
    dt = (t[b] - t[a]) * _NS
    ok = dt > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        v = (xy[b] - xy[a]) / dt[:, None]
    return v, ok


def difference_tracks(
    t_ns: I64,
    track_id: I64,
    xy: F64,
    min_step: float = 0.0,
    max_span_ns: int | None = None,
) -> tuple[F64, F64]:
    """Heading (rad) and speed (m/s) per row from each track's neighbouring samples.

    For each row, ``p`` is the nearest earlier and ``q`` the nearest later row of the same
    ``track_id`` (any int64 value is a track label) whose position is at least ``min_step``
    away, looking at most ``max_span_ns`` away in time (``None``: the whole track). The
    velocity is the central difference ``(xy[q] - xy[p]) / (t[q] - t[p])`` when both exist,
    else the one-sided difference to the one that does. Rows with neither have no heading
    (NaN) and the neighbour difference as speed (NaN for a single-row track), and so do rows
    whose neighbours stand where they do (speed 0: no direction). Zero time steps give NaN.
    With ``min_step = 0`` this is the plain central / one-sided neighbour difference. Rows may
    come in any order; the outputs are aligned with them. Vectorized.
    """
    n = len(t_ns)
    heading = np.full(n, np.nan)
    speed = np.full(n, np.nan)
    if n == 0:
        return heading, speed
    order = np.lexsort((t_ns, track_id))
    t, p = t_ns[order], xy[order, :2]
    first, last = _track_bounds(track_id[order])
    idx = np.arange(n)
    # path length along each track: no point nearer (in path length) than min_step is far
    # enough, so the search can start at the first row with enough path in between
    step = np.hypot(*(p[1:] - p[:-1]).T)
    step[first[1:] == idx[1:]] = 0.0
    path = np.concatenate([[0.0], np.cumsum(step)])
    reach = max(min_step - 1e-9, 0.0)  # (a little short: the cumulative sum rounds)
    back = np.minimum(np.searchsorted(path, path - reach, side="right") - 1, idx - 1)
    ahead = np.maximum(np.searchsorted(path, path + reach, side="left"), idx + 1)
    prev = _far_neighbour(t, p, back, first, -1, min_step, max_span_ns)
    nxt = _far_neighbour(t, p, ahead, last, +1, min_step, max_span_ns)
    has_p, has_n = prev >= 0, nxt >= 0
    a = np.where(has_p, prev, idx)
    b = np.where(has_n, nxt, idx)
    v, ok = _velocity(t, p, a, b)
    moved = (has_p | has_n) & ok
    s = np.where(moved, np.hypot(v[:, 0], v[:, 1]), np.nan)
    still = np.flatnonzero(~(has_p | has_n))
    if still.size:  # standing: speed from the immediate neighbours, no heading
        sa = np.where(first[still] < still, still - 1, still)
        sb = np.where(last[still] > still, still + 1, still)
        sv, sok = _velocity(t, p, sa, sb)
        s[still[sok]] = np.hypot(sv[sok, 0], sv[sok, 1])
    # no displacement between the neighbours (a person standing, min_step 0): speed 0 and no
    # heading, not atan2(0, 0) = 0, a walk due east
    went = moved & ((v[:, 0] != 0.0) | (v[:, 1] != 0.0))
    h = np.where(went, np.arctan2(v[:, 1], v[:, 0]), np.nan)
    heading[order], speed[order] = h, s
    return heading, speed
