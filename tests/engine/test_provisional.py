"""The pending day scored provisionally for queries (``engine.temporal.provisional``): a map
whose last day has not closed still chooses its families with that day's evidence, exactly as
closing the day would score it, while its own sums stay those of its closed days."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.mapper import Mapper
from aion_cli.engine.query import predict_table
from aion_cli.engine.state import MapState
from aion_cli.engine.temporal.accumulators import _SCORES
from aion_cli.engine.temporal.provisional import PREFIX, ROWS, STORED, ProvisionalScores
from aion_cli.errors import MapCorruptError
from aion_cli.formats.mapfile import open_map, write_map
from aion_cli.mapquery import load_map
from tests.engine.temporal_data import DAY, HOUR, MONDAY, corridor, rush, total_flow


def _two_days() -> Mapper:
    """A full first day and the second until 20:00: the second day is still pending."""
    return corridor(2, rush, end_ns=MONDAY + DAY + 20 * HOUR)


@pytest.fixture(scope="module")
def two_days() -> Mapper:
    return _two_days()


def test_two_recorded_days_forecast_their_rhythm_before_the_second_closes(
    two_days: Mapper,
) -> None:
    """No day was scored for good (the first had no day before it, the second is pending);
    the forecast follows the rush all the same, where it used to be the static mean, the
    same at 03:00 as at 09:00."""
    state = two_days.state
    assert state.pending
    assert not state.temporal.flow_days.any()
    after = MONDAY + 2 * DAY
    night, morning = total_flow(two_days, after + 3 * HOUR), total_flow(two_days, after + 9 * HOUR)
    assert morning == pytest.approx(300.0 / 6, rel=0.1)  # 300 an hour, 6 windows an hour
    assert night <= 0.05 * morning
    families = predict_table(state, after + 9 * HOUR).flow_family
    assert set(families.tolist()) == {"shape"}  # the map's shape, borrowed by every cell
    # the queries left the map's own scores alone (a build's state is queried in a copy)
    assert not state.temporal.flow_days.any()
    assert not state.temporal.flow_scored.any()


def test_closing_the_day_scores_it_exactly_as_the_queries_did() -> None:
    mapper = _two_days()
    state = mapper.state
    provisional = state.provisional_scores()
    assert provisional is not None
    assert provisional.rows.size == state.entries.live_rows().size
    seen = state.scored_temporal()
    state.close_day()
    assert not state.pending
    assert state.provisional_scores() is None
    for name in _SCORES:
        np.testing.assert_array_equal(getattr(state.temporal, name), getattr(seen, name))


def _write(state: MapState, path: Path, drop_provisional: bool = False, version: int = 3) -> Path:
    arrays, meta = state.to_arrays()
    if drop_provisional:
        arrays = {k: v for k, v in arrays.items() if not k.startswith(PREFIX)}
    write_map(path, arrays, {"state": {**meta, "state_version": version}})
    return path


def test_the_map_file_stores_the_provisional_scores(two_days: Mapper, tmp_path: Path) -> None:
    """A query of the map read without its Fourier sums (which scoring FreMEn needs) chooses
    as the map in memory does, from the stored scores."""
    path = _write(two_days.state, tmp_path / "two.aion")
    with open_map(path) as members:
        names = {n for n in members if n.startswith(PREFIX)}
        stored = ProvisionalScores.from_arrays(
            members, len(two_days.state.entries.live_rows()), two_days.state.params
        )
    assert names == {ROWS, *(PREFIX + name for name in STORED)}  # gains and days derived
    computed = two_days.state.provisional_scores()
    assert stored is not None
    assert computed is not None
    as_rows = two_days.state.entries.canonical_order()[stored.rows]  # stored: positions
    by_row = np.argsort(as_rows)
    np.testing.assert_array_equal(as_rows[by_row], computed.rows)
    for name in _SCORES:  # every field, the derived ones too, to the bit
        np.testing.assert_array_equal(stored.fields[name][by_row], computed.fields[name])
    light = load_map(path, forecast_only=True).state
    assert not light.temporal.fourier_loaded
    t = MONDAY + 2 * DAY + 9 * HOUR
    a, b = predict_table(two_days.state, t), predict_table(light, t)
    np.testing.assert_array_equal(a.flow_family, b.flow_family)
    np.testing.assert_allclose(b.flow, a.flow, rtol=1e-12, atol=0)


def test_a_version_2_map_is_read_as_written(two_days: Mapper, tmp_path: Path) -> None:
    """Written before provisional scores existed, a map's query chooses by its closed days
    alone: here none, so the static mean, the same at night as in the rush."""
    path = _write(two_days.state, tmp_path / "v2.aion", drop_provisional=True, version=2)
    state = load_map(path, forecast_only=True).state
    night = predict_table(state, MONDAY + 2 * DAY + 3 * HOUR)
    morning = predict_table(state, MONDAY + 2 * DAY + 9 * HOUR)
    assert set(morning.flow_family.tolist()) == {"static"}
    np.testing.assert_array_equal(night.flow, morning.flow)


@pytest.mark.parametrize(
    ("member", "damage", "message"),
    [
        (ROWS, lambda a: a[::-1].copy(), "not increasing positions"),
        (ROWS, lambda a: a + 10_000, "not increasing positions"),
        (ROWS, lambda a: a.astype(np.float64), "not a list of integers"),
        (PREFIX + "flow_score", lambda a: a[:, :2].copy(), "flow_score has shape"),
        (PREFIX + "dir_score", lambda a: np.full_like(a, np.nan), "not finite"),
        (PREFIX + "flow_scored", lambda a: -a.astype(np.float64), "negative"),
        (PREFIX + "dir_scored", None, "lack"),
    ],
)
def test_damaged_provisional_scores_are_refused(
    two_days: Mapper, tmp_path: Path, member: str, damage: object, message: str
) -> None:
    arrays, meta = two_days.state.to_arrays()
    if damage is None:
        del arrays[member]
    else:
        arrays[member] = damage(np.asarray(arrays[member]))  # type: ignore[operator]
    path = tmp_path / "bad.aion"
    write_map(path, arrays, {"state": meta})
    with pytest.raises(MapCorruptError, match=message):
        load_map(path, forecast_only=True)


def test_flows_alone_equal_the_flows_of_the_pairs(two_days: Mapper) -> None:
    """Series of totals ask ``Predictor.flows`` (no direction histograms); it must be the
    flow ``pairs`` gives, to the bit, and the reconciliation factor of a block of times the
    factor of each time alone."""
    rows, predictor = two_days.state.predictor()
    assert predictor.map_family is not None  # totals are reconciled: the factor matters
    times = MONDAY + 2 * DAY + np.arange(0, DAY, HOUR // 2)
    e = np.tile(np.arange(rows.size), times.size)
    t = np.repeat(times, rows.size)
    flow, _ = predictor.pairs(e, t)
    np.testing.assert_array_equal(predictor.flows(e, t), flow)
    together = predictor.scale(times)
    alone = np.array([predictor.scale(np.array([x]))[0] for x in times])
    np.testing.assert_array_equal(together, alone)
    assert len(set(together.tolist())) > 1  # the factor varies over the day
