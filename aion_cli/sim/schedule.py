"""Daily and weekly rhythms: when each simulated person wants to go where.

The schedule is a table of *planned moves* (agent, local time, destination place) built per
agent and day from an office routine: arrival in the morning (~8:30), coffee breaks (~10:30,
~15:30), lunch in the kitchen (~12:30), team meetings at fixed weekly hours, a few errands to
random places, departure (~17:30, earlier on Fridays). Weekends are quiet: an agent comes in on
a weekend day only with a small probability. Activities that would overlap a higher-priority one
(meeting > lunch > coffee > errand) are dropped, so the routine stays plausible.

Times are seconds since the scene start (local midnight of the first day); all randomness comes
from the numpy Generator passed in, so a seed fixes the schedule.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aion_cli.engine.types import F64, I64
from aion_cli.sim.environment import Roles

HOUR = 3600.0
DAY = 86400.0

# weekday (0 = Monday) -> (start hour, duration minutes) of the team meeting
MEETINGS: dict[int, tuple[float, float]] = {0: (10.0, 60.0), 2: (14.0, 60.0), 4: (11.0, 45.0)}


@dataclass(frozen=True)
class Rhythm:
    """Parameters of the office routine (hours are local time)."""

    arrive_h: float = 8.5
    leave_h: float = 17.5
    friday_leave_h: float = 16.5
    lunch_h: float = 12.4
    coffee_h: tuple[float, ...] = (10.5, 15.5)
    coffee_p: float = 0.7
    meeting_p: float = 0.85
    errands_per_day: float = 6.0
    weekend_p: float = 0.05


@dataclass(frozen=True)
class PlannedMoves:
    """One row per planned move, sorted by agent then time: go to ``dst`` at ``t_s``."""

    agent: I64
    t_s: F64
    dst: I64
    outside: I64  # 1 where the move leaves the building (the agent disappears afterwards)

    def __len__(self) -> int:
        return len(self.agent)


def _day_blocks(
    rng: np.random.Generator, weekday: int, rhythm: Rhythm, roles: Roles, n_places: int
) -> list[tuple[float, float, int, int]]:
    """Candidate activities (start h, end h, place, priority) of one workday."""
    blocks: list[tuple[float, float, int, int]] = []
    if weekday in MEETINGS and rng.random() < rhythm.meeting_p:
        start, minutes = MEETINGS[weekday]
        early = rng.uniform(1.0, 4.0) / 60.0
        end = start + minutes / 60.0 + rng.uniform(0, 5) / 60
        blocks.append((start - early, end, roles.meeting, 0))
    lunch = rng.normal(rhythm.lunch_h, 0.25)
    blocks.append((lunch, lunch + rng.uniform(30.0, 50.0) / 60.0, roles.kitchen, 1))
    for h in rhythm.coffee_h:
        if rng.random() < rhythm.coffee_p:
            t = rng.normal(h, 0.4)
            blocks.append((t, t + rng.uniform(5.0, 12.0) / 60.0, roles.kitchen, 2))
    for _ in range(rng.poisson(rhythm.errands_per_day)):
        t = rng.uniform(9.5, 16.5)
        blocks.append((t, t + rng.uniform(1.0, 5.0) / 60.0, int(rng.integers(n_places)), 3))
    return blocks


def _keep_non_overlapping(
    blocks: list[tuple[float, float, int, int]], lo: float, hi: float
) -> list[tuple[float, float, int, int]]:
    """Blocks inside [lo, hi] that do not overlap a higher-priority block (5 min margin)."""
    margin = 5.0 / 60.0
    kept: list[tuple[float, float, int, int]] = []
    for b in sorted(blocks, key=lambda b: (b[3], b[0])):
        if b[0] < lo + margin or b[1] > hi - margin:
            continue
        if all(b[1] + margin <= k[0] or b[0] >= k[1] + margin for k in kept):
            kept.append(b)
    return sorted(kept)


def plan_moves(
    rng: np.random.Generator,
    n_agents: int,
    days: float,
    first_weekday: int,
    roles: Roles,
    n_places: int,
    rhythm: Rhythm | None = None,
) -> PlannedMoves:
    """Planned moves of every agent over ``days`` days starting at local midnight."""
    rhythm = rhythm or Rhythm()
    agent: list[int] = []
    t_s: list[float] = []
    dst: list[int] = []
    outside: list[int] = []
    for a in range(n_agents):
        desk = int(roles.desks[a % len(roles.desks)])
        for day in range(int(np.ceil(days))):
            weekday = (first_weekday + day) % 7
            if weekday >= 5:
                if rng.random() >= rhythm.weekend_p:
                    continue
                arrive = rng.uniform(10.0, 14.0)
                leave = arrive + rng.uniform(1.0, 3.0)
                blocks: list[tuple[float, float, int, int]] = []
            else:
                arrive = float(np.clip(rng.normal(rhythm.arrive_h, 0.35), 7.5, 9.75))
                mean_leave = rhythm.friday_leave_h if weekday == 4 else rhythm.leave_h
                leave = float(np.clip(rng.normal(mean_leave, 0.4), 15.5, 19.5))
                blocks = _keep_non_overlapping(
                    _day_blocks(rng, weekday, rhythm, roles, n_places), arrive, leave
                )
            base = day * DAY
            moves = [(arrive, desk, 0)]
            for start, end, place, _ in blocks:
                moves += [(start, place, 0), (end, desk, 0)]
            moves.append((leave, roles.entrance, 1))
            for h, place, out in moves:
                agent.append(a)
                t_s.append(base + h * HOUR)
                dst.append(place)
                outside.append(out)
    return PlannedMoves(
        agent=np.asarray(agent, dtype=np.int64),
        t_s=np.asarray(t_s, dtype=np.float64),
        dst=np.asarray(dst, dtype=np.int64),
        outside=np.asarray(outside, dtype=np.int64),
    )
