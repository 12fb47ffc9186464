"""Which entries a sensor observed in a time window.

Two sources: the robot trajectory (an entry is observed in a window if it lies within
``sensor_range`` metres, horizontally, of any robot pose inside that window) and fixed-sensor
intervals (every entry is observed in any window that overlaps the interval). Observed-but-empty
windows become real zeros for the temporal model; windows no source covers teach nothing.

Poses are kept until the windows they fall in are closed (:meth:`prune`), so a trajectory may be
given before, with or after the detections of the open window.

**Exposure.** A robot that passes a place for twenty seconds of a ten-minute window sees a
thirtieth of the people who walk there in that window. Counting the window whole would put the
place's rate at a thirtieth of the truth, and rank places by how long the robot lingered rather
than by how busy they are. :meth:`ObservationSource.robot_exposure` measures, per entry, the
fraction of the window in which it lay within ``sensor_range`` of the robot: the window is cut
into :data:`SUBSTEPS` equal steps, each step takes the robot pose of the window nearest its
middle in time (if one lies within :data:`POSE_HOLD_NS` or half a step), and an entry's exposure
is the share of steps whose pose had it in range, but at least a floor
(``ModelConfig.exposure_floor``, 0.2): an entry the coverage test observes (a pose in the window
within range) gets at least that, so exactly the same entries are observed as before; the
temporal model then weighs each robot window by its exposure (a rate per full window =
detections / exposure). The floor trades a little bias for much less variance: a ten-second look
that caught three detections would otherwise read as 180 per window. Measured on the simulated
office (``docs/EVALUATION.md``), floors of 0.2 and 0.3 forecast the true flow best, 1/60 (no
floor) and 1 (whole windows) worst. Only the window's own poses count, as for
:meth:`ObservationSource.robot_observed`: a build prunes the poses of closed windows (a parallel
build's shard keeps them), and the poses after a window may or may not have been read when it
closes, so a pose across the boundary made the exposure depend on how the logs were read.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.row_masks import all_columns
from aion_cli.engine.sensor_reach import any_within, count_within
from aion_cli.engine.types import F64, I64, BoolA, Trajectory
from aion_cli.engine.windows import window_index
from aion_cli.errors import InputError

if TYPE_CHECKING:
    from aion_cli.engine.config import ModelConfig

SUBSTEPS = 60
"""Steps a window is cut into to measure exposure (10 s steps in a 10-minute window)."""
POSE_HOLD_NS = 30 * 10**9
"""How long a robot pose stands for its position when no pose of the window lies nearer in
time: 30 s, so a trajectory sampled every minute or faster covers every step between the
window's first and last pose and half a minute beyond them (the robot's last pose before a
recording stops covers half a minute after it)."""


@dataclass
class ObservationSource:
    """Pending robot poses (sorted by time) and fixed-sensor intervals ``[start, end)`` in ns."""

    pose_t: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    pose_xy: F64 = field(default_factory=lambda: np.zeros((0, 2)))
    fixed_start: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    fixed_end: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    # the fixed-sensor intervals merged into sorted disjoint ones (built on first use)
    _merged: tuple[I64, I64] | None = field(default=None, init=False, repr=False, compare=False)
    _covered: I64 | None = field(default=None, init=False, repr=False, compare=False)

    def add_trajectory(self, trajectory: Trajectory) -> None:
        """Add robot poses; non-finite poses are ignored (they cannot say what was seen)."""
        t = np.asarray(trajectory.t_ns, dtype=np.int64).reshape(-1)
        xyz = np.asarray(trajectory.xyz, dtype=np.float64).reshape(-1, 3)
        if len(t) != len(xyz):
            raise InputError(f"trajectory has {len(t)} times but {len(xyz)} positions")
        ok = all_columns(np.isfinite(xyz[:, :2]))
        t_all = np.concatenate([self.pose_t, t[ok]])
        xy_all = np.concatenate([self.pose_xy, xyz[ok, :2]])
        order = np.argsort(t_all, kind="stable")
        self.pose_t, self.pose_xy = t_all[order], xy_all[order]

    def set_fixed_sensor(self, start_ns: int, end_ns: int) -> None:
        """Declare ``[start_ns, end_ns)`` observed everywhere (a fixed sensor, or no trajectory)."""
        if int(end_ns) < int(start_ns):
            raise InputError(f"fixed-sensor interval ends before it starts ({start_ns}, {end_ns})")
        self.fixed_start = np.append(self.fixed_start, np.int64(start_ns))
        self.fixed_end = np.append(self.fixed_end, np.int64(end_ns))
        self._merged = None

    def add_fixed_windows(
        self, windows: I64, delta_ns: int, within: tuple[I64, I64] | None = None
    ) -> None:
        """Declare windows observed everywhere: each run of consecutive windows becomes one
        fixed-sensor interval. ``within``: spans ``[start, end)`` of log time the sensor
        recorded (each log's first to last message, declared spans): each window is cut to
        the parts of it they cover, so a log that starts or ends inside a window observed only
        that part (:meth:`fixed_share`); a window no span reaches stays whole."""
        w = np.unique(np.asarray(windows, dtype=np.int64))
        if w.size == 0:
            return
        if within is not None and np.asarray(within[0]).size:
            starts, stops = _cut_windows(w, np.int64(delta_ns), *within)
            self.fixed_start = np.concatenate([self.fixed_start, starts])
            self.fixed_end = np.concatenate([self.fixed_end, stops])
            self._merged = None
            return
        breaks = np.flatnonzero(np.diff(w) > 1)
        starts = np.concatenate([w[:1], w[breaks + 1]])
        stops = np.concatenate([w[breaks], w[-1:]]) + 1
        self.fixed_start = np.concatenate([self.fixed_start, starts * np.int64(delta_ns)])
        self.fixed_end = np.concatenate([self.fixed_end, stops * np.int64(delta_ns)])
        self._merged = None

    def merged_fixed(self) -> tuple[I64, I64]:
        """The fixed-sensor intervals as sorted, disjoint ``[start, end)`` intervals (empty
        ones left out), so a window's coverage is one binary search instead of a pass over
        every interval (a long log with gaps has one interval per run of recorded windows)."""
        if self._merged is None:
            self._merged = merged_spans(self.fixed_start, self.fixed_end)
            self._covered = None
        return self._merged

    def _covered_before(self) -> I64:
        """Per merged interval, the time the intervals before it cover (one more entry: all
        of them), kept with the merged intervals: :meth:`fixed_share` runs at every window a
        build closes."""
        starts, ends = self.merged_fixed()
        if self._covered is None:
            self._covered = np.concatenate([[0], np.cumsum(ends - starts)]).astype(np.int64)
        return self._covered

    def prune(self, before_ns: int) -> None:
        """Forget poses before ``before_ns`` (their windows are closed). The poses are sorted,
        so they are the first ones: one binary search and views of the rest, nothing copied
        (a build prunes at every window it closes, with perhaps a whole log's trajectory
        pending: a mask and a copy of it cost a millisecond each time; the poses are never
        written in place, :meth:`add_trajectory` makes new arrays)."""
        cut = int(np.searchsorted(self.pose_t, np.int64(before_ns), side="left"))
        if cut:
            self.pose_t, self.pose_xy = self.pose_t[cut:], self.pose_xy[cut:]

    def covered_windows(self, first: int, stop: int, delta_ns: int) -> I64:
        """Sorted windows in ``[first, stop)`` covered by a pose or a fixed-sensor interval.

        Costs O(log n + covered windows): poses are sorted and the intervals merged, so a long
        gap between recordings is skipped by binary search, never walked window by window."""
        lo, hi = int(first) * delta_ns, int(stop) * delta_ns
        i0, i1 = np.searchsorted(self.pose_t, [lo, hi], side="left")
        starts, ends = self.merged_fixed()
        k0 = int(np.searchsorted(ends, lo, side="right"))  # first interval ending after lo
        k1 = int(np.searchsorted(starts, hi, side="left"))  # intervals starting before hi
        if stop - first == 1:  # one window (a build's usual step): covered or not
            covered = i1 > i0 or k1 > k0
            return np.array([first] if covered else [], np.int64)
        poses = window_index(self.pose_t[i0:i1], delta_ns)  # sorted: the poses are
        parts = [poses[np.concatenate([[True], poses[1:] != poses[:-1]])] if poses.size else poses]
        if k1 > k0:
            w0 = np.maximum(starts[k0:k1] // delta_ns, first)
            w1 = np.minimum(-((-ends[k0:k1]) // delta_ns), stop)  # ceil(e / Δ)
            size = np.maximum(w1 - w0, 0)
            total = int(size.sum())
            if total:
                # every window of every interval: w0 repeated, plus 0, 1, ... within each
                offsets = np.arange(total, dtype=np.int64) - np.repeat(np.cumsum(size) - size, size)
                parts.append(np.repeat(w0, size) + offsets)
        if len(parts) == 1:  # the poses' windows alone: sorted and distinct already
            return parts[0].astype(np.int64)
        # intervals may share a window (two merged intervals within one window)
        return np.unique(np.concatenate(parts)).astype(np.int64)

    def fixed_covers(self, window: int, delta_ns: int) -> bool:
        """Whether a fixed-sensor interval overlaps window ``window``."""
        return bool(self.fixed_mask(np.array([window], np.int64), delta_ns)[0])

    def fixed_mask(self, windows: I64, delta_ns: int) -> BoolA:
        """Per window of ``windows``: whether a fixed-sensor interval overlaps it (one binary
        search per window over the merged intervals)."""
        w = np.asarray(windows, dtype=np.int64)
        starts, ends = self.merged_fixed()
        if starts.size == 0 or w.size == 0:
            return np.zeros(w.size, dtype=bool)
        lo = w * np.int64(delta_ns)
        k = np.searchsorted(ends, lo, side="right")  # the first interval ending after lo
        mask: BoolA = k < ends.size
        mask[mask] = starts[k[mask]] < lo[mask] + np.int64(delta_ns)
        return mask

    def fixed_share(self, windows: I64, delta_ns: int, config: ModelConfig) -> F64:
        """Per window of ``windows``, the share of it the fixed-sensor intervals cover: a log
        that starts or ends inside a window recorded only that part of it (with
        ``config.exposure``; without, 1 wherever an interval overlaps, as in the paper), so
        its detections are counted against the time it recorded. 0 where no interval
        overlaps. Exact in integer nanoseconds: the covered length below a time is the whole
        intervals before it plus the part of the one it falls in."""
        w = np.asarray(windows, dtype=np.int64)
        starts, ends = self.merged_fixed()
        if not config.exposure:
            return self.fixed_mask(w, delta_ns).astype(np.float64)
        if starts.size == 0 or w.size == 0:
            return np.zeros(w.size)
        if w.size == 1:  # a build closes one window at a time: one search, a scalar walk
            return np.array([self._share_of(int(w[0]), int(delta_ns))])
        before = self._covered_before()  # covered before interval k

        def covered_below(t: I64) -> I64:
            k = np.searchsorted(starts, t, side="left")  # intervals starting before t
            last = np.maximum(k - 1, 0)
            part = np.clip(np.minimum(ends[last], t) - starts[last], 0, None)
            out: I64 = np.where(k > 0, before[last] + part, 0)
            return out

        lo = w * np.int64(delta_ns)
        out: F64 = (covered_below(lo + np.int64(delta_ns)) - covered_below(lo)) / float(delta_ns)
        return np.minimum(out, 1.0)

    def fixed_share_of(self, window: int, delta_ns: int, config: ModelConfig) -> float:
        """:meth:`fixed_share` of the one window ``window``, as a float (a build's window
        close asks it of every window it closes)."""
        starts, _ = self.merged_fixed()
        if starts.size == 0:
            return 0.0
        if not config.exposure:
            return float(self.fixed_share(np.array([window], np.int64), delta_ns, config)[0])
        return self._share_of(int(window), int(delta_ns))

    def _share_of(self, window: int, delta_ns: int) -> float:
        """The share of window ``window`` the merged fixed-sensor intervals cover (with
        ``exposure``): one search, then a scalar walk over the intervals it meets."""
        starts, ends = self.merged_fixed()
        begin = window * delta_ns
        stop = begin + delta_ns
        k = int(ends.searchsorted(begin, side="right"))  # the first interval ending after
        covered = 0
        while k < starts.size and int(starts[k]) < stop:
            covered += min(int(ends[k]), stop) - max(int(starts[k]), begin)
            k += 1
        return min(covered / delta_ns, 1.0)

    def robot_observed(
        self, entry_xy: F64, window: int, delta_ns: int, sensor_range: float
    ) -> BoolA:
        """Mask of entries within ``sensor_range`` of a robot pose inside the window."""
        n = len(entry_xy)
        lo, hi = window * delta_ns, (window + 1) * delta_ns
        i0, i1 = np.searchsorted(self.pose_t, [lo, hi])
        if i1 <= i0 or n == 0:
            return np.zeros(n, dtype=bool)
        poses = self.pose_xy[i0:i1]
        # a pose repeated (a robot standing) adds nothing: each kept once in a row, in one
        # pass (np.unique's sort of the rows cost more than the rest of the test)
        moved = np.ones(len(poses), dtype=bool)
        moved[1:] = (poses[1:] != poses[:-1]).any(axis=1)
        # an entry exactly sensor_range away is observed (numpy: no KD-tree, whose import
        # cost a query of a patrolled map more than the rest of it; the same answers)
        return any_within(entry_xy, poses[moved], sensor_range)

    def robot_exposure(
        self,
        entry_xy: F64,
        window: int,
        delta_ns: int,
        sensor_range: float,
        floor: float = 1.0 / SUBSTEPS,
    ) -> F64:
        """Per entry, the fraction of the window in which the robot had it within
        ``sensor_range`` (module docstring): 0 where :meth:`robot_observed` is False, else in
        [``floor``, 1]."""
        observed = self.robot_observed(entry_xy, window, delta_ns, sensor_range)
        out = np.zeros(len(entry_xy))
        if not observed.any():
            return out
        step = delta_ns / SUBSTEPS
        lo = np.int64(window) * np.int64(delta_ns)
        middles = lo + ((np.arange(SUBSTEPS) + 0.5) * step).astype(np.int64)
        # the window's own poses only (not empty: an entry was observed): the poses before it
        # may be pruned already, or kept (a shard's), and those after it read or not yet,
        # depending on how the logs were read; within the window they are all there
        i0, i1 = np.searchsorted(self.pose_t, [lo, lo + np.int64(delta_ns)])
        t, xy = self.pose_t[i0:i1], self.pose_xy[i0:i1]
        after = np.minimum(np.searchsorted(t, middles), t.size - 1)
        before = np.maximum(after - 1, 0)
        nearest = np.where(np.abs(t[before] - middles) <= np.abs(t[after] - middles), before, after)
        held = np.abs(t[nearest] - middles) <= max(POSE_HOLD_NS, step / 2)
        steps = xy[nearest[held]]
        seen = np.zeros(int(observed.sum()))
        if len(steps):
            seen = count_within(entry_xy[observed, :2], steps, sensor_range) / SUBSTEPS
        out[observed] = np.clip(seen, floor, 1.0)
        return out

    def coverage(self, entry_xy: F64, window: int, delta_ns: int, config: ModelConfig) -> F64:
        """Per entry, how much of the window the robot observed it in, by the model's
        settings: its exposure (:meth:`robot_exposure`, at least ``exposure_floor``) with
        ``exposure``, else 1 wherever :meth:`robot_observed`; 0 where no pose in the window
        had it within ``sensor_range``."""
        reach = config.sensor_range
        if config.exposure:
            return self.robot_exposure(entry_xy, window, delta_ns, reach, config.exposure_floor)
        return self.robot_observed(entry_xy, window, delta_ns, reach).astype(np.float64)

    def observed(self, entry_xy: F64, window: int, delta_ns: int, sensor_range: float) -> BoolA:
        """Mask of entries observed in one window (every entry under a fixed sensor)."""
        if self.fixed_covers(window, delta_ns):
            return np.ones(len(entry_xy), dtype=bool)
        return self.robot_observed(entry_xy, window, delta_ns, sensor_range)

    def join(self, earlier: ObservationSource) -> None:
        """Take in the poses and fixed-sensor intervals of an earlier source (a shard join)."""
        t_all = np.concatenate([earlier.pose_t, self.pose_t])
        xy_all = np.concatenate([earlier.pose_xy, self.pose_xy])
        order = np.argsort(t_all, kind="stable")
        self.pose_t, self.pose_xy = t_all[order], xy_all[order]
        self.fixed_start = np.concatenate([earlier.fixed_start, self.fixed_start])
        self.fixed_end = np.concatenate([earlier.fixed_end, self.fixed_end])
        self._merged = None

    def to_arrays(self, prefix: str = "obs_") -> dict[str, np.ndarray]:
        """The poses and the fixed-sensor intervals as :meth:`merged_fixed` (so one interval
        declared whole or in touching parts saves the same)."""
        starts, ends = self.merged_fixed()
        return {
            f"{prefix}pose_t": self.pose_t.copy(),
            f"{prefix}pose_xy": self.pose_xy.copy(),
            f"{prefix}fixed_start": starts.copy(),
            f"{prefix}fixed_end": ends.copy(),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str = "obs_") -> ObservationSource:
        return cls(
            np.asarray(arrays[f"{prefix}pose_t"], dtype=np.int64),
            np.asarray(arrays[f"{prefix}pose_xy"], dtype=np.float64).reshape(-1, 2),
            np.asarray(arrays[f"{prefix}fixed_start"], dtype=np.int64),
            np.asarray(arrays[f"{prefix}fixed_end"], dtype=np.int64),
        )


def merged_spans(starts: I64, ends: I64) -> tuple[I64, I64]:
    """Spans ``[start, end)`` as sorted disjoint ones (overlapping or touching spans joined,
    empty ones left out; new arrays)."""
    s, e = np.asarray(starts, np.int64), np.asarray(ends, np.int64)
    ok = e > s
    s, e = s[ok], e[ok]
    if s.size == 0:
        return s, e
    order = np.argsort(s, kind="stable")
    s, e = s[order], np.maximum.accumulate(e[order])
    new = np.concatenate([[True], s[1:] > e[:-1]])
    last = np.concatenate([new[1:], [True]])
    return s[new], e[last]


def _cut_windows(windows: I64, delta: np.int64, starts: I64, ends: I64) -> tuple[I64, I64]:
    """The windows (sorted, distinct) as intervals of log time cut to the spans
    ``[starts, ends)``: each window gives its overlap with every span reaching into it, or
    itself whole where none does."""
    s, e = merged_spans(starts, ends)
    lo = windows * delta
    hi = lo + delta
    if s.size == 0:
        return lo, hi
    first = np.searchsorted(e, lo, side="right")  # the first span ending after the start
    stop = np.searchsorted(s, hi, side="left")  # the spans starting before the end
    n = np.maximum(stop - first, 0)
    pieces = np.maximum(n, 1)
    total = int(pieces.sum())
    k = np.repeat(first, pieces) + (
        np.arange(total, dtype=np.int64) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    )
    cut = np.repeat(n > 0, pieces)
    w_lo, w_hi = np.repeat(lo, pieces), np.repeat(hi, pieces)
    k = np.minimum(k, s.size - 1)  # a whole window's k is not used
    out_lo = np.where(cut, np.maximum(w_lo, s[k]), w_lo)
    out_hi = np.where(cut, np.minimum(w_hi, e[k]), w_hi)
    return out_lo, out_hi
