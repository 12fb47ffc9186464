"""An entry the robot saw by day only, on a map whose nights were observed (and empty)
elsewhere: the night forecast of an entry that chose ``static`` is its group's shape there,
not its daytime rate (``Predictor``, "hours an entry never observed")."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.query import predict_table
from aion_cli.engine.types import DetectionBatch, Trajectory
from tests.engine.temporal_data import DAY, HOUR, MONDAY, S

WINDOW = 600 * S
HALL = (0.0, 4.0)  # x range of the hall, watched day and night
DESK = (40.0, 44.0)  # x range of the desk, 40 m away: watched 08-18 h only


def _day_only_desk(days: int, seed: int = 0, families: list[str] | None = None) -> Mapper:
    """The robot stands in the hall at night; from 08 to 18 h it spends every other
    10-minute window at the desk. People come only by day: the hall has a rush at 08-10 h
    and 16-18 h (its rhythm, seen against its empty nights), the desk a flat 12 an hour
    while watched (flat over every hour it was seen: ``static`` forecasts it best there)."""
    rng = np.random.default_rng(seed)
    config = ModelConfig() if families is None else ModelConfig(families=families)
    mapper = Mapper(config)
    t = MONDAY + np.arange(0, days * DAY, 60 * S)
    window = (t - MONDAY) // WINDOW
    hour = ((t - MONDAY) % DAY) // HOUR
    at_desk = (hour >= 8) & (hour < 18) & (window % 2 == 1)
    x = np.where(at_desk, 42.0, 2.0)
    mapper.add_trajectory(Trajectory(t, np.column_stack([x, np.ones(t.size), np.zeros(t.size)])))
    for d in range(days):
        for h in range(24):
            start = MONDAY + d * DAY + h * HOUR
            for w in range(6):
                t0 = start + w * WINDOW
                desk_window = 8 <= h < 18 and w % 2 == 1
                rate = 2.0 if desk_window else (300.0 if h in (8, 9, 16, 17) else 0.0) / 6
                n = int(rng.poisson(rate))
                if n == 0:
                    continue
                times = t0 + 30 * S + np.sort(rng.integers(0, WINDOW - 60 * S, n))
                lo, hi = DESK if desk_window else HALL
                xy = rng.uniform((lo, 0.0), (hi, 2.0), size=(n, 2))
                batch = DetectionBatch.from_arrays(
                    times, np.column_stack([xy, np.zeros(n)]), rng.normal(0.0, 0.3, n), np.ones(n)
                )
                mapper.add_detections(batch)
    mapper.advance(MONDAY + days * DAY)
    return mapper


def _desk_flow(mapper: Mapper, t_ns: int) -> tuple[float, list[str]]:
    table = predict_table(mapper.state, t_ns)
    desk = table.xyz[:, 0] >= DESK[0] - 1.0
    return float(np.nansum(table.flow[desk])), sorted(set(table.flow_family[desk].tolist()))


def test_a_day_only_static_entry_forecasts_its_groups_shape_at_night() -> None:
    mapper = _day_only_desk(7)
    after = MONDAY + 7 * DAY
    noon, noon_families = _desk_flow(mapper, after + 12 * HOUR)
    night, night_families = _desk_flow(mapper, after + 3 * HOUR)
    assert "static" in noon_families  # flat while watched: the desk keeps its static rate by day
    assert noon == pytest.approx(2.0, rel=0.25)  # 12 an hour, six windows an hour
    assert night <= 0.05 * noon  # nobody is at the desk at night, and none was seen anywhere
    assert "static" not in night_families


def test_without_the_shape_family_static_stays() -> None:
    """With ``static`` the only family there is nothing to fall back to: the desk's rate."""
    mapper = _day_only_desk(4, families=["static"])
    after = MONDAY + 4 * DAY
    noon, _ = _desk_flow(mapper, after + 12 * HOUR)
    night, families = _desk_flow(mapper, after + 3 * HOUR)
    assert families == ["static"]
    assert night == pytest.approx(noon)
