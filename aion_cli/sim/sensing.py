"""What the people tracker publishes: visible agents, noisy, in the message frame, with tracks.

A walking agent is detected at a tick when the sensor sees it (always for a fixed sensor; within
range and line of sight of the robot otherwise). The measured position is the true one plus
Gaussian noise; it is expressed either in ``base_link`` (relative to the robot's *true* pose —
what a sensor on the robot measures) or in ``map`` (through the robot's *estimated* pose, so the
drift error ``C ∘ E`` is baked in, as a tracker running in the map frame would do). A consumer that
transforms ``base_link`` detections through the logged TF gets exactly the ``map`` variant.

Track ids change whenever a person leaves view for more than one tick or starts a new trip, as a
real tracker would lose and re-acquire them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aion_cli.engine.types import F64, I64, BoolA
from aion_cli.sim.agents import AgentSamples
from aion_cli.sim.environment import Environment
from aion_cli.sim.geometry import rotate_xy, se2_apply, se2_inverse
from aion_cli.sim.robot import RobotTrack


@dataclass(frozen=True)
class Observations:
    """Published detections, one row per (tick, visible agent), sorted by tick."""

    sample: I64  # row in AgentSamples
    tick: I64
    xyz: F64  # message frame
    velocity: F64  # message frame
    track_id: I64
    age_ns: I64
    frame: str

    def __len__(self) -> int:
        return len(self.tick)


def visible_samples(env: Environment, samples: AgentSamples, robot: RobotTrack | None) -> BoolA:
    """Which agent samples the sensor sees."""
    if robot is None:
        return np.ones(len(samples), dtype=bool)
    return robot.sees(env, samples.tick, samples.xyz)


def track_ids(trip: I64, tick: I64) -> I64:
    """Tracker ids (1, 2, ...): a new id per trip and after every gap of more than one tick."""
    if len(trip) == 0:
        return np.zeros(0, dtype=np.int64)
    order = np.lexsort((tick, trip))
    t, k = trip[order], tick[order]
    new = np.ones(len(t), dtype=bool)
    new[1:] = (t[1:] != t[:-1]) | (k[1:] - k[:-1] > 1)
    ids = np.empty(len(t), dtype=np.int64)
    ids[order] = np.cumsum(new)
    return ids


def track_ages(ids: I64, tick: I64, dt_ns: int) -> I64:
    """Nanoseconds since each row's track was first seen."""
    if len(ids) == 0:
        return np.zeros(0, dtype=np.int64)
    first = np.full(int(ids.max()) + 1, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(first, ids, tick)
    return (tick - first[ids]) * dt_ns


def observe(
    env: Environment,
    samples: AgentSamples,
    robot: RobotTrack | None,
    frame: str,
    noise: float,
    rng: np.random.Generator,
    dt_ns: int,
) -> Observations:
    """Detections as published: visibility, noise, frame transform, track ids."""
    vis = np.flatnonzero(visible_samples(env, samples, robot))
    tick = samples.tick[vis]
    meas = samples.xyz[vis] + rng.normal(0.0, noise, size=(len(vis), 3)) * (noise > 0)
    vel = samples.velocity()[vis]
    if robot is not None and frame == "base_link":
        inv = se2_inverse(robot.pose[tick])
        xyz, velocity = se2_apply(inv, meas), rotate_xy(inv[:, 2], vel)
    elif robot is not None:
        err = robot.error(tick)
        xyz, velocity = se2_apply(err, meas), rotate_xy(err[:, 2], vel)
    else:
        xyz, velocity = meas, vel
    ids = track_ids(samples.trip[vis], tick)
    return Observations(
        sample=vis.astype(np.int64),
        tick=tick,
        xyz=xyz,
        velocity=velocity,
        track_id=ids,
        age_ns=track_ages(ids, tick, dt_ns),
        frame=frame,
    )
