"""The paper's comparison protocol: metric plumbing on known views, then one small scene."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.evaluation.office import (
    PAPER_TABLE,
    FlowSeries,
    MapView,
    compare_views,
    evaluated_times,
    expected_flow_correlations,
    reference_forecasts,
    run_office,
    separable_flow_correlations,
)
from aion_cli.evaluation.office_directions import DIRECTION_MAPS


def view(seed: int = 0, n: int = 50) -> MapView:
    rng = np.random.default_rng(seed)
    return MapView(rng.uniform(0.1, 1.0, n), rng.uniform(1.0, 5.0, n), rng.uniform(-3, 3, n))


def test_identical_views_compare_as_identical() -> None:
    v = view()
    rows = compare_views(v, v)
    assert rows["Entropy"]["js"] == pytest.approx(0.0, abs=1e-12)
    assert rows["Flow"]["bhattacharyya"] == pytest.approx(0.0, abs=1e-12)
    assert rows["Flow"]["wasserstein"] == pytest.approx(0.0, abs=1e-12)
    assert rows["Direction"]["wasserstein"] == pytest.approx(0.0, abs=1e-9)
    assert rows["Direction"]["circular_correlation"] == pytest.approx(1.0)


def test_rotated_directions_give_the_rotation_angle() -> None:
    v = view(1)
    turned = MapView(v.entropy, v.flow, v.angle + math.radians(40))
    rows = compare_views(v, turned)
    assert rows["Direction"]["wasserstein"] == pytest.approx(40.0)
    assert rows["Direction"]["circular_correlation"] == pytest.approx(1.0)


def test_cells_without_flow_are_left_out() -> None:
    v = view(2)
    empty = MapView(v.entropy, np.where(np.arange(50) < 25, v.flow, 0.0), v.angle)
    assert compare_views(v, empty)["Direction"]["cells"] == 25


@pytest.mark.slow
def test_reference_forecasts_of_a_daily_pattern() -> None:
    """Counts that repeat every day exactly: yesterday's counts and the hour-of-day mean are
    both the truth; on the first day there is no yesterday."""
    window, day = 600 * 10**9, 86_400 * 10**9
    starts = np.arange(3 * 144, dtype=np.int64) * window + 10 * day
    hours = (starts // 3_600_000_000_000) % 24
    counts = np.stack([hours % 5, (hours * 7) % 3, np.zeros_like(hours)], axis=1).astype(float)
    w = 2 * 144 + 50  # the third day
    previous, hour_mean = reference_forecasts(counts, starts, w)
    np.testing.assert_array_equal(previous, counts[w])
    np.testing.assert_array_equal(hour_mean, counts[w])
    first, _ = reference_forecasts(counts, starts, 10)
    assert np.isnan(first).all()
    noisy = counts.copy()
    noisy[w - 144, 0] += 6.0  # yesterday differs at one place: the hour mean moves by 6/18
    previous, hour_mean = reference_forecasts(noisy, starts, w)
    assert previous[0] == counts[w, 0] + 6.0
    assert hour_mean[0] == pytest.approx(counts[w, 0] + 6.0 / 18)  # 6 windows/hour x 3 days


def _series(counts: np.ndarray, predicted: np.ndarray, ids: list[int]) -> FlowSeries:
    """A scene over windows 0..W-1 (starts 600 s apart) whose forecasts cover every pair."""
    w, m = counts.shape
    starts = np.arange(w, dtype=np.int64) * 600 * 10**9
    return FlowSeries(
        place=np.tile(np.array(ids, np.uint64), w),
        window_start=np.repeat(starts, m),
        predicted=predicted.ravel().astype(float),
        place_ids=np.array(ids, np.uint64),
        starts=starts,
        counts=counts.astype(float),
    )


def test_expected_flow_is_the_other_scenes_mean() -> None:
    """Three scenes: the leave-one-out mean of the others' counts is the expected flow, so a
    forecast that is an affine function of it correlates 1, one that is its negation -1; place
    ids listed in another order are matched by id; fewer than two scenes give NaN."""
    rng = np.random.default_rng(3)
    counts = [rng.poisson(3.0, (6, 4)).astype(float) for _ in range(3)]
    ids = [11, 5, 7, 2]
    expected0 = (counts[1] + counts[2]) / 2
    shuffled = [2, 0, 3, 1]  # scene 2 lists its places in another order
    scene2 = _series(counts[2][:, shuffled], np.zeros((6, 4)), [ids[k] for k in shuffled])
    series = [
        _series(counts[0], 2.0 * expected0 + 1.0, ids),
        _series(counts[1], -((counts[0] + counts[2]) / 2), ids),
        scene2,
    ]
    corr = expected_flow_correlations(series)
    assert corr[0] == pytest.approx(1.0)
    assert corr[1] == pytest.approx(-1.0)
    assert math.isnan(corr[2])  # a constant forecast has no correlation
    assert all(math.isnan(c) for c in expected_flow_correlations(series[:1]))


def test_where_and_when_apart() -> None:
    """Every scene's counts are the same separable flow ``times[w] * places[i]``, so the
    expected flow is that product. A forecast with the right places and wrong times gains
    nothing from the true places and reaches 1 with the true times; one with the right times
    and wrong places the other way round; both true is 1 for any forecast; fewer than two
    scenes give NaN."""
    rng = np.random.default_rng(5)
    times, places = rng.uniform(1, 5, 6), rng.uniform(1, 5, 4)
    other_times, other_places = rng.uniform(1, 5, 6), rng.uniform(1, 5, 4)
    truth = np.outer(times, places)
    ids = [3, 1, 4, 9]
    series = [
        _series(truth, np.outer(other_times, places), ids),  # right places, wrong times
        _series(truth, np.outer(times, other_places), ids),  # right times, wrong places
        _series(truth, np.ones((6, 4)), ids),
    ]
    wrong_times, wrong_places, _ = separable_flow_correlations(series)
    assert wrong_times["flow_correlation_true_times"] == pytest.approx(1.0)
    assert wrong_times["flow_correlation_true_places"] < 0.99
    assert wrong_times["flow_correlation_true_places"] == pytest.approx(
        wrong_times["flow_correlation_separable"]
    )
    assert wrong_places["flow_correlation_true_places"] == pytest.approx(1.0)
    assert wrong_places["flow_correlation_true_times"] < 0.99
    for scene in (wrong_times, wrong_places):
        assert scene["flow_correlation_separable_oracle"] == pytest.approx(1.0)
    alone = separable_flow_correlations(series[:1])
    assert all(math.isnan(v) for v in alone[0].values())


def test_where_by_the_robots_coverage() -> None:
    """Six places, three seen in every window and three in a third of them: a forecast right
    at the first three and reversed at the others correlates 1 and -1 in the two groups;
    without the coverage both are NaN."""
    import dataclasses

    times = np.linspace(1.0, 2.0, 6)
    places = np.array([1.0, 2.0, 3.0, 1.0, 2.0, 3.0])
    truth = np.outer(times, places)
    guessed = np.outer(times, np.array([1.0, 2.0, 3.0, 3.0, 2.0, 1.0]))
    ids = [10, 11, 12, 13, 14, 15]
    share = np.array([1.0, 0.95, 0.9, 0.33, 0.33, 0.2])
    series = [
        dataclasses.replace(_series(truth, guessed, ids), seen_share=share),
        dataclasses.replace(_series(truth, truth, ids), seen_share=share),
    ]
    scene = separable_flow_correlations(series)[0]
    assert scene["places_seen_all_day"] == 3
    assert scene["place_correlation_seen_all_day"] == pytest.approx(1.0)
    assert scene["place_correlation_seen_in_part"] == pytest.approx(-1.0)
    unknown = separable_flow_correlations([_series(truth, guessed, ids)] * 2)[0]
    assert math.isnan(unknown["place_correlation_seen_all_day"])
    assert math.isnan(unknown["places_seen_all_day"])


def test_expected_flow_leaves_out_pairs_no_other_scene_has() -> None:
    """A scene's pair that no other scene recorded (a window past their end) is not scored."""
    rng = np.random.default_rng(4)
    short = rng.poisson(2.0, (4, 3)).astype(float)
    long_counts = rng.poisson(2.0, (6, 3)).astype(float)
    truth = np.vstack([short, np.zeros((2, 3))])
    wild = truth.copy()
    wild[4:] = 99.0  # the forecast is wrong where nothing can check it
    series = [_series(long_counts, wild, [1, 2, 3]), _series(short, np.ones((4, 3)), [1, 2, 3])]
    corr = expected_flow_correlations(series)
    assert corr[0] == pytest.approx(1.0)


def test_one_small_office_scene_end_to_end() -> None:
    result = run_office(scenes=1, days=0.5, eval_hours=4)
    table = {(r["map_type"], r["data_type"]): r for r in result.table()}
    assert set(table) == set(PAPER_TABLE)
    js, _std = table[("Flow", "Historical")]["js"]
    assert 0.0 <= js <= 1.0
    assert table[("Direction", "Historical")]["js"] is None
    disp, _ = table[("Direction", "Historical")]["wasserstein"]
    assert 0.0 <= disp <= 180.0
    scene = result.scenes[0]
    assert scene["detections"] > 0
    assert scene["truth"]["places_compared"] > 0
    assert scene["grid_bytes"] > 0
    assert result.figure is not None
    directions = {r["map"]: r for r in result.directions()}
    assert set(directions) == set(DIRECTION_MAPS)
    assert 0 < scene["directions"]["places"] <= scene["truth"]["places_compared"]
    for row in directions.values():
        assert row["scenes"] == 1
        assert 0.0 <= row["js"][0] <= 1.0
        assert 0.0 <= row["dominant_deg"][0] <= 180.0


def test_truth_means_skip_missing_figures() -> None:
    """Scene means of the truth figures: NaN-skipping, NaN where no scene has a figure, empty
    without any compared scene; the sentence shows them rounded and n/a for NaN."""
    from aion_cli.evaluation.office import OfficeResult, truth_sentence

    none = OfficeResult(scenes=[{"truth": {"places_compared": 0.0}}])
    assert none.truth_means() == {}
    result = OfficeResult(
        scenes=[
            {"truth": {"places_compared": 5.0, "flow_correlation": 0.2, "direction_js": 0.4,
                       "flow_correlation_expected": math.nan}},
            {"truth": {"places_compared": 7.0, "flow_correlation": 0.4, "direction_js": 0.2,
                       "flow_correlation_previous_day": 0.1}},
            {"truth": {"places_compared": 0.0, "flow_correlation": 9.0}},  # not compared
        ]
    )
    means = result.truth_means()
    assert means["flow_correlation"] == pytest.approx(0.3)
    assert means["direction_js"] == pytest.approx(0.3)
    assert means["flow_correlation_previous_day"] == pytest.approx(0.1)
    assert math.isnan(means["flow_correlation_expected"])
    assert math.isnan(means["flow_correlation_oracle"])
    text = truth_sentence(means)
    assert "correlates 0.300 with one day's true counts" in text
    assert "n/a with the expected flow" in text


def test_the_grid_comparison_places_aions_bins_at_their_centres() -> None:
    """The grid knows its bins by their centres only, so Table I reads aion's directions the
    same way, whatever heading sums (own, or filled from the room) the table carries: a
    corridor along +x compares as the bin's centre, 22.5 degrees, on both sides."""
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.query import predict_table
    from aion_cli.evaluation.office import discretise
    from tests.engine.engine_builders import T0, S, detections

    cfg = ModelConfig(window_s=600.0, stability_s=0.0)
    m = Mapper(cfg)
    m.set_fixed_sensor(T0, T0 + 1200 * S)
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0.0]] * 20, heading=[0.0] * 20))
    m.advance(T0 + 600 * S)
    table = predict_table(m.state, T0 + 1800 * S)
    assert table.bin_cos is not None  # the table itself places the bin at 0 degrees
    (row,) = np.flatnonzero(np.nan_to_num(table.descriptors.flow_per_window) > 0)
    assert abs(table.descriptors.dominant_angle[row]) < math.radians(1.0)  # (the prior's bins)
    seen = discretise(table, table.xyz[[row], :2], radius=0.5)
    p = table.descriptors.probabilities[row]
    centres = -math.pi + (np.arange(len(p)) + 0.5) * 2 * math.pi / len(p)
    expected = math.atan2(float(p @ np.sin(centres)), float(p @ np.cos(centres)))
    assert seen.angle[0] == pytest.approx(expected, abs=1e-12)
    assert expected > math.radians(15.0)  # the centre, not the walking direction


def test_a_scene_is_evaluated_at_the_hours_of_its_last_day() -> None:
    """Two days from Monday 00:00 (ticks up to 23:59:59.5 on Tuesday): Tuesday 00:00 .. 23:00,
    each at the start of its hour (they had been the last tick and the 23 hours before it,
    half a second before each hour: the hour before's forecast)."""
    t0 = int(np.datetime64("2026-01-05T00:00", "ns").astype(np.int64))
    hour = 3_600_000_000_000
    dt = 500_000_000
    n_ticks = 2 * 24 * 3600 * 2
    times = evaluated_times(t0 + n_ticks * dt, 24)
    assert times.tolist() == [t0 + 24 * hour + k * hour for k in range(24)]
