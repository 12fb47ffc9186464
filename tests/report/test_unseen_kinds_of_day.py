"""The report's activity charts mark the hours of a kind of day the map never observed (a
Saturday from a map of weekdays): hatched bands and dotted curves, said in words on the page;
a map that observed weekends marks none."""

from __future__ import annotations

import html
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.types import DetectionBatch
from aion_cli.formats.tracks_log import tracks_to_log
from aion_cli.mapquery import LoadedMap, load_map
from aion_cli.pipeline import BuildOptions, build_map
from aion_cli.report.content import gather
from aion_cli.timeparse import resolve_zone

S = 1_000_000_000
HOUR = 3600 * S
DAY = 24 * HOUR
MONDAY_10 = 1_762_164_000 * S  # Monday 2025-11-03 10:00 UTC


def _map(folder: Path, days: range) -> tuple[Path, LoadedMap]:
    """A fixed sensor observing 10:00-11:00 UTC on ``days`` (0: that Monday), people walking."""
    n = 60
    starts = [MONDAY_10 + d * DAY for d in days]
    batch = DetectionBatch.concat([
        DetectionBatch.from_arrays(
            s + np.arange(n) * (HOUR // n),
            np.column_stack([np.linspace(0.0, 3.0, n), np.zeros(n), np.zeros(n)]),
            np.zeros(n), np.ones(n), np.arange(n) % 3,
        )
        for s in starts
    ])
    log = folder / "sessions.mcap"
    tracks_to_log(batch, log, observed=[(s, s + HOUR) for s in starts])
    report = build_map(BuildOptions(logs=(log,), output=folder / "m.aion"))
    return report.output, load_map(report.output)


@pytest.fixture(scope="module")
def weekdays(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, LoadedMap]:
    return _map(tmp_path_factory.mktemp("weekdays"), range(5))


@pytest.fixture(scope="module")
def whole_week(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, LoadedMap]:
    return _map(tmp_path_factory.mktemp("week"), range(7))


def _weekend_10(times: np.ndarray) -> list[bool]:
    """Per time, whether it falls on a Saturday or Sunday, 10:00-11:00 UTC (by the calendar)."""
    out = []
    for t in times.tolist():
        when = datetime.fromtimestamp(t // S, UTC)
        out.append(when.weekday() >= 5 and when.hour == 10)
    return out


def test_a_map_of_weekdays_marks_the_weekend_hours_it_observed_on_weekdays(
    weekdays: tuple[Path, LoadedMap],
) -> None:
    """Observed weekdays 10:00-11:00: the weekend curve's 10:00-11:00 and the week's Saturday
    and Sunday 10:00 are marked, the weekdays nowhere; the other hours, never observed on any
    day, stay the grey ones."""
    path, loaded = weekdays
    content = gather(loaded, path, resolve_zone("UTC"), None)
    weekday, weekend, week = content.activity
    for series in (weekday, weekend, week):
        assert series.other_days.tolist() == _weekend_10(series.times_ns)
        hours = [datetime.fromtimestamp(t // S, UTC).hour for t in series.times_ns.tolist()]
        assert series.unobserved.tolist() == [h != 10 for h in hours]
    assert weekend.other_days.sum() == 4  # four quarter hours of the Saturday
    assert not weekday.other_days.any()
    assert week.other_days.sum() == 2  # Saturday and Sunday 10:00
    assert content.hours_observed == "weekdays 10:00-11:00; weekends none (UTC)"


def test_a_map_that_observed_weekends_marks_no_kind_of_day(
    whole_week: tuple[Path, LoadedMap],
) -> None:
    path, loaded = whole_week
    content = gather(loaded, path, resolve_zone("UTC"), None)
    for series in content.activity:
        assert not series.other_days.any()
        assert series.unobserved.any()  # the night hours are still the grey ones
    assert content.hours_observed == "weekdays, weekends 10:00-11:00 (UTC)"


def test_the_page_says_so_in_words_only_for_the_map_of_weekdays(
    weekdays: tuple[Path, LoadedMap], whole_week: tuple[Path, LoadedMap]
) -> None:
    from aion_cli.report.page import render

    pages = []
    for path, loaded in (weekdays, whole_week):
        content = gather(loaded, path, resolve_zone("UTC"), None)
        pages.append(html.unescape(render(content, {}, "now", "0")))
    said = (
        "Hatched bands, dotted curves: hours of a kind of day the map never observed at that "
        "hour (it observed weekdays 10:00-11:00; weekends none (UTC)); the forecast there "
        "follows the rhythm of the days it saw, not measured."
    )
    assert said in pages[0]
    assert "Hatched" not in pages[1]


def test_the_chart_hatches_those_hours_and_dots_their_curve(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A Saturday of hourly values: hours 9-17 observed on weekdays only (hatched, dotted),
    the rest on no day (grey, dotted): no solid stretch, one hatched band from 09:00 to 18:00
    with its legend entry, one grey band either side."""
    from aion_cli.report import plots
    from aion_cli.report.content import Series

    figures: list[object] = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: figures.append(fig) or path)
    saturday = MONDAY_10 - 10 * HOUR + 5 * DAY
    times = saturday + np.arange(24) * HOUR
    day = (np.arange(24) >= 9) & (np.arange(24) < 18)
    series = Series("a Saturday", times, ("whole map",), np.ones((24, 1)), ~day, day)
    plots.activity_png(series, "detections", tmp_path / "sat.png", resolve_zone("UTC"))
    (ax,) = figures[0].axes  # type: ignore[attr-defined]
    solid, _dotted = ax.get_lines()
    assert not np.isfinite(np.asarray(solid.get_ydata(), dtype=float)).any()
    hatched = [p for p in ax.patches if p.get_hatch()]
    assert len(hatched) == 1
    band = hatched[0].get_bbox()  # data coordinates: hours of the day
    assert (band.x0, band.x1) == (9.0, 18.0)
    assert len([p for p in ax.patches if not p.get_hatch()]) == 2
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert plots.OTHER_DAYS_LABEL in labels
    assert plots.UNOBSERVED_LABEL in labels
