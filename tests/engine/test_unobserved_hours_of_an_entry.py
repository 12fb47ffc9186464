"""An entry the robot saw by day only, on a map whose nights were observed (and empty)
elsewhere: the night forecast of an entry that chose ``static`` or a FreMEn family is its
group's shape there, not its daytime rate nor its sinusoids; ``profile`` is its shape parent
there by construction (``Predictor``, "hours an entry never observed";
``temporal.unseen_hours``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.query import predict_table
from aion_cli.engine.temporal.model import Predictor
from aion_cli.engine.types import DetectionBatch, Trajectory
from tests.engine.temporal_data import DAY, HOUR, MONDAY, S

WINDOW = 600 * S
HALL = (0.0, 4.0)  # x range of the hall, watched day and night
DESK = (40.0, 44.0)  # x range of the desk, 40 m away: watched 08-18 h only


def _day_only_desk(
    days: int,
    seed: int = 0,
    families: list[str] | None = None,
    desk_rate: Callable[[int], float] | None = None,
) -> Mapper:
    """The robot stands in the hall at night; from 08 to 18 h it spends every other
    10-minute window at the desk. People come only by day: the hall has a rush at 08-10 h
    and 16-18 h (its rhythm, seen against its empty nights), the desk a flat 12 an hour
    while watched (flat over every hour it was seen: ``static`` forecasts it best there).
    ``desk_rate``: the desk's detections per window by hour of the day instead, all at one
    spot (one cell: its counts are not spread over the desk's cells)."""
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
                desk = 2.0 if desk_rate is None else desk_rate(h)
                rate = desk if desk_window else (300.0 if h in (8, 9, 16, 17) else 0.0) / 6
                n = int(rng.poisson(rate))
                if n == 0:
                    continue
                times = t0 + 30 * S + np.sort(rng.integers(0, WINDOW - 60 * S, n))
                lo, hi = DESK if desk_window else HALL
                xy = rng.uniform((lo, 0.0), (hi, 2.0), size=(n, 2))
                if desk_window and desk_rate is not None:
                    xy = np.full((n, 2), (42.05, 1.05)) + rng.uniform(-0.05, 0.05, (n, 2))
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


def _rising(h: int) -> float:
    """0.5 detections a window at 08 h, 0.5 more every hour to 5 at 17 h: a trend over the
    hours watched that a 24 h cosine follows better than a flat rate (``fremen1``)."""
    return 0.5 + 0.5 * (h - 8)


def _desk(mapper: Mapper) -> int:
    """The desk's entry position (the one cell of its spot)."""
    table = predict_table(mapper.state, MONDAY)
    (desk,) = np.flatnonzero(table.xyz[:, 0] >= DESK[0] - 1.0)
    return int(desk)


def _flow(predictor: Predictor, e: int, t_ns: int) -> float:
    return float(predictor.flows(np.array([e]), np.array([t_ns]))[0])


def test_a_day_only_fremen_entry_forecasts_its_groups_shape_at_night() -> None:
    """The desk's rising daytime counts choose FreMEn, whose cosine, fitted to 08-18 h,
    stood at about a tenth of its noon forecast all night; the group's shape says what the
    hall saw there (nobody). At the hours the desk was watched nothing changes."""
    mapper = _day_only_desk(14, desk_rate=_rising)
    after = MONDAY + 14 * DAY
    _, predictor = mapper.state.predictor()
    desk = _desk(mapper)
    assert predictor.params.flow[predictor.flow_choice[desk]].startswith("fremen")
    # the same forecasts without the rule: no hour counts as one the desk never observed
    without = dataclasses.replace(predictor, unseen_own=np.zeros_like(predictor.unseen_own))
    noon = _flow(predictor, desk, after + 12 * HOUR)
    for h in range(8, 18):  # watched: the chosen FreMEn forecast, unchanged
        t = after + h * HOUR + 30 * 60 * S
        assert _flow(predictor, desk, t) == _flow(without, desk, t)
    table = predict_table(mapper.state, after + 12 * HOUR)
    assert table.flow_family[desk].startswith("fremen")
    for h in (3, 19, 22):  # never watched at the desk, watched (empty) in the hall
        t = after + h * HOUR + 30 * 60 * S
        assert _flow(predictor, desk, t) <= 0.05 * noon
        assert _flow(without, desk, t) > 0.05 * noon  # the cosine's extrapolation
        assert predict_table(mapper.state, t).flow_family[desk] == "shape"


def test_a_fremen_map_total_takes_no_entrys_sinusoids_where_it_never_was() -> None:
    """Reconciled to FreMEn totals, the desk's cosine at night does not come back through
    the factor that scales the map's entries to them. Order 2: the hall's two rushes (24 h
    and 12 h terms) and empty nights, which its FreMEn total then holds at about zero."""
    mapper = _day_only_desk(14, desk_rate=_rising)
    after = MONDAY + 14 * DAY
    _, chosen = mapper.state.predictor()
    predictor = dataclasses.replace(chosen, map_family="fremen2")
    desk = _desk(mapper)
    noon = _flow(predictor, desk, after + 12 * HOUR)
    for h in (3, 19, 22):
        assert _flow(predictor, desk, after + h * HOUR + 30 * 60 * S) <= 0.05 * noon


def test_a_profile_entry_is_its_shape_parent_at_hours_it_never_observed() -> None:
    """``profile`` needs no rule: at a bin without windows of its own it forecasts exactly
    its ``shape`` parent (a trend steep enough for the desk's own profile to win)."""
    mapper = _day_only_desk(14, desk_rate=lambda h: 4.0 * _rising(h))
    after = MONDAY + 14 * DAY
    _, predictor = mapper.state.predictor()
    desk = _desk(mapper)
    assert predictor.params.flow[predictor.flow_choice[desk]] == "profile"
    fc = predictor.forecaster
    for h in (3, 19, 22):
        t = np.array([after + h * HOUR + 30 * 60 * S])
        b = predictor.params.calendar.profile_bin(t)
        shape = fc.flow("shape", np.array([desk]), b, predictor.params.model_seconds(t))
        assert _flow(predictor, desk, int(t[0])) == pytest.approx(
            float(shape[0] * predictor.scale(t)[0]), rel=1e-12
        )
