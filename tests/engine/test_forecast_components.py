"""Stored FreMEn components: a map read for queries without its Fourier sums forecasts exactly
what the whole map forecasts (issue 15: ``predict`` on big maps)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.query import predict_table
from aion_cli.engine.state import MapState
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.components import PREFIX, FremenComponents
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.types import DetectionBatch
from aion_cli.errors import MapCorruptError, MapFileError
from aion_cli.formats.mapfile import open_map, write_map
from aion_cli.mapquery import load_map
from tests.engine.temporal_data import DAY, HOUR, MONDAY, corridor, heading_56h, rhythm_56h


@pytest.fixture(scope="module")
def map_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """21 days of a 56 h rhythm over a small corridor, then a morning of day 22 left in the
    pending day and an open window with detections (what a query absorbs first)."""
    mapper = corridor(21, rhythm_56h, cells=(3.0, 1.0), heading=heading_56h)
    rng = np.random.default_rng(5)
    n = 40
    t = MONDAY + 21 * DAY + np.sort(rng.integers(0, 10 * HOUR + 5 * 60 * 10**9, n))
    xy = rng.uniform((0.0, 0.0), (1.5, 1.0), (n, 2))  # half the corridor: the rest untouched
    mapper.state.observation.set_fixed_sensor(MONDAY + 21 * DAY, MONDAY + 22 * DAY)
    mapper.add_detections(
        DetectionBatch.from_arrays(t, np.column_stack([xy, np.zeros(n)]), np.zeros(n), np.ones(n))
    )
    state = mapper.state
    assert state.pending  # both parts a query absorbs: the pending day
    assert state.entries.window_rows().size  # and the open window
    arrays, meta = state.to_arrays()
    path = tmp_path_factory.mktemp("components") / "rhythm.aion"
    write_map(path, arrays, {"state": meta})
    return path


def _tables(path: Path, times: list[int]) -> list[tuple[object, object]]:
    whole = load_map(path).state
    light = load_map(path, forecast_only=True).state
    assert whole.temporal.fourier_loaded
    assert not light.temporal.fourier_loaded
    return [(predict_table(whole, t), predict_table(light, t)) for t in times]


def test_forecasts_without_the_sums_equal_the_whole_maps(map_path: Path) -> None:
    times = [MONDAY + 21 * DAY + k * 7 * HOUR for k in range(1, 12)]
    for whole, light in _tables(map_path, times):
        assert whole.flow_family.tolist() == light.flow_family.tolist()
        assert whole.direction_family.tolist() == light.direction_family.tolist()
        for name in ("flow", "flow_var", "rate"):
            np.testing.assert_array_equal(getattr(whole, name), getattr(light, name))
    families = set(whole.flow_family.tolist()) | set(whole.direction_family.tolist())
    assert any(f.startswith("fremen") for f in families), families  # the case under test


def test_stored_components_equal_the_query_views(map_path: Path) -> None:
    """The components written (rows the pending day touched: copied and absorbed; the
    others: read in place with the global block absorbed) equal a forecaster's on the whole
    query view, and both kinds of rows are there."""
    from aion_cli.engine.temporal.forecast import Forecaster, PoolStats

    state = load_map(map_path, writable=True).state
    rows = state.entries.canonical_order()
    stored = state.forecast_components(rows)
    touched = np.union1d(state.pending.consolidated().cnt_entry, state.entries.window_rows())
    at_rows = rows[stored.total_pos]
    assert np.isin(at_rows, touched).any()
    assert (~np.isin(at_rows, touched)).any()
    view = state.query_temporal()
    groups = np.zeros(rows.size, np.int64)
    pool = PoolStats.of(state.params, view, rows, groups, 1)
    fc = Forecaster(state.params, view, rows, groups, pool)
    idx, coef = fc.total_components(stored.total_pos)
    np.testing.assert_array_equal(idx, stored.period_idx)
    np.testing.assert_array_equal(coef, stored.coef_total)
    depth = stored.bins_depth
    fc.ensure_bins(stored.bins_pos, depth)
    np.testing.assert_array_equal(fc.coef_bins[stored.bins_pos, :, :depth], stored.coef_bins)


def test_the_query_reads_no_fourier_sums(map_path: Path) -> None:
    with open_map(map_path, in_place=True) as members:
        state = MapState.from_arrays(
            members, members.manifest["state"], writable=False, copy=False, forecast_only=True
        )
        predict_table(state, MONDAY + 22 * DAY)
        read = set(members.read_names)
    assert "temporal_cnt_fourier" not in read
    assert "temporal_obs_fourier" not in read
    assert PREFIX + "coef_total" in read


def test_a_query_state_cannot_be_written(map_path: Path) -> None:
    state = load_map(map_path, forecast_only=True).state
    with pytest.raises(ValueError, match="cannot be stored"):
        state.to_arrays()


def test_components_outside_the_map_are_refused(map_path: Path) -> None:
    with open_map(map_path) as members:
        arrays = {name: np.array(members[name]) for name in members}
        params = MapState.from_arrays(arrays, members.manifest["state"]).params
    n = int(arrays["entry_kind"].shape[0])
    stored = FremenComponents.from_arrays(arrays, n, params)
    assert stored is not None
    bad = dict(arrays)
    bad[PREFIX + "period_idx"] = np.full_like(arrays[PREFIX + "period_idx"], 200)
    with pytest.raises(MapCorruptError, match="period outside"):
        FremenComponents.from_arrays(bad, n, params)
    bad = dict(arrays)
    del bad[PREFIX + "coef_bins"]
    with pytest.raises(MapCorruptError, match="missing"):
        FremenComponents.from_arrays(bad, n, params)


def test_without_stored_components_the_sums_are_read(map_path: Path, tmp_path: Path) -> None:
    """A map written before components were stored is read whole, and forecasts the same."""
    with open_map(map_path) as members:
        arrays = {n: np.array(members[n]) for n in members if not n.startswith(PREFIX)}
        meta = members.manifest["state"]
    old = tmp_path / "old.aion"
    write_map(old, arrays, {"state": meta})
    state = load_map(old, forecast_only=True).state
    assert state.temporal.fourier_loaded
    t = MONDAY + 22 * DAY + 3 * HOUR
    np.testing.assert_array_equal(
        predict_table(state, t).flow, predict_table(load_map(map_path).state, t).flow
    )


def test_a_forecast_beyond_the_stored_components_is_a_clear_error(map_path: Path) -> None:
    from aion_cli.engine.temporal.forecast import Forecaster, PoolStats

    state = load_map(map_path, forecast_only=True).state
    view = state.query_temporal()
    rows = state.entries.canonical_order()
    groups = np.zeros(rows.size, np.int64)
    pool = PoolStats.of(state.params, view, rows, groups, 1)
    fc = Forecaster(state.params, view, rows, groups, pool)
    with pytest.raises(MapFileError, match="without its Fourier sums"):
        fc.ensure_total()


def test_narrow_counts_widen_when_a_day_would_overflow_them() -> None:
    """A query's counts stay in their stored integer type until a sum would not fit."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.temporal.absorption import absorb
    from aion_cli.engine.temporal.model import empty_state
    from aion_cli.engine.temporal.params import TemporalParams

    params = TemporalParams.from_config(ModelConfig())
    state: TemporalState = empty_state(params, 2)
    state.fourier_loaded = False
    state.cnt_fourier = np.zeros((2, params.values, 0), np.complex128)
    state.cnt_profile = np.zeros((2, params.values, params.n_profile), np.uint8)
    state.touch(np.array([1]))  # row 1 written (as a map read with it stored would say)
    state.cnt_profile[1, 0, :] = 250
    window = (MONDAY + 9 * HOUR) // (600 * 10**9)
    values = np.zeros((1, params.values))
    values[0, 0] = 3.0
    day = DayWindows(
        np.array([window]), np.array([True]), np.zeros(0, np.int64), np.zeros(0, np.int64),
        np.array([1]), np.array([0]), values,
    )
    absorb(params, state, day, 600 * 10**9)
    assert state.cnt_profile.dtype == np.uint8
    assert state.cnt_profile[1, 0].max() == 253
    absorb(params, state, day, 600 * 10**9)
    assert state.cnt_profile.dtype == np.float64
    assert state.cnt_profile[1, 0].max() == 256.0
    assert state.cnt_profile.sum() == 48 * 250 + 6



def test_an_entry_whose_components_the_map_lacks_does_not_choose_fremen(map_path: Path) -> None:
    """A map written under older rules of the family choice stores components for the
    entries that chose FreMEn then; today's rules may send another entry to FreMEn (an
    entry's default became the profile its group chose). Read for queries without its sums,
    such an entry takes its best other family instead of stopping the query ("forecast
    components do not cover what was asked"): here the choice is made as if the first
    FreMEn entry's components were missing; every other entry chooses as the map did."""
    from aion_cli.engine.temporal.query_state import choose

    state = load_map(map_path, forecast_only=True).state
    view = state.query_temporal()
    assert not view.fourier_loaded
    rows = state.entries.canonical_order()
    groups, n_groups = state.groups(rows)
    stored = state.components
    assert stored is not None
    flow, _, _ = choose(state.params, view, rows, groups, n_groups, stored)
    names = state.params.flow
    fremen = [p for p in stored.total_pos.tolist() if names[flow[p]].startswith("fremen")]
    assert fremen  # the case under test
    dropped = fremen[0]
    keep = stored.total_pos != dropped
    fewer = FremenComponents(
        stored.total_pos[keep], stored.period_idx[keep], stored.coef_total[keep],
        stored.bins_pos, stored.bin_idx, stored.coef_bins,
    )
    got, _, _ = choose(state.params, view, rows, groups, n_groups, fewer)
    assert not names[got[dropped]].startswith("fremen")
    others = np.arange(rows.size) != dropped
    assert got[others].tolist() == flow[others].tolist()
    # the whole map (its sums read) may choose FreMEn anywhere: the same as written
    whole = load_map(map_path).state
    full, _, _ = choose(whole.params, whole.query_temporal(), rows, groups, n_groups, fewer)
    assert full.tolist() == flow.tolist()
