"""People detections without track ids -> tracks, and tracks -> headings and speeds.

Many people detectors publish bare positions (leg detectors' ``PoseArray``s, the Lincoln
corridor dataset), but a walking direction needs to know which detection follows which. Two
steps, both pure numpy/scipy:

1. **Linking** (:func:`link_tracks`). Detections with the same ``t_ns`` are one *frame* (one
   message); frames are taken in time order. Every live track predicts where it is now from
   its last position and its (smoothed) velocity, assuming constant velocity; a detection may
   join a track if it lies within the gate ``max_speed * dt + gate_slack`` of that prediction
   (``dt`` = time since the track was last matched), and among all such pairs the globally
   cheapest one-to-one assignment (sum of distances, ``scipy.optimize.linear_sum_assignment``)
   wins. Detections left over start new tracks; a track unmatched for more than
   ``max_gap_s`` ends, so a person seen again after a longer gap gets a new id. A track takes
   at most one detection per frame, so a second detection of the same person in one frame
   (coarse time stamps that merge several scans, as in the Lincoln 2017-06-09 file) becomes
   a short track of its own instead of being averaged into — or stealing — a neighbour's
   track. The loop runs once per frame; the work per detection is array work.
2. **Differencing** (:func:`difference_tracks`). Each detection's velocity is the central
   difference between the nearest earlier and the nearest later point of its track that are
   at least ``min_step`` away from it (one-sided at a track's ends), so sensor noise on a slow
   walker does not turn into a random direction. A detection with no such point within
   ``heading_span_s`` either way (a standing person) has no heading (NaN); its speed is the
   plain neighbour difference (small, noisy), NaN for a single-detection track.
   With ``min_step = 0`` this is the plain neighbour difference of ``formats.tracks``
   (``finite_difference`` is this function).

Rows whose position is NaN or infinite take no part: ``track_id`` -1, heading and speed NaN.
Outputs are aligned with the input rows whatever their order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.errors import ConfigError, InputError
from aion_cli.engine.types import F64, I64, BoolA

_NS = 1e-9
_BIG = 1e12  # the cost of a pair outside the gate (never chosen over a gated pair)


@dataclass(frozen=True)
class LinkerConfig:
    """Parameters of :func:`link_tracks`; invalid values raise :class:`ConfigError`.

    - ``max_speed`` (m/s): the fastest a person moves; with ``gate_slack`` it sets the gate
      ``max_speed * dt + gate_slack`` around a track's predicted position, and it caps the
      velocity a track predicts with.
    - ``gate_slack`` (m): sensor noise allowance added to the gate, and the whole gate for
      ``dt = 0``.
    - ``max_gap_s`` (s): a track unmatched for longer ends (the next detection starts a new id).
    - ``min_step`` (m): headings come from displacements at least this long.
    - ``heading_span_s`` (s): how far in time differencing looks for a point ``min_step`` away;
      a detection with none within it either way is standing still (NaN heading).
    - ``velocity_smoothing`` (0 < a <= 1): a track's predicted velocity is
      ``a * last step + (1 - a) * previous velocity``; 1 uses the last step only. Smoothing
      keeps one noisy step from throwing the prediction (and the gate) off the person.
    """

    max_speed: float = 2.5
    gate_slack: float = 0.3
    max_gap_s: float = 2.0
    min_step: float = 0.3
    heading_span_s: float = 5.0
    velocity_smoothing: float = 0.5

    def __post_init__(self) -> None:
        checks = {
            "max_speed": self.max_speed > 0,
            "gate_slack": self.gate_slack >= 0,
            "max_gap_s": self.max_gap_s > 0,
            "min_step": self.min_step >= 0,
            "heading_span_s": self.heading_span_s > 0,
            "velocity_smoothing": 0 < self.velocity_smoothing <= 1,
        }
        for name, ok in checks.items():
            value = getattr(self, name)
            if not (ok and math.isfinite(value)):
                raise ConfigError(
                    f"track linking: invalid {name} = {value!r}",
                    hint="max_speed, max_gap_s, heading_span_s > 0; gate_slack, min_step >= 0; "
                    "0 < velocity_smoothing <= 1",
                )


@dataclass(frozen=True)
class TrackLinks:
    """:func:`link_tracks`' result, aligned with its input rows.

    ``track_id`` int64 (0, 1, ... in order of each track's first detection; -1 for a row
    with a non-finite position), ``heading`` float64 (rad, ``atan2(dy, dx)``, NaN if unknown),
    ``speed`` float64 (m/s, NaN if unknown).
    """

    track_id: I64
    heading: F64
    speed: F64

    @property
    def n_tracks(self) -> int:
        """Number of tracks found."""
        return int(self.track_id.max(initial=-1)) + 1


def _inputs(t_ns: npt.ArrayLike, xy: npt.ArrayLike) -> tuple[I64, F64]:
    """Checked copies: ``t_ns`` int64[n], ``xy`` float64[n, 2] (a third column, z, is ignored)."""
    t = np.asarray(t_ns)
    if t.ndim != 1 or not (t.dtype.kind in "iu" or t.size == 0):
        raise InputError(
            f"track linking needs integer nanosecond times of shape (n,), got {t.dtype} {t.shape}"
        )
    p = np.asarray(xy, dtype=np.float64)
    if p.size == 0 and len(t) == 0:
        p = p.reshape(0, 2)
    if p.ndim != 2 or p.shape[0] != len(t) or p.shape[1] not in (2, 3):
        raise InputError(
            f"track linking needs positions of shape ({len(t)}, 2) or ({len(t)}, 3), got {p.shape}"
        )
    return t.astype(np.int64, copy=False), p[:, :2]


def link_tracks(
    t_ns: npt.ArrayLike, xy: npt.ArrayLike, config: LinkerConfig | None = None
) -> TrackLinks:
    """Link detections (times ``t_ns`` int64 ns, positions ``xy`` [n, 2] or [n, 3] m) into
    tracks and give each its heading and speed (see the module docstring).

    The input need not be sorted; the result is aligned with the input rows. Raises
    :class:`InputError` for arrays of the wrong shape or dtype.
    """
    cfg = config or LinkerConfig()
    t, p = _inputs(t_ns, xy)
    n = len(t)
    track_id = np.full(n, -1, np.int64)
    heading = np.full(n, np.nan)
    speed = np.full(n, np.nan)
    rows = np.flatnonzero(np.isfinite(p).all(axis=1))
    if rows.size == 0:
        return TrackLinks(track_id, heading, speed)
    rows = rows[np.argsort(t[rows], kind="stable")]
    ts, ps = t[rows], p[rows]
    ids = _associate(ts, ps, cfg)
    h, s = difference_tracks(
        ts, ids, ps, min_step=cfg.min_step, max_span_ns=round(cfg.heading_span_s * 1e9)
    )
    track_id[rows], heading[rows], speed[rows] = ids, h, s
    return TrackLinks(track_id, heading, speed)


class _Tracks:
    """Every track's last time, position, velocity and match count, indexed by track id
    (ids are handed out in order, so one preallocated array per field suffices)."""

    def __init__(self, capacity: int) -> None:
        self.t: I64 = np.zeros(capacity, np.int64)
        self.xy: F64 = np.zeros((capacity, 2))
        self.v: F64 = np.zeros((capacity, 2))
        self.count: I64 = np.zeros(capacity, np.int64)
        self.next_id = 0

    def start(self, t: int, xy: F64) -> I64:
        """New tracks at the positions ``xy`` (stationary until matched); their ids."""
        a = self.next_id
        b = a + len(xy)
        self.t[a:b], self.xy[a:b], self.v[a:b], self.count[a:b] = t, xy, 0.0, 1
        self.next_id = b
        return np.arange(a, b, dtype=np.int64)

    def extend(self, ids: I64, t: int, xy: F64, dt_s: F64, cfg: LinkerConfig) -> None:
        """Tracks ``ids`` matched detections at ``xy``: new position, and a velocity smoothed
        over the steps and capped at ``max_speed``."""
        step = (xy - self.xy[ids]) / dt_s[:, None]
        a = np.where(self.count[ids] == 1, 1.0, cfg.velocity_smoothing)[:, None]
        v = a * step + (1.0 - a) * self.v[ids]
        fast = np.hypot(v[:, 0], v[:, 1]) / cfg.max_speed
        v /= np.maximum(fast, 1.0)[:, None]  # a person does not outrun max_speed
        self.v[ids], self.xy[ids], self.t[ids] = v, xy, t
        self.count[ids] += 1


def _frames(t_sorted: I64) -> tuple[list[int], list[int], list[int]]:
    """Start row, end row and stamp of each frame (run of equal times) of sorted times."""
    cut = np.flatnonzero(t_sorted[1:] != t_sorted[:-1]) + 1
    starts = np.concatenate([[0], cut])
    ends = np.concatenate([cut, [len(t_sorted)]])
    return starts.tolist(), ends.tolist(), t_sorted[starts].tolist()


def _associate(t: I64, xy: F64, cfg: LinkerConfig) -> I64:
    """Track ids of time-sorted finite detections: one pass over the frames."""
    from scipy.optimize import linear_sum_assignment

    ids = np.empty(len(t), np.int64)
    tracks = _Tracks(len(t))
    live = np.zeros(0, np.int64)
    gap_ns = round(cfg.max_gap_s * 1e9)
    for a, b, now in zip(*_frames(t), strict=True):
        det = xy[a:b]
        if live.size:
            last = tracks.t[live]
            alive = last >= now - gap_ns
            if not alive.all():
                live, last = live[alive], last[alive]
        if live.size == 0:
            ids[a:b] = live = tracks.start(now, det)
            continue
        dt_s = (now - last).astype(np.float64) * _NS
        pred = tracks.xy[live] + tracks.v[live] * dt_s[:, None]
        dist = np.hypot(pred[:, None, 0] - det[None, :, 0], pred[:, None, 1] - det[None, :, 1])
        gated = dist <= (cfg.max_speed * dt_s + cfg.gate_slack)[:, None]
        if live.size == 1 or b - a == 1:  # one row or column: the best gated pair is optimal
            flat = int(np.argmin(np.where(gated, dist, np.inf)))
            r, c = np.divmod(np.array([flat]), b - a)
        else:
            r, c = linear_sum_assignment(np.where(gated, dist, _BIG))
        keep = gated[r, c]
        r, c = r[keep], c[keep]
        matched = live[r]
        tracks.extend(matched, now, det[c], dt_s[r], cfg)
        ids[a + c] = matched
        if len(c) < b - a:
            rest = np.ones(b - a, dtype=bool)
            rest[c] = False
            new = tracks.start(now, det[rest])
            ids[a:b][rest] = new
            live = np.concatenate([live, new])
    return ids


# ----------------------------------------------------------------------------- differencing


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
    (NaN) and the neighbour difference as speed (NaN for a single-row track). Zero time steps
    give NaN. With ``min_step = 0`` this is the plain central / one-sided neighbour
    difference. Rows may come in any order; the outputs are aligned with them. Vectorized.
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
    h = np.where(moved, np.arctan2(v[:, 1], v[:, 0]), np.nan)
    heading[order], speed[order] = h, s
    return heading, speed
