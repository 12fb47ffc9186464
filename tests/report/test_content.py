"""The report's content and pictures for a fixed sensor without a scene graph: the observed
intervals and profile hours it draws are the spans the log declared, the activity is the
whole map's flow, and the timeline shows the intervals in blue; the days the curves show."""

from __future__ import annotations

from datetime import date
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.types import DetectionBatch
from aion_cli.formats.tracks_log import tracks_to_log
from aion_cli.mapquery import LoadedMap, load_map
from aion_cli.pipeline import BuildOptions, build_map
from aion_cli.report.content import gather, series_days
from aion_cli.report.writer import write_report
from aion_cli.timeparse import resolve_zone

S = 1_000_000_000
HOUR = 3600 * S
DAY = 24 * HOUR
T0 = 1_762_070_400 * S  # Sunday 2025-11-02 08:00 UTC, on a 10-minute window boundary
SECOND = T0 + DAY + 2 * HOUR  # Monday 10:00 UTC
FIXED_BLUE = np.array([0x2C, 0x6F, 0xBB]) / 255.0


def _people(start: int, n: int = 60) -> DetectionBatch:
    t = start + np.arange(n) * (HOUR // n)
    xy = np.column_stack([np.linspace(0.0, 3.0, n), np.zeros(n), np.zeros(n)])
    return DetectionBatch.from_arrays(t, xy, np.zeros(n), np.ones(n), np.arange(n) % 3)


@pytest.fixture(scope="module")
def fixed_map(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, LoadedMap]:
    folder = tmp_path_factory.mktemp("fixed")
    log = folder / "two_sessions.mcap"
    batch = DetectionBatch.concat([_people(T0), _people(SECOND)])
    tracks_to_log(batch, log, observed=[(T0, T0 + HOUR), (SECOND, SECOND + HOUR)])
    report = build_map(BuildOptions(logs=(log,), output=folder / "m.aion"))
    return report.output, load_map(report.output)


def test_the_observed_intervals_and_hours_are_the_declared_spans(
    fixed_map: tuple[Path, LoadedMap],
) -> None:
    path, loaded = fixed_map
    content = gather(loaded, path, resolve_zone("UTC"), None)
    starts, ends = content.observed.fixed
    np.testing.assert_array_equal(starts, [T0, SECOND])
    np.testing.assert_array_equal(ends, [T0 + HOUR, SECOND + HOUR])
    hours = content.observed.hours  # day_weekend: Mon-Fri, Sat-Sun x 24 hours (UTC)
    expected = np.zeros((2, 24))
    expected[1, 8] = 1.0  # Sunday 08:00-09:00
    expected[0, 10] = 1.0  # Monday 10:00-11:00
    np.testing.assert_allclose(hours, expected)
    assert content.observed.day_types == ("Mon-Fri", "Sat-Sun")
    assert content.counts["rooms"] == 0


def test_without_rooms_the_curves_are_the_whole_maps_flow(
    fixed_map: tuple[Path, LoadedMap],
) -> None:
    from aion_cli.engine.query import predict_table

    path, loaded = fixed_map
    content = gather(loaded, path, resolve_zone("UTC"), None)
    assert [s.names for s in content.activity] == [("whole map",)] * 3
    assert any("no rooms" in n for n in content.notes)
    weekday, weekend, week = content.activity
    assert weekday.times_ns.size == 96  # every 15 minutes
    assert week.times_ns.size == 168  # every hour
    # the last observation is Monday 2025-11-03: the curves show the next week, from Monday 10
    assert int(weekday.times_ns[0]) == 1_762_732_800 * S  # Monday 2025-11-10 00:00 UTC
    assert int(weekend.times_ns[0]) == int(weekday.times_ns[0]) + 5 * DAY
    for k in (0, 41, 95):
        t = int(weekday.times_ns[k])
        total = float(np.nansum(predict_table(loaded.state, t).flow))
        assert weekday.flows[k, 0] == pytest.approx(total, rel=1e-12, abs=1e-12)


def test_the_timeline_draws_the_fixed_intervals(
    fixed_map: tuple[Path, LoadedMap], tmp_path: Path
) -> None:
    from PIL import Image

    path, loaded = fixed_map
    written = write_report(loaded, path, tmp_path / "r", resolve_zone("UTC"))
    assert written[0].name == "index.html"
    assert {p.name for p in written} == {p.name for p in (tmp_path / "r").iterdir()}
    with Image.open(tmp_path / "r" / "observed.png") as image:
        rgb = np.asarray(image.convert("RGB"), dtype=np.float64) / 255.0
    left = rgb[:, : rgb.shape[1] // 2]
    blue = np.abs(left - FIXED_BLUE).max(axis=2) < 0.02
    rows = np.flatnonzero(blue.any(axis=1))
    assert rows.size > 0
    # two days, one bar each: two separate bands of rows
    assert int((np.diff(rows) > 1).sum()) == 1
    sunday, monday = (
        rows[: np.argmax(np.diff(rows) > 1) + 1],
        rows[np.argmax(np.diff(rows) > 1) + 1 :],
    )
    # the x axis runs between the days panel's spines (its first two dark full-height columns)
    dark = np.flatnonzero((rgb.max(axis=2) < 0.2).sum(axis=0) > rgb.shape[0] / 2)
    midnight = int(dark[0])
    per_hour = (int(dark[dark > midnight + 10][0]) - midnight) / 24
    for band, hour in ((sunday, 8), (monday, 10)):  # Sunday 08:00-09:00, Monday 10:00-11:00
        cols = np.flatnonzero(blue[int(band[band.size // 5])])  # above the triangles
        assert cols.min() - midnight == pytest.approx(hour * per_hour, abs=3)
        assert cols.size == pytest.approx(per_hour, abs=3)


@pytest.mark.parametrize(
    ("anchor", "zone", "inside", "expected"),
    [
        # the end of the sample (Sat 2026-01-10 00:00 UTC): the next week
        (
            1_768_003_200 * S,
            "UTC",
            False,
            (date(2026, 1, 12), date(2026, 1, 12), date(2026, 1, 17)),
        ),
        # --time on a Wednesday: its week, that day, the week's Saturday
        (1_768_392_000 * S, "UTC", True, (date(2026, 1, 12), date(2026, 1, 14), date(2026, 1, 17))),
        # Sunday 2026-01-11 23:30 UTC is Monday 00:30 in Berlin: another week
        (1_768_174_200 * S, "UTC", True, (date(2026, 1, 5), date(2026, 1, 5), date(2026, 1, 11))),
        (
            1_768_174_200 * S,
            "Europe/Berlin",
            True,
            (date(2026, 1, 12), date(2026, 1, 12), date(2026, 1, 17)),
        ),
    ],
)
def test_the_days_the_curves_show(
    anchor: int, zone: str, inside: bool, expected: tuple[date, date, date]
) -> None:
    assert series_days(anchor, resolve_zone(zone), inside) == expected


def test_a_rose_of_a_hash_cell_is_titled_by_where_it_is(fixed_map: tuple[Path, LoadedMap]) -> None:
    """The map of cells only: the roses name each cell by its position, not by its 19-digit
    spatial-hash id; a node keeps its id."""
    from aion_cli.predictions import entry_table, rows_from_table
    from aion_cli.report.plots import rose_title

    _, loaded = fixed_map
    cells = [e for e in rows_from_table(entry_table(loaded, None)) if e["kind"] == "cell"]
    assert cells
    for e in cells:
        assert rose_title(e) == f"cell at ({e['x']:.2f}, {e['y']:.2f}) m"
        assert e["id"] not in rose_title(e)
    assert rose_title({"id": "p12", "kind": "node", "x": 1.0, "y": 2.0}) == "p12"
    # a 0.5 m cell's centre at 11.75 read "11.8", a place no cell is centred at
    assert rose_title({"id": "c1", "kind": "cell", "x": 11.75, "y": -0.25}) == (
        "cell at (11.75, -0.25) m")


def test_the_curves_are_dotted_where_the_forecast_is_extrapolated(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A day of hourly values observed 09:00-18:00: the solid curve holds those hours only,
    the dotted one the others, joined to the solid at 08:00-09:00 and 18:00-19:00, both in
    the line's colour."""
    from aion_cli.report import plots
    from aion_cli.report.content import Series

    figures: list[object] = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: figures.append(fig) or path)
    times = T0 - 8 * HOUR + np.arange(24) * HOUR  # midnight on, hourly
    unobserved = (np.arange(24) < 9) | (np.arange(24) >= 19)
    flows = np.arange(24, dtype=np.float64)[:, None] + 1.0
    series = Series("a day", times, ("whole map",), flows, unobserved)
    plots.activity_png(series, "detections", tmp_path / "day.png", resolve_zone("UTC"))
    (ax,) = figures[0].axes  # type: ignore[attr-defined]
    solid, dotted = ax.get_lines()
    assert solid.get_linestyle() == "-"
    assert dotted.get_linestyle() == ":"
    assert solid.get_color() == dotted.get_color()
    drawn = np.isfinite(np.asarray(solid.get_ydata(), dtype=float))
    assert drawn.tolist() == (~unobserved).tolist()
    near = np.isfinite(np.asarray(dotted.get_ydata(), dtype=float))
    assert np.flatnonzero(near).tolist() == [*range(10), *range(18, 24)]


def test_the_busiest_table_prints_no_negative_zero(fixed_map: tuple[Path, LoadedMap]) -> None:
    """A dominant direction of -6e-16 degrees (a symmetric histogram's circular mean) read
    '-0.0' in the busiest table, a position of -1 mm '-0.00'; they read '+0.0' (as predict's
    '+0°') and '0.00'; a real negative keeps its sign."""
    from dataclasses import replace

    from aion_cli.report.page import render

    path, loaded = fixed_map
    content = gather(loaded, path, resolve_zone("UTC"), None)
    first = content.busiest[0]
    odd = replace(first, record={**first.record, "direction_deg": -5.887368655515379e-16,
                                 "x": -0.001, "y": -2.5})
    page = render(replace(content, busiest=(odd,)), {}, "now", "test")
    table = page[page.index("direction (deg)"):]
    row = table[table.index("<tbody>"):table.index("</tbody>")]
    assert '<td class="n">+0.0</td>' in row
    assert "<td>0.00, -2.50</td>" in row
    assert "-0.0" not in row


def test_a_time_at_which_nothing_flows_says_so_instead_of_an_empty_table() -> None:
    """With no entry flowing (every forecast 0 at that time), the page said "The 0 busiest
    of the map's N places" above an empty table; it now says that none has any flow."""
    from types import SimpleNamespace

    from aion_cli.report.page import _busiest

    content = SimpleNamespace(t_ns=None, zone=None, busiest=(), matched=151)
    html = " ".join(_busiest(content, {}))  # type: ignore[arg-type]
    assert "None of the map's 151 places and hash cells has any flow as observed" in html
    assert "<table" not in html


def test_the_map_caption_names_no_colour_the_picture_lacks(
    fixed_map: tuple[Path, LoadedMap], tmp_path: Path
) -> None:
    """People walked along +x only: as observed every cell has flow and a heading, so the
    map from above draws no grey (no flow) and no teal (no heading), and its own legend names
    neither; the page's caption under it named both, always."""
    import html
    import re

    from aion_cli.formats.scene_colours import NO_FLOW_KEY, NO_HEADING_KEY
    from aion_cli.predictions import entry_table, rows_from_table

    path, loaded = fixed_map
    rows = rows_from_table(entry_table(loaded, None))
    assert rows
    assert all(r["flow"] > 0 and r["direction_deg"] is not None for r in rows)
    write_report(loaded, path, tmp_path / "r", resolve_zone("UTC"), None)
    page = (tmp_path / "r" / "index.html").read_text()
    (caption,) = re.findall(r'<img src="map.png"[^>]*>\s*<figcaption>(.*?)</figcaption>', page)
    text = html.unescape(caption)
    assert "seen from above" in text
    for key in (NO_FLOW_KEY, NO_HEADING_KEY, "teal", "grey"):
        assert key not in text, text


def test_the_page_says_how_many_days_were_scored_as_info_does(
    fixed_map: tuple[Path, LoadedMap], tmp_path: Path
) -> None:
    """Two sessions, Sunday and Monday (UTC, the map's zone): the day-ahead scoring judged
    one day, the Monday (nothing before the Sunday forecasts it), still open to more logs.
    aion info MAP has a "days scored" row; the report page had none, though those days decide
    whether an entry can leave static."""
    import html
    import re

    from aion_cli.cli.info_map import describe_map

    path, loaded = fixed_map
    info = describe_map(path)["families"]
    assert (info["scored_days"], info["last_day_provisional"]) == (1, True)
    write_report(loaded, path, tmp_path / "r", resolve_zone("UTC"), None)
    page = html.unescape((tmp_path / "r" / "index.html").read_text())
    assert re.findall(r"<tr><td>days scored</td><td>(.*?)</td></tr>", page) == [
        "1 (the last, still open to more logs, provisionally)"
    ]


def test_the_roses_caption_says_what_their_rings_are(
    fixed_map: tuple[Path, LoadedMap], tmp_path: Path
) -> None:
    """The roses' rings are labelled in shares of a place's headings, one scale for every
    rose (report/plots.py); the caption under the picture described the bars and the arrow
    but not the rings, so a reader of the page alone could not tell what they measure."""
    import html
    import re

    path, loaded = fixed_map
    write_report(loaded, path, tmp_path / "r", resolve_zone("UTC"), None)
    page = (tmp_path / "r" / "index.html").read_text()
    (caption,) = re.findall(r'<img src="roses.png"[^>]*>\s*<figcaption>(.*?)</figcaption>', page)
    text = html.unescape(caption)
    assert "rings give the share of the place's headings" in text, text
    assert "one scale for every rose" in text, text


def test_the_activity_text_of_a_map_without_rooms_sums_its_entries(
    fixed_map: tuple[Path, LoadedMap], tmp_path: Path
) -> None:
    """The curves of a map without rooms are the whole map's flow (the sum over every entry,
    test above): the text above them said they were 'summed over each room's places as aion
    predict --layer rooms sums them', of a map that has no room."""
    import html
    import re

    path, loaded = fixed_map
    write_report(loaded, path, tmp_path / "r", resolve_zone("UTC"), None)
    page = html.unescape((tmp_path / "r" / "index.html").read_text())
    (text,) = re.findall(r"<p>Predicted flow \(.*?</p>", page, flags=re.S)
    assert "room" not in text, text
    assert "summed over every entry" in text
    assert "the whole map's flow" in text
