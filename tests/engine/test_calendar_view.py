"""A ``profile = "week"`` map forecasts with the calendar its own evidence asks for
(engine/temporal/calendar_view.py), on logs drawn from known rates
(``benchmarks/forecast_scenarios.py``): a place busy on Wednesdays only keeps its week's
hours (the market forecast on Wednesday, not spread over the weekdays); weekday rushes the same
every week are forecast as the weekday/weekend map of the same logs forecasts them, to
rounding; so are two days, too few to judge (one Monday standing for all Mondays)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli import api
from aion_cli.cli.info_map import calendar_text
from aion_cli.engine.temporal.shape_prior import group_shapes, pool_week, pooled_week_bins
from aion_cli.formats.mapfile import read_map
from benchmarks.forecast_scenarios import SCENARIOS, market_rates
from tests.cli.conftest import run_json
from tests.engine.test_week_evidence import TRAIN_DAYS, _build, _logs

WEEK = 'profile = "week"\n'


def _week_config(folder: Path) -> Path:
    path = folder / "week.toml"
    path.write_text(WEEK)
    return path


def _hourly_totals(site: Path, start: str, end: str) -> np.ndarray:
    """The map's forecast total per hour at each hour from ``start`` to ``end`` (UTC)."""
    table = api.Map.load(site).predict_series(start, end, "1h", tz="UTC", layer="cells")
    return np.nansum(np.asarray(table.flow_per_hour, dtype=np.float64), axis=0)


def _families(site: Path) -> object:
    """The families chosen, counted (the observed bins are each profile's own)."""
    doc = run_json("info", site, "--format", "json")["families"]
    return {k: v for k, v in doc.items() if k not in ("calendar", "observed_bins")}


@pytest.fixture(scope="module")
def market_maps(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("market_week")
    logs = _logs("market", folder)
    week = _build(logs, folder / "week.aion", "--config", _week_config(folder))
    default = _build(logs, folder / "default.aion")
    return week, default


def test_a_weekday_market_is_forecast_on_its_weekday(market_maps: tuple[Path, Path]) -> None:
    """15 days from Monday 2026-01-05: two Wednesdays with place 0 at 25 people an hour
    08-14. The week map's evidence asks for the week, so the third Wednesday's 09-13 h are
    forecast at most of the true total (29 an hour: 25 + 3 + 1; two Wednesdays, shrunk) and
    Thursday's near 4.5, where the
    weekday/weekend map of the same logs spreads the market over five weekdays (about
    (25 + 4 · 0.5) / 5 + 4 = 9.4 both days)."""
    week, default = market_maps
    assert SCENARIOS["market"].zone == "UTC"
    calendar = run_json("info", week, "--format", "json")["families"]["calendar"]
    assert calendar["calendar"] == "week"
    assert 'profile = "week", the week\'s hours' in calendar_text(calendar, "week")
    hour = np.arange(9, 14)
    truth_wed = market_rates(np.full(5, 2), hour, np.zeros(5)).sum(axis=1)  # per hour
    truth_thu = market_rates(np.full(5, 3), hour, np.zeros(5)).sum(axis=1)
    wed = _hourly_totals(week, "2026-01-21T09:00", "2026-01-21T13:00")
    thu = _hourly_totals(week, "2026-01-22T09:00", "2026-01-22T13:00")
    wed_default = _hourly_totals(default, "2026-01-21T09:00", "2026-01-21T13:00")
    thu_default = _hourly_totals(default, "2026-01-22T09:00", "2026-01-22T13:00")
    # two Wednesdays, each entry's week bins shrunk toward its parents': most of the market
    assert (wed > 0.6 * truth_wed).all()
    assert (wed < 1.25 * truth_wed).all()
    # Thursday's hours from two Thursdays each (noisy hour by hour), near the truth in all
    assert abs(thu.mean() - truth_thu.mean()) < 0.25 * truth_thu.mean()
    # the default map cannot tell the days apart: the market spread over the weekdays
    assert np.abs(wed_default - thu_default).max() < 0.2 * thu_default.min()
    assert (np.abs(wed - truth_wed) < np.abs(wed_default - truth_wed)).all()
    assert abs(thu.mean() - truth_thu.mean()) < abs(thu_default.mean() - truth_thu.mean())


@pytest.mark.parametrize(("name", "days"), [("weekly", TRAIN_DAYS), ("weekly", 2)])
def test_a_week_map_without_the_evidence_forecasts_as_weekdays_and_weekends(
    name: str, days: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Weekday rushes and quiet weekends, the same every week (15 days: the week's day-ahead
    gain is 0), or two days (no weekday closed twice, as Lincoln's four days): the week map's
    evidence says ``day_weekend``, and it forecasts every hour of the next week exactly as
    the weekday/weekend map of the same logs (the same sums pooled: families, scores and
    flows alike), where the week's own bins would forecast a weekday it saw once (or never)
    from that day alone."""
    import tests.engine.test_week_evidence as evidence

    monkeypatch.setattr(evidence, "TRAIN_DAYS", days)
    logs = _logs(name, tmp_path)
    week = _build(logs, tmp_path / "week.aion", "--config", _week_config(tmp_path))
    default = _build(logs, tmp_path / "default.aion")
    calendar = run_json("info", week, "--format", "json")["families"]["calendar"]
    assert calendar["calendar"] == "day_weekend"
    assert "its hours pooled into weekdays and weekends" in calendar_text(calendar, "week")
    assert _families(week) == _families(default)
    start, end = "2026-01-19T00:00", "2026-01-25T23:00"  # Monday to Sunday after 15 days
    np.testing.assert_allclose(
        _hourly_totals(week, start, end), _hourly_totals(default, start, end), rtol=1e-9
    )


def test_pooled_bins_are_the_weekday_and_weekend_hours() -> None:
    """Monday 00 h is weekday hour 0, Friday 23 h weekday 23, Saturday 00 h weekend 0
    (bin 24), Sunday 23 h weekend 23 (bin 47); with half-hour bins the same by 48."""
    np.testing.assert_array_equal(pooled_week_bins(np.array([0, 4 * 24 + 23, 5 * 24, 167]), 24),
                                  [0, 23, 24, 47])
    np.testing.assert_array_equal(pooled_week_bins(np.array([48 * 2 + 5, 48 * 6 + 1]), 48),
                                  [5, 48 + 1])


def test_a_groups_week_departs_from_its_own_weekdays() -> None:
    """Two groups watched 100 windows in every hour of the week, each 0.5 a window by day
    (07-20) and 0.01 at night; the first also 10 a window on Wednesdays 08-14 (a market).
    The map's Wednesday is the market's; the flat group's week is shrunk toward its own
    weekdays, so its Wednesday 10 h equals its Thursday 10 h (toward the map's week it was
    lifted by the market and its other weekdays lowered), while the market group's
    Wednesday stays many times its Thursday."""
    per_day = 24
    hour = np.tile(np.arange(per_day), 7)
    weekday = np.repeat(np.arange(7), per_day)
    base = np.where((hour >= 7) & (hour < 20), 0.5, 0.01)
    market = np.where((weekday == 2) & (hour >= 8) & (hour < 14), 10.0, base)
    w = np.full((2, 7 * per_day), 100.0)
    s = np.stack([market, base]) * w
    shapes, _ = group_shapes(s, w, 1.0, bins_per_day=per_day)
    wed, thu = 2 * per_day + 10, 3 * per_day + 10
    assert shapes[1, wed] == pytest.approx(shapes[1, thu], rel=1e-12)
    assert shapes[0, wed] > 5.0 * shapes[0, thu]
    # the pooled weekday/weekend shapes are the same sums' (48 bins): a flat group's day
    np.testing.assert_allclose(pool_week(w, per_day)[:, :per_day], 500.0)


def test_a_fleet_of_weekdays_may_choose_the_week(tmp_path: Path) -> None:
    """The market's Monday-to-Friday logs only (days 0-4 and 7-11, and the third Monday,
    pending, which closes the second Friday): every weekday closed twice, no weekend day
    ever. A day never observed takes its kind's hours under both calendars, so it is no
    evidence either way: the week map chooses the week on its Wednesdays and forecasts the
    third Wednesday's market there, not spread over five weekdays. Counting the fewest days
    of all seven (0: the weekend), such a map could never choose it."""
    logs = _logs("market", tmp_path, cuts=(5, 7, 12, 14))
    weekdays = [logs[0], logs[2], logs[4]]
    week = _build(weekdays, tmp_path / "week.aion", "--config", _week_config(tmp_path))
    sums = read_map(week)[0]["temporal_week_sums"]
    np.testing.assert_array_equal(sums[0].reshape(7, 24).max(axis=1), [2] * 5 + [0, 0])
    calendar = run_json("info", week, "--format", "json")["families"]["calendar"]
    assert calendar["weekday_days"] == 2
    assert calendar["calendar"] == "week"
    assert calendar["gain"] > 3.0
    hour = np.arange(9, 14)
    truth_wed = market_rates(np.full(5, 2), hour, np.zeros(5)).sum(axis=1)
    truth_thu = market_rates(np.full(5, 3), hour, np.zeros(5)).sum(axis=1)
    wed = _hourly_totals(week, "2026-01-21T09:00", "2026-01-21T13:00")
    thu = _hourly_totals(week, "2026-01-22T09:00", "2026-01-22T13:00")
    assert (wed > 0.6 * truth_wed).all()  # not the weekdays' (25 + 4 · 0.5) / 5 + 4 = 9.4
    assert abs(thu.mean() - truth_thu.mean()) < 0.25 * truth_thu.mean()


def test_too_few_days_are_counted_on_the_days_observed() -> None:
    """``weekday_days`` is the fewest days of those the map observed: a map of two weeks of
    weekdays, each closed twice, counts 2 (not its weekend's 0), one whose Saturday was
    closed once beside them 1, and a map with no closed day 0."""
    from aion_cli.engine.temporal.week_evidence import calendar_choice, empty_sums

    sums = empty_sums(24)
    sums[0, : 5 * 24] = 2.0
    sums[3, 2 * 24 + 10] = 10.0  # a Wednesday's gain, over the 3-nat margin
    assert calendar_choice(sums, 3.0) == {"calendar": "week", "gain": 10.0, "weekday_days": 2}
    sums[0, 5 * 24 + 9] = 1.0  # a Saturday 09 h, once
    assert calendar_choice(sums, 3.0)["weekday_days"] == 1
    assert calendar_choice(sums, 3.0)["calendar"] == "day_weekend"
    assert calendar_choice(empty_sums(24), 3.0)["weekday_days"] == 0


def test_the_summary_names_the_calendar_the_forecasts_use(tmp_path: Path) -> None:
    """The market's first 14 days, Monday to Sunday: its second Sunday is the pending day, so
    the closed days saw Sunday once (too few to judge), while a query, which absorbs the
    pending day, sees every day of the week twice and forecasts with the week's hours. The
    manifest's calendar (``aion info``'s row: 'forecasts use ... pooled into weekdays and
    weekends') had been the closed days' alone; it is now the one the query's view chooses."""
    from aion_cli.engine.temporal.calendar_view import forecast_calendar
    from aion_cli.engine.temporal.week_evidence import calendar_choice
    from aion_cli.mapquery import load_map

    first = _logs("market", tmp_path, cuts=(14,))[0]
    week = _build([first], tmp_path / "week.aion", "--config", _week_config(tmp_path))
    closed = read_map(week)[0]["temporal_week_sums"][0].reshape(7, 24).max(axis=1)
    np.testing.assert_array_equal(closed, [2] * 6 + [1])  # the second Sunday pending
    state = load_map(week).state
    view = state.query_temporal()
    assert forecast_calendar(state.params, view) == "week"
    calendar = run_json("info", week, "--format", "json")["families"]["calendar"]
    assert calendar == calendar_choice(view.week_sums, state.config.family_margin)
    assert calendar["calendar"] == "week"
    assert calendar["weekday_days"] == 2
    assert 'profile = "week", the week\'s hours' in calendar_text(calendar, "week")
