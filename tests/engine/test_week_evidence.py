"""Which calendar the map's data asks for (``temporal_week_sums``,
engine/temporal/week_evidence.py), on logs drawn from known rates
(``benchmarks/forecast_scenarios.py``): a place busy on Wednesdays only asks for the week's
hours; weekday rushes and quieter weekends, the same every week, do not; two days are too
few to judge; continuing and merging give one build's sums and choice."""

from __future__ import annotations

import itertools
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.engine.temporal.week_evidence import MIN_DAYS, calendar_choice, rates
from aion_cli.formats.mapfile import read_map
from benchmarks.forecast_scenarios import SCENARIOS, draw, spans, write_csv
from tests.cli.conftest import run, run_json

TRAIN_DAYS = 15  # Monday to Monday: every weekday closed twice, the last Monday pending


def _logs(name: str, folder: Path, cuts: tuple[int, ...] = ()) -> list[Path]:
    """The scenario's first ``TRAIN_DAYS`` days as logs of consecutive days cut at
    ``cuts`` (one log without)."""
    scenario = replace(SCENARIOS[name], train_days=TRAIN_DAYS, test_days=0)
    rng = np.random.default_rng(scenario.seed)
    drawn = draw(scenario, rng)
    hours = drawn.hours
    out = []
    edges = [0, *cuts, TRAIN_DAYS]
    for k, (a, b) in enumerate(itertools.pairwise(edges)):
        sl = slice(int(np.searchsorted(hours.day, a)), int(np.searchsorted(hours.day, b)))
        start, end = int(hours.start_s[sl.start]) * 10**9, int(hours.start_s[sl.stop - 1])
        rows = np.flatnonzero((drawn.t_ns >= start) & (drawn.t_ns < (end + 3600) * 10**9))
        csv, log = folder / f"{name}{k}.csv", folder / f"{name}{k}.mcap"
        write_csv(csv, drawn, rows, rng, scenario.jitter_m)
        args = ["convert", csv, "-o", log, "--tz", scenario.zone, "--force"]
        assert run(*args, *spans(hours.start_s[sl], drawn.watched[sl])).exit_code == 0
        out.append(log)
    return out


def _build(logs: list[Path], site: Path, *extra: str | Path) -> Path:
    result = run("build", *logs, "-o", site, "--workers", "1", "-q", *extra)
    assert result.exit_code == 0, result.stderr
    return site


def _sums(site: Path) -> np.ndarray:
    out: np.ndarray = read_map(site)[0]["temporal_week_sums"]
    return out


def _calendar(site: Path) -> dict[str, Any]:
    out: dict[str, Any] = run_json("info", site, "--format", "json")["families"]["calendar"]
    return out


@pytest.fixture(scope="module")
def market(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("market")
    return _build(_logs("market", folder), folder / "market.aion")


def test_a_weekday_market_asks_for_the_week(market: Path) -> None:
    """Place 0 at 25 people an hour on Wednesdays 08-14 and 0.5 on other days: the second
    Wednesday, forecast with the first's hours, beats the weekday hours that spread the
    market over five days, so the week's day-ahead gain passes the margin (3 nats) and every
    weekday was closed twice."""
    calendar = _calendar(market)
    assert calendar["calendar"] == "week"
    assert calendar["weekday_days"] == MIN_DAYS
    assert calendar["gain"] > 3.0
    sums = _sums(market)
    assert sums.shape == (4, 168)
    # the closed days: two of each weekday (the third Monday is pending), every hour seen
    np.testing.assert_array_equal(sums[0].reshape(7, 24).max(axis=1), [2] * 7)
    # the week's gain lies on Wednesday's market hours, where the rate differs from the
    # weekday hours': over half of it in 08-14 h of Wednesday (bins 56..61)
    assert sums[3][2 * 24 + 8 : 2 * 24 + 14].sum() > 0.5 * sums[3].sum()
    # and the week's rates find the market: the three places' 29 people at Wednesday 10 h,
    # 4.5 at Thursday's (6.4 times: over 3 times, shrunk toward the weekday hours' mean)
    week, day_weekend = rates(sums, 1.0, 24)
    assert week[2 * 24 + 10] > 3 * week[3 * 24 + 10]
    assert day_weekend[2 * 24 + 10] == day_weekend[3 * 24 + 10]
    text = run("info", market).stdout
    assert "calendar" in text
    assert "profile = \"week\"" in " ".join(text.split())


def test_the_same_rhythm_every_week_keeps_weekdays_and_weekends(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """Weekday rushes at 08 and 17 h, quieter weekends, the same on every weekday: the week's
    hours forecast no better, so the map keeps weekdays and weekends with enough days to
    judge."""
    folder = tmp_path_factory.mktemp("weekly")
    calendar = _calendar(_build(_logs("weekly", folder), folder / "weekly.aion"))
    assert calendar["weekday_days"] >= MIN_DAYS
    assert calendar["calendar"] == "day_weekend"
    assert calendar["gain"] <= 3.0


def test_too_few_days_keep_the_default(tmp_path: Path) -> None:
    """Two days of the market scenario (a Monday closed, the Tuesday pending): the one day
    observed was closed once, so the calendar stays weekdays and weekends whatever the gain
    (nor is there a gain: the Monday had no earlier day to be scored against)."""
    logs = _logs("market", tmp_path, cuts=(2,))
    calendar = _calendar(_build(logs[:1], tmp_path / "two.aion"))
    assert calendar == {"calendar": "day_weekend", "gain": 0.0, "weekday_days": 1}
    assert calendar_choice(np.zeros((4, 0)), 3.0)["calendar"] == "day_weekend"


def test_continued_and_merged_maps_choose_as_one_build(
    market: Path, tmp_path: Path
) -> None:
    """The market's logs cut after a week: a map continued with ``build --map`` holds one
    build's sums to the bit; part maps merged hold its days, detections and units and choose
    the same (their gain differs: each part's days were scored against its own earlier days)."""
    first, second = _logs("market", tmp_path, cuts=(8,))
    whole = _sums(market)
    continued = _build([first], tmp_path / "continued.aion")
    _build([second], continued, "--map", continued)
    np.testing.assert_array_equal(_sums(continued), whole)
    assert _calendar(continued) == _calendar(market)
    parts = [_build([log], tmp_path / f"part{k}.aion", "--part") for k, log in
             enumerate((first, second))]  # fmt: skip
    merged = tmp_path / "merged.aion"
    assert run("merge", *parts, "-o", merged, "-q").exit_code == 0
    np.testing.assert_array_equal(_sums(merged)[:3], whole[:3])
    assert _calendar(merged)["calendar"] == "week"


def test_a_map_written_before_the_member_continues_into_one_with_it(tmp_path: Path) -> None:
    """A 2.1 map (no ``temporal_week_sums``, as aion wrote it before) reads as no evidence
    and, continued, holds the sums of the days closed since: not its own earlier days'."""
    import json
    import zipfile

    first, second = _logs("market", tmp_path, cuts=(8,))
    new = _build([first], tmp_path / "new.aion")
    old = tmp_path / "old.aion"
    with zipfile.ZipFile(new) as zin:
        contents = {n: zin.read(n) for n in zin.namelist() if n != "temporal_week_sums.npy"}
    manifest = json.loads(contents["manifest.json"])
    manifest["version"] = "2.1"
    del manifest["members"]["temporal_week_sums"]
    del manifest["families"]["calendar"]
    contents["manifest.json"] = json.dumps(manifest).encode()
    with zipfile.ZipFile(old, "w", compression=zipfile.ZIP_STORED) as zout:
        for name, data in contents.items():
            zout.writestr(name, data)
    assert "calendar" not in run("info", old).stdout
    _build([second], old, "--map", old)
    arrays, written = read_map(old)
    assert written["version"] == "2.3"
    # days 0-6 closed in the 2.1 map (no sums); since: its pending Monday (7) and 8-13 closed,
    # one of each weekday, the last Monday (14) pending
    days = arrays["temporal_week_sums"][0].reshape(7, 24).max(axis=1)
    np.testing.assert_array_equal(days, [1] * 7)
    assert written["families"]["calendar"]["calendar"] == "day_weekend"


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (np.zeros((4, 100)), "shape"),
        (np.zeros((3, 168)), "shape"),
        (np.zeros((4, 168), np.int64), "real numbers"),
        (np.full((4, 168), np.nan), "non-finite"),
        (-np.ones((4, 168)), "negative"),
    ],
)
def test_corrupt_sums_are_refused(value: np.ndarray, message: str) -> None:
    from aion_cli.engine.temporal.week_evidence import stored_sums
    from aion_cli.errors import MapCorruptError

    with pytest.raises(MapCorruptError, match=message):
        stored_sums({"t_week_sums": value}, "t_", 48)
    gain_only = np.zeros((4, 168))
    gain_only[3] = -1.0  # a loss of the week is a sum like any other
    np.testing.assert_array_equal(stored_sums({"t_week_sums": gain_only}, "t_", 48), gain_only)
    assert stored_sums({}, "t_", 48).shape == (4, 0)


def test_sums_of_another_calendars_width_are_refused_on_reading_the_map() -> None:
    """A day-and-weekend profile of hourly bins keeps 168 hours of the week; 336 columns (the
    week of a half-hour profile) pass the member's own check, which knows the profile's bins
    but not its kinds of day, and the map read, then failed in its next day close (numpy's
    broadcast error) or merge. Refused where the map is read, as other members whose shape
    does not match the config."""
    from aion_cli.engine.state import MapState
    from aion_cli.errors import MapCorruptError
    from tests.engine.temporal_data import corridor

    state = corridor(3, lambda d, h: 5.0, seed=1).state
    arrays, meta = state.to_arrays()
    assert arrays["temporal_week_sums"].shape == (4, 168)
    MapState.from_arrays(dict(arrays), meta)  # as written: read
    wide = np.zeros((4, 336))
    wide[:3] = 1.0
    with pytest.raises(MapCorruptError, match="week_sums"):
        MapState.from_arrays({**arrays, "temporal_week_sums": wide}, meta)


def test_a_querys_open_window_is_no_second_day(tmp_path: Path) -> None:
    """Two days of the market scenario: the Monday closed, the Tuesday pending with its last
    window open. A query absorbs the pending day and then the open window (a window of the
    same Tuesday); the week sums' days observed had counted the Tuesday twice (2 at the
    open window's hour), so a day of the week seen once passed for the two days the week's
    hours need (``MIN_DAYS``). One day each now, as closing the day will count it."""
    from aion_cli.engine.closing import open_window_record
    from aion_cli.mapquery import load_map

    logs = _logs("market", tmp_path, cuts=(2,))
    state = load_map(_build(logs[:1], tmp_path / "two.aion")).state
    assert state.pending  # both parts there
    assert open_window_record(state) is not None
    view = state.query_temporal()
    days = view.week_sums[0].reshape(7, 24).max(axis=1)
    np.testing.assert_array_equal(days, [1, 1, 0, 0, 0, 0, 0])
