"""People walking: planned moves → positions sampled on the sensor's tick grid.

Each planned move becomes a trip along the shortest place-graph path from where the agent is to
the destination, walked at the agent's own speed (1.0-1.5 m/s, a little different every trip).
A move planned while the agent is still walking or dwelling starts when the agent is free. An
agent is *present* only while walking: people sitting at desks, in meetings or at lunch are not
moving and do not contribute to flow, so the simulator emits them only on the way.

Output is one row per (tick, walking agent): true position, heading (walking direction) and
speed, plus the agent and trip that produced it. Rows are sorted by tick.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aion_cli.engine.types import F64, I64
from aion_cli.sim.environment import Environment
from aion_cli.sim.schedule import PlannedMoves


@dataclass(frozen=True)
class AgentSamples:
    """True states of walking agents, one row per tick and agent."""

    tick: I64
    agent: I64
    trip: I64
    xyz: F64
    heading: F64
    speed: F64

    def __len__(self) -> int:
        return len(self.tick)

    def velocity(self) -> F64:
        """Velocity vectors (map frame) from heading and speed, z = 0."""
        return np.column_stack(
            [
                self.speed * np.cos(self.heading),
                self.speed * np.sin(self.heading),
                np.zeros(len(self)),
            ]
        )


def agent_speeds(rng: np.random.Generator, n_agents: int) -> F64:
    """Each agent's preferred walking speed in m/s."""
    return rng.uniform(1.0, 1.5, size=n_agents)


def walk_path(
    points: F64, depart_s: float, speed: float, dt_s: float, n_ticks: int
) -> tuple[I64, F64, F64]:
    """Ticks, positions and headings of one walk along a polyline at constant speed."""
    seg = np.diff(points, axis=0)
    seg_len = np.linalg.norm(seg, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg_len)])
    arrive_s = depart_s + cum[-1] / speed
    k0 = max(int(np.ceil(depart_s / dt_s)), 0)
    k1 = min(int(np.floor(arrive_s / dt_s)), n_ticks - 1)
    ticks = np.arange(k0, k1 + 1, dtype=np.int64)
    s = np.clip(speed * (ticks * dt_s - depart_s), 0.0, cum[-1])
    xyz = np.column_stack([np.interp(s, cum, points[:, c]) for c in range(3)])
    idx = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
    heading = np.arctan2(seg[idx, 1], seg[idx, 0])
    return ticks, xyz, heading


def simulate_agents(
    env: Environment,
    moves: PlannedMoves,
    speeds: F64,
    rng: np.random.Generator,
    dt_s: float,
    n_ticks: int,
) -> AgentSamples:
    """Walk every planned move over the place graph; sample at ticks ``k·dt_s``."""
    parts: list[tuple[I64, I64, I64, F64, F64, F64]] = []
    trip = 0
    for a in np.unique(moves.agent):
        rows = np.flatnonzero(moves.agent == a)
        cur = env.roles.entrance
        free_s = -np.inf
        for r in rows:
            dst = int(moves.dst[r])
            depart = max(float(moves.t_s[r]), free_s)
            if dst == cur:
                continue
            points = env.xyz[env.path(cur, dst)]
            v = float(speeds[a] * np.clip(rng.normal(1.0, 0.05), 0.85, 1.15))
            ticks, xyz, heading = walk_path(points, depart, v, dt_s, n_ticks)
            length = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
            free_s = depart + length / v
            cur = dst
            if len(ticks):
                n = len(ticks)
                parts.append((ticks, np.full(n, a), np.full(n, trip), xyz, heading, np.full(n, v)))
            trip += 1
    if not parts:
        z = np.zeros(0, dtype=np.int64)
        return AgentSamples(z, z, z, np.zeros((0, 3)), np.zeros(0), np.zeros(0))
    cols = [np.concatenate([p[i] for p in parts]) for i in range(6)]
    order = np.lexsort((cols[1], cols[0]))
    return AgentSamples(
        tick=cols[0][order].astype(np.int64),
        agent=cols[1][order].astype(np.int64),
        trip=cols[2][order].astype(np.int64),
        xyz=cols[3][order],
        heading=cols[4][order],
        speed=cols[5][order],
    )
