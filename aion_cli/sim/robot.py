"""The patrolling robot: its true path, odometry drift, loop closures and what it can see.

The robot waits at its dock and, every ``tour_every_s`` seconds inside the patrol hours, drives
a tour over the environment's patrol waypoints (shortest place-graph paths) back to the dock.

Localization is modelled the way ROS stacks publish it: ``odom→base_link`` comes from odometry,
which drifts as a random walk in SE(2) growing with the distance driven (drift ``E``), so
``odom_T_base = E ∘ true_pose``; ``map→odom`` (correction ``C``) is constant between loop
closures and jumps at each one — when the robot is back at its dock — to ``C = E⁻¹`` so the map
estimate is exact again. In between, everything the robot measures is off by ``C ∘ E``: detections
transformed through TF and the scene graph's place positions alike.
"""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass

import numpy as np

from aion_cli.engine.types import F64, I64, BoolA
from aion_cli.sim.agents import walk_path
from aion_cli.sim.clock import SceneClock
from aion_cli.sim.environment import Environment
from aion_cli.sim.geometry import se2_compose, se2_inverse


@dataclass(frozen=True)
class PatrolConfig:
    """How and when the robot patrols, and how its odometry drifts."""

    tour_every_s: float = 1800.0
    hours: tuple[float, float] = (0.0, 24.0)  # local patrol hours [start, end)
    speed: float = 0.5
    sensor_range: float = 8.0
    line_of_sight: bool = True
    drift_xy: float = 0.03  # m per sqrt(m driven)
    drift_yaw: float = 0.004  # rad per sqrt(m driven)

    def changed_flags(self) -> list[str]:
        """The ``aion simulate`` options whose values this config changes from the defaults
        (a fixed sensor, which neither tours nor has a range, refuses them)."""
        default = PatrolConfig()
        flags = (
            ("--tour-every", self.tour_every_s != default.tour_every_s),
            ("--patrol-hours", self.hours != default.hours),
            ("--sensor-range", self.sensor_range != default.sensor_range),
            ("--no-line-of-sight", self.line_of_sight != default.line_of_sight),
        )
        return [flag for flag, changed in flags if changed]


@dataclass(frozen=True)
class RobotTrack:
    """The robot per tick: true pose (x, y, yaw), odometry drift E, loop-closure ticks."""

    pose: F64
    drift: F64
    moving: BoolA
    loop_closures: I64
    tour_starts: I64
    config: PatrolConfig

    def correction(self, ticks: I64) -> F64:
        """map→odom (x, y, yaw) at the given ticks: E⁻¹ of the latest loop closure, else 0."""
        idx = np.searchsorted(self.loop_closures, ticks, side="right") - 1
        out = np.zeros((len(ticks), 3))
        has = idx >= 0
        out[has] = se2_inverse(self.drift[self.loop_closures[idx[has]]])
        return out

    def error(self, ticks: I64) -> F64:
        """The map-estimate error C ∘ E at the ticks: estimated = error ∘ true (world points)."""
        return se2_compose(self.correction(ticks), self.drift[ticks])

    def odom_pose(self, ticks: I64) -> F64:
        """odom→base_link = E ∘ true pose."""
        return se2_compose(self.drift[ticks], self.pose[ticks])

    def sees(self, env: Environment, ticks: I64, xyz: F64) -> BoolA:
        """Which targets xyz[i] the sensor sees at ticks[i] (range, then walls if enabled)."""
        d = np.linalg.norm(xyz[:, :2] - self.pose[ticks, :2], axis=1)
        ok = d <= self.config.sensor_range
        if self.config.line_of_sight and len(env.walls) and ok.any():
            idx = np.flatnonzero(ok)
            ok[idx] = env.visible(self.pose[ticks[idx], :2], xyz[idx, :2])
        return ok


def _tour_starts(cfg: PatrolConfig, days: float, clock: SceneClock) -> F64:
    """Planned tour start times (s since the scene start, ``clock.offset_s`` after local
    midnight) inside the patrol hours (local, on ``clock``: a zone's daylight saving moves
    them in elapsed time); tours start on a fixed grid of wall time from one minute past
    midnight."""
    offset_s = clock.offset_s
    end = float(clock.wall([days * 86400.0])[0])
    t = np.arange(60.0, end, cfg.tour_every_s)
    t = t[_in_hours(t, cfg.hours) & (t >= offset_s)]
    return clock.elapsed(t)


def _in_hours(wall_s: F64, hours: tuple[float, float]) -> BoolA:
    """Which wall times (s after a local midnight) lie in the patrol ``hours`` [start, end),
    a start after the end wrapping past midnight."""
    hour = (wall_s % 86400.0) / 3600.0
    lo, hi = hours
    inside: BoolA = (
        (hour >= lo) & (hour < hi) if lo <= hi else (hour >= lo) | (hour < hi)
    )
    return inside


def tours_can_start(cfg: PatrolConfig) -> bool:
    """Whether a tour of the grid (every ``tour_every_s`` of wall time from 00:01) starts
    inside the patrol hours on any day of a week (after which a grid of whole seconds mostly
    repeats): a span the grid misses (``24-0``, or minutes between two starts) never does."""
    t = np.arange(60.0, 7 * 86400.0, max(cfg.tour_every_s, 1.0))
    return bool(_in_hours(t, cfg.hours).any())


def simulate_robot(
    env: Environment,
    cfg: PatrolConfig,
    rng: np.random.Generator,
    dt_s: float,
    n_ticks: int,
    days: float,
    clock: SceneClock | None = None,
) -> RobotTrack:
    """Drive the patrol tours, integrate drift, close loops at the dock.

    ``clock`` is the scene's local clock: tick 0 is ``clock.offset_s`` seconds after local
    midnight (a scene may start at any time of day), and it places the local patrol hours in
    elapsed time (default: a scene starting at midnight, at a fixed offset, whose date then
    does not matter).
    """
    clock = clock or SceneClock(_dt.date(1970, 1, 1), 0.0)
    route = env.polyline(env.roles.patrol)
    route = route.copy()
    route[:, 2] = 0.0  # the robot base drives on the floor
    dock = route[0]
    pose = np.zeros((n_ticks, 3))
    pose[:, :2] = dock[:2]
    yaw = np.full(n_ticks, np.nan)
    yaw[0] = 0.0
    moving = np.zeros(n_ticks, dtype=bool)
    closures: list[int] = []
    starts: list[int] = []
    free = 0.0
    for t in _tour_starts(cfg, days, clock):
        if t < free:
            continue
        ticks, xyz, heading = walk_path(route, float(t), cfg.speed, dt_s, n_ticks)
        if len(ticks) < 2:
            continue
        pose[ticks, :2] = xyz[:, :2]
        yaw[ticks] = heading
        moving[ticks] = True
        starts.append(int(ticks[0]))
        free = float(t) + float(np.linalg.norm(np.diff(route, axis=0), axis=1).sum()) / cfg.speed
        end = int(np.ceil(free / dt_s))
        if end < n_ticks:
            closures.append(end)
    # hold the last heading while parked
    filled = np.where(np.isnan(yaw), 0, np.arange(n_ticks))
    np.maximum.accumulate(filled, out=filled)
    pose[:, 2] = yaw[filled]
    step = np.linalg.norm(np.diff(pose[:, :2], axis=0), axis=1)
    scale = np.sqrt(np.concatenate([[0.0], step]))[:, None]
    noise = rng.standard_normal((n_ticks, 3)) * np.array(
        [cfg.drift_xy, cfg.drift_xy, cfg.drift_yaw]
    )
    drift = np.cumsum(noise * scale, axis=0)
    return RobotTrack(
        pose=pose,
        drift=drift,
        moving=moving,
        loop_closures=np.asarray(closures, dtype=np.int64),
        tour_starts=np.asarray(starts, dtype=np.int64),
        config=cfg,
    )
