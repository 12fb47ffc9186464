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
   :func:`difference_linked` is this rule with the linker's parameters, which
   ``formats.track_csv`` also gives the tracks of files without a direction column. With
   ``min_step = 0`` it is the plain neighbour difference (``finite_difference`` there).
   :func:`difference_tracks` lives in :mod:`aion_cli.engine.differencing` and is re-exported
   here.

Rows whose position is NaN or infinite take no part: ``track_id`` -1, heading and speed NaN.
Outputs are aligned with the input rows whatever their order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.differencing import _NS, difference_tracks
from aion_cli.engine.row_masks import all_columns
from aion_cli.engine.types import F64, I64
from aion_cli.errors import ConfigError, InputError

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
    rows = np.flatnonzero(all_columns(np.isfinite(p)))
    if rows.size == 0:
        return TrackLinks(track_id, heading, speed)
    rows = rows[np.argsort(t[rows], kind="stable")]
    ts, ps = t[rows], p[rows]
    ids = TrackLinker(cfg).link(ts, ps)  # the build's linker: one association for both
    h, s = difference_linked(ts, ids, ps, cfg)
    track_id[rows], heading[rows], speed[rows] = ids, h, s
    return TrackLinks(track_id, heading, speed)


def difference_linked(
    t_ns: I64, track_id: I64, xy: F64, config: LinkerConfig | None = None
) -> tuple[F64, F64]:
    """Heading and speed per row by the linker's own rule (:func:`difference_tracks` with
    ``config``'s ``min_step`` and ``heading_span_s``): what :func:`link_tracks` gives its
    tracks, and what files with their own track ids but no direction (ETH/UCY, Edinburgh)
    get, so that a person standing in sensor noise has no heading in either."""
    cfg = config or LinkerConfig()
    return difference_tracks(
        t_ns, track_id, xy, min_step=cfg.min_step, max_span_ns=round(cfg.heading_span_s * 1e9)
    )


def _frames(t_sorted: I64) -> tuple[list[int], list[int], list[int]]:
    """Start row, end row and stamp of each frame (run of equal times) of sorted times."""
    cut = np.flatnonzero(t_sorted[1:] != t_sorted[:-1]) + 1
    starts = np.concatenate([[0], cut])
    ends = np.concatenate([cut, [len(t_sorted)]])
    return starts.tolist(), ends.tolist(), t_sorted[starts].tolist()


# ----------------------------------------------------------------------------- incremental


class TrackLinker:
    """The association of step 1 (the module docstring), one chunk of detections at a time: a
    log's stream is decoded in chunks of messages, and tracks must carry over from one chunk
    to the next. It is the one linker: the build (``aion_cli.detection_feed``) and
    :func:`link_tracks` (``aion convert``'s datasets without ids) both call it, so the same
    rows give the same tracks on either path.

    :meth:`link` takes the next detections (times need not be sorted within a chunk; a frame
    is a run of equal times, i.e. one message), associates them frame by frame with the live
    tracks, and returns their track ids, unique over the linker's life (0, 1, ... in order of
    each track's first detection; -1 for a non-finite position).
    Linking a stream in chunks that end between frames gives the ids linking it at once gives;
    a chunk that ends inside a frame (two messages of one stamp) still gives each track at
    most one detection of that frame.

    Only live tracks are kept (preallocated arrays of their id, last time, position, velocity
    and match count; ended tracks are compacted away), so memory follows the people in view,
    not the length of the log. The work per frame is array work over live tracks x
    detections: squared distances against each track's gate, then the optimal assignment
    (``linear_sum_assignment``) only over the tracks and detections that have a pair inside a
    gate -- and none where every gated pair is unambiguous.

    Frames older than a track's last detection (stamps that jitter across chunks) are gated
    as if no time had passed (``dt = 0``: the gate is ``gate_slack``, the velocity unchanged).
    """

    def __init__(self, config: LinkerConfig | None = None, capacity: int = 64) -> None:
        self.config = config or LinkerConfig()
        self._gap_ns = round(self.config.max_gap_s * 1e9)
        cap = max(int(capacity), 1)
        self._ids: I64 = np.zeros(cap, np.int64)
        self._t: I64 = np.zeros(cap, np.int64)
        self._xy: F64 = np.zeros((cap, 2))
        self._v: F64 = np.zeros((cap, 2))
        self._count: I64 = np.zeros(cap, np.int64)
        self._n = 0
        self.next_id = 0
        self._last_now: int | None = None  # the last stamp of the previous call

    def __len__(self) -> int:
        """Number of live tracks."""
        return self._n

    @property
    def ids(self) -> I64:
        """Ids of the live tracks."""
        return self._ids[: self._n]

    @property
    def v(self) -> F64:
        """Predicted velocities (m/s) of the live tracks."""
        return self._v[: self._n]

    def link(self, t_ns: npt.ArrayLike, xy: npt.ArrayLike) -> I64:
        """Track ids of the next detections (``t_ns`` int64 ns, ``xy`` [n, 2] or [n, 3] m),
        aligned with the input rows; :class:`InputError` for arrays of the wrong shape."""
        t, p = _inputs(t_ns, xy)
        out = np.full(len(t), -1, np.int64)
        rows = np.flatnonzero(all_columns(np.isfinite(p)))
        if rows.size == 0:
            return out
        if rows.size > 1 and not bool(np.all(t[rows][1:] >= t[rows][:-1])):
            rows = rows[np.argsort(t[rows], kind="stable")]
        ts, ps = t[rows], p[rows]
        ids = np.empty(len(rows), np.int64)
        frame = self._frame
        with np.errstate(over="ignore"):  # positions far out (1e300 m) are no match: inf
            for a, b, now in zip(*_frames(ts), strict=True):
                ids[a:b] = frame(now, ps[a:b])
        self._last_now = int(ts[-1])
        out[rows] = ids
        return out

    def _frame(self, now: int, det: F64) -> I64:
        """Associate one frame's detections with the live tracks (the module docstring, step 1)."""
        cfg = self.config
        n = self._n
        if n and np.minimum.reduce(self._t[:n]) < now - self._gap_ns:  # some track ended
            self._keep(self._t[:n] >= now - self._gap_ns)
            n = self._n
        m = len(det)
        if n == 0:
            return self._start(now, det)
        dt_s = np.maximum(now - self._t[:n], 0).astype(np.float64) * _NS
        pred = self._xy[:n] + self._v[:n] * dt_s[:, None]
        # (the caller, link, ignores overflow: positions far out (1e300 m) are no match: inf)
        dx = pred[:, 0, None] - det[:, 0]
        dy = pred[:, 1, None] - det[:, 1]
        dx *= dx
        dy *= dy
        d2 = dx
        d2 += dy
        gate = cfg.max_speed * dt_s + cfg.gate_slack
        gate *= gate
        gated = d2 <= gate[:, None]
        if now == self._last_now:  # the rest of the previous call's last frame (a message of
            gated &= (self._t[:n] != now)[:, None]  # the same stamp): a track takes one of it
        rows_in = np.logical_or.reduce(gated, axis=1).nonzero()[0]
        if rows_in.size == 0:
            return self._start(now, det)
        cols_in = np.logical_or.reduce(gated, axis=0).nonzero()[0]
        if rows_in.size == cols_in.size == np.count_nonzero(gated):
            r, c = np.nonzero(gated)  # every gated pair is the only one of its row and column
        else:
            r, c = self._assign(gated, d2, rows_in, cols_in)
        out = np.empty(m, np.int64)
        out[c] = self._ids[r]
        self._extend(r, now, det[c], dt_s[r])
        if len(c) < m:
            rest = np.ones(m, dtype=bool)
            rest[c] = False
            out[rest] = self._start(now, det[rest])
        return out

    @staticmethod
    def _assign(
        gated: npt.NDArray[np.bool_], d2: F64, rows_in: I64, cols_in: I64
    ) -> tuple[I64, I64]:
        """Track rows and detection columns matched: the cheapest one-to-one assignment of
        gated pairs (most pairs first, then the least total distance), solved only over the
        rows and columns that have a gated pair."""
        pick = (rows_in[:, None], cols_in)
        sub = gated[pick]
        dist = np.sqrt(d2[pick])
        if len(rows_in) == 1 or len(cols_in) == 1:  # the best gated pair is optimal
            flat = int(np.argmin(np.where(sub, dist, np.inf)))
            r, c = np.divmod(np.array([flat]), len(cols_in))
        else:
            from scipy.optimize import linear_sum_assignment

            r, c = linear_sum_assignment(np.where(sub, dist, _BIG))
            keep = sub[r, c]
            r, c = r[keep], c[keep]
        return rows_in[r], cols_in[c]

    def _keep(self, mask: npt.NDArray[np.bool_]) -> None:
        """Compact the live tracks to those of ``mask`` (their order kept)."""
        keep = mask.nonzero()[0]
        k = len(keep)
        for arr in (self._ids, self._t, self._count, self._xy, self._v):
            arr[:k] = arr[keep]
        self._n = k

    def _start(self, now: int, xy: F64) -> I64:
        """New tracks at ``xy`` (stationary until matched), appended to the live ones."""
        k = len(xy)
        a, b = self._n, self._n + k
        if b > len(self._ids):
            self._grow(b)
        new = np.arange(self.next_id, self.next_id + k, dtype=np.int64)
        self.next_id += k
        self._ids[a:b], self._t[a:b], self._xy[a:b] = new, now, xy
        self._v[a:b], self._count[a:b] = 0.0, 1
        self._n = b
        return new

    def _grow(self, needed: int) -> None:
        cap = max(needed, 2 * len(self._ids))
        for name in ("_ids", "_t", "_count", "_xy", "_v"):
            old = getattr(self, name)
            arr = np.zeros((cap, *old.shape[1:]), old.dtype)
            arr[: self._n] = old[: self._n]
            setattr(self, name, arr)

    def _extend(self, rows: I64, now: int, xy: F64, dt_s: F64) -> None:
        """Live rows ``rows`` matched detections at ``xy``: new position, and a velocity
        smoothed over the steps (the first step taken whole) and capped at ``max_speed``; a
        zero time step keeps the velocity."""
        cfg = self.config
        old_v = self._v[rows]
        count = self._count[rows]
        if np.count_nonzero(dt_s) == len(dt_s):  # dt_s >= 0: every track moved on in time
            step = (xy - self._xy[rows]) / dt_s[:, None]
        else:
            moved = dt_s > 0
            step = (xy - self._xy[rows]) / np.where(moved, dt_s, 1.0)[:, None]
            step[~moved] = old_v[~moved]
        a = np.where(count == 1, 1.0, cfg.velocity_smoothing)[:, None]
        step -= old_v
        step *= a
        v = old_v + step
        speed2 = np.einsum("ij,ij->i", v, v)
        too_fast = speed2 > cfg.max_speed * cfg.max_speed
        if np.count_nonzero(too_fast):  # a person does not outrun max_speed
            v[too_fast] *= (cfg.max_speed / np.sqrt(speed2[too_fast]))[:, None]
        self._v[rows], self._xy[rows], self._t[rows] = v, xy, now
        self._count[rows] = count + 1  # rows are distinct


__all__ = ["LinkerConfig", "TrackLinker", "TrackLinks", "difference_tracks", "link_tracks"]
