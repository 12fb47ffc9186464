"""The heading estimator as it was before issue 15 (one vectorised round per occurrence of a
track within a call): the reference the vectorised :mod:`aion_cli.engine.heading` is tested
against, kept here verbatim (only this docstring and the class name changed)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import DetectionBatch
from aion_cli.errors import ConfigError
from aion_cli.formats.detections.frame import F64, I64, FrameDetections

#: Heading source codes of :attr:`HeadingEstimator.sources`: no heading, the message's
#: velocity, differencing the track, the pose yaw.
SOURCES: tuple[str, ...] = ("none", "velocity", "track", "pose_yaw")
NO_HEADING, FROM_VELOCITY, FROM_TRACK, FROM_YAW = range(4)


class RoundsHeadingEstimator:
    """Stateful heading/speed estimation over successive calls (see the module docstring)."""

    def __init__(
        self, min_displacement: float = 0.05, max_gap_s: float = 5.0, prune_above: int = 4096
    ) -> None:
        if not min_displacement >= 0.0 or not max_gap_s > 0.0:
            raise ConfigError(
                f"heading estimation needs min_displacement >= 0 and max_gap_s > 0, got "
                f"{min_displacement} and {max_gap_s}"
            )
        self.min_displacement = float(min_displacement)
        self.max_gap_ns = int(max_gap_s * 1e9)
        self.prune_above = int(prune_above)
        self.ids: I64 = np.zeros(0, np.int64)
        self.ref_t: I64 = np.zeros(0, np.int64)
        self.ref_xy: F64 = np.zeros((0, 2))
        self.heading: F64 = np.zeros(0)
        #: Per row of the last :meth:`estimate` call, the code (index into :data:`SOURCES`) of
        #: the rule that gave its heading.
        self.sources: npt.NDArray[np.int8] = np.zeros(0, np.int8)

    def __len__(self) -> int:
        """Number of tracks remembered."""
        return len(self.ids)

    def to_batch(self, det: FrameDetections) -> DetectionBatch:
        """The engine batch of detections already transformed into the map frame."""
        return self.estimate(det.t_ns, det.xyz, det.velocity, det.yaw, det.track_id)

    def estimate(
        self,
        t_ns: npt.ArrayLike,
        xyz: npt.ArrayLike,
        velocity: npt.ArrayLike | None = None,
        yaw: npt.ArrayLike | None = None,
        track_id: npt.ArrayLike | None = None,
    ) -> DetectionBatch:
        """Headings and speeds for map-frame arrays; rows keep their order."""
        t = np.asarray(t_ns, np.int64).reshape(-1)
        n = len(t)
        p = np.asarray(xyz, np.float64).reshape(n, 3)
        v = np.full((n, 3), np.nan) if velocity is None else np.asarray(velocity, np.float64)
        v = v.reshape(n, 3)
        y = np.full(n, np.nan) if yaw is None else np.asarray(yaw, np.float64).reshape(n)
        k = np.full(n, -1, np.int64) if track_id is None else np.asarray(track_id, np.int64)
        k = k.reshape(n)

        vxy = v[:, :2]
        vspeed = np.hypot(vxy[:, 0], vxy[:, 1])
        has_vel = np.isfinite(vspeed) & (vspeed > 0.0)
        heading = np.full(n, np.nan)
        moving = np.flatnonzero(has_vel)
        if moving.size:  # (logs without velocities skip the arctan2 entirely)
            heading[moving] = np.arctan2(vxy[moving, 1], vxy[moving, 0])
        speed = np.where(has_vel, vspeed, np.nan)

        source = np.where(has_vel, FROM_VELOCITY, NO_HEADING).astype(np.int8)
        tracked = np.flatnonzero(k >= 0)
        if len(tracked):
            self._difference(tracked, t, p[:, :2], k, has_vel, heading, speed)
            if len(self.ids) > self.prune_above:
                self._prune(int(t[tracked].max()))
            source[tracked] = np.where(
                has_vel[tracked], FROM_VELOCITY,
                np.where(np.isnan(heading[tracked]), NO_HEADING, FROM_TRACK),
            )
        unset = np.isnan(heading)
        source[unset & ~np.isnan(y)] = FROM_YAW
        self.sources = source
        heading = np.where(unset, y, heading)
        outside = np.flatnonzero(np.abs(heading) > np.pi)  # yaws moved by TF: wrap them
        if outside.size:
            h = heading[outside]
            heading[outside] = np.arctan2(np.sin(h), np.cos(h))
        return DetectionBatch(t, np.ascontiguousarray(p), heading, speed, k)

    # --- internals -------------------------------------------------------------------------------
    def _prune(self, t_now: int) -> None:
        """Forget tracks not seen for ``max_gap_s`` (they would start over anyway), so the state
        stays the size of the recently active tracks over a long log."""
        keep = self.ref_t >= t_now - self.max_gap_ns
        self.ids, self.ref_t = self.ids[keep], self.ref_t[keep]
        self.ref_xy, self.heading = self.ref_xy[keep], self.heading[keep]

    def _slots(self, ids: I64) -> I64:
        """Slots of ``ids`` in the state arrays, adding unseen ids (kept sorted)."""
        new = np.setdiff1d(ids, self.ids)
        if len(new):
            merged = np.union1d(self.ids, new)
            old = np.searchsorted(merged, self.ids)
            ref_t = np.full(len(merged), np.iinfo(np.int64).min)
            ref_xy = np.full((len(merged), 2), np.nan)
            head = np.full(len(merged), np.nan)
            ref_t[old], ref_xy[old], head[old] = self.ref_t, self.ref_xy, self.heading
            self.ids, self.ref_t, self.ref_xy, self.heading = merged, ref_t, ref_xy, head
        return np.searchsorted(self.ids, ids)

    def _difference(
        self,
        rows: I64,
        t: I64,
        xy: F64,
        k: I64,
        has_vel: npt.NDArray[np.bool_],
        heading: F64,
        speed: F64,
    ) -> None:
        """Rule 2 for the tracked ``rows`` (updates ``heading``/``speed`` in place)."""
        slot = self._slots(k[rows])
        order = np.lexsort((t[rows], slot))
        rows, slot = rows[order], slot[order]
        start = np.r_[True, slot[1:] != slot[:-1]]
        group_start = np.maximum.accumulate(np.where(start, np.arange(len(rows)), 0))
        rank = np.arange(len(rows)) - group_start
        for r in range(int(rank.max()) + 1):
            sel = rank == r
            self._round(rows[sel], slot[sel], t, xy, has_vel, heading, speed)

    def _round(
        self,
        rows: I64,
        slot: I64,
        t: I64,
        xy: F64,
        has_vel: npt.NDArray[np.bool_],
        heading: F64,
        speed: F64,
    ) -> None:
        """One detection per track (distinct slots): difference against the reference."""
        ref_t = self.ref_t[slot]
        dt = t[rows] - ref_t
        known = ref_t != np.iinfo(np.int64).min
        fresh = known & (dt > 0) & (dt <= self.max_gap_ns)
        stale = ~fresh & ~(known & (dt == 0))
        d = xy[rows] - self.ref_xy[slot]
        dist = np.hypot(d[:, 0], d[:, 1])
        moved = fresh & (dist >= self.min_displacement)
        prev = np.where(stale, np.nan, self.heading[slot])
        diff_heading = np.where(moved, np.arctan2(d[:, 1], d[:, 0]), prev)
        vel = has_vel[rows]
        use = ~vel & fresh
        heading[rows[use]] = diff_heading[use]
        speed[rows[use]] = dist[use] / (dt[use] * 1e-9)
        # State: velocity headings and new differenced headings become "previous".
        self.heading[slot] = np.where(vel, heading[rows], diff_heading)
        reset = stale | moved
        self.ref_t[slot] = np.where(reset, t[rows], ref_t)
        self.ref_xy[slot] = np.where(reset[:, None], xy[rows], self.ref_xy[slot])
