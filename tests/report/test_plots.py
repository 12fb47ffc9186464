"""The report's pictures, read back from their matplotlib artists: axis labels name the
zone the times are shown in; titles stay inside the picture."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.report import plots
from aion_cli.report.content import Series
from aion_cli.timeparse import resolve_zone

NS = 1_000_000_000
MONDAY_TOKYO = 1350831600 * NS  # Mon 2012-10-22 00:00 Asia/Tokyo


@pytest.fixture
def drawn(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The figures the report's pictures are saved from."""
    figures: list[Any] = []
    save = plots._save

    def keep(fig: Any, path: Path) -> Path:
        figures.append(fig)
        return save(fig, path)

    monkeypatch.setattr(plots, "_save", keep)
    return figures


@pytest.mark.parametrize("hours", [24, 7 * 24])
def test_the_time_axis_names_its_zone(tmp_path: Path, drawn: list[Any], hours: int) -> None:
    """A day's and a week's curves are drawn by the clock of the report's zone; the week's
    axis had no label at all, so nothing said in which zone its days start."""
    times = MONDAY_TOKYO + np.arange(hours) * 3600 * NS
    series = Series("t", times, ("whole map",), np.ones((hours, 1)))
    plots.activity_png(series, "detections per 10 min", tmp_path / "a.png",
                       resolve_zone("Asia/Tokyo"))
    (ax,) = drawn[-1].axes
    assert "Asia/Tokyo" in ax.get_xlabel()
    if hours > 24:  # the days start at the zone's midnight
        assert ax.get_xticklabels()[0].get_text() == "Mon 22"


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6])
def test_rose_titles_are_inside_the_picture(tmp_path: Path, drawn: list[Any], n: int) -> None:
    """Two or three roses in a row had their titles cut at the top edge of the picture."""
    from aion_cli.report.content import Busiest

    record = {"id": "c1", "kind": "cell", "x": 1.25, "y": -8.25, "direction_deg": 0.0,
              "concentration": 0.8, "histogram": [0.1, 0, 0, 0, 0.9, 0, 0, 0]}
    plots.roses_png([Busiest(record, "R1 hallway", "static")] * n, 8, tmp_path / "r.png")
    fig = drawn[-1]
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        box = ax.title.get_window_extent(renderer)
        assert box.y1 <= fig.bbox.y1, ax.get_title()
        assert box.x0 >= 0, ax.get_title()
        assert box.x1 <= fig.bbox.x1, ax.get_title()


@pytest.mark.parametrize("n", [1, 2, 3])
def test_the_roses_caption_is_inside_the_picture(tmp_path: Path, drawn: list[Any], n: int) -> None:
    """The caption under the roses is one line of 83 characters: under one rose (a busiest
    list of one entry: a map of one hash cell) it ran past both edges of the 3.2-inch page,
    "e of the place's headings ... (same scale on e". It is broken to the page's width, and
    all of it is there."""
    from aion_cli.report.content import Busiest

    record = {"id": "c1", "kind": "cell", "x": 2.25, "y": 3.25, "direction_deg": 0.0,
              "concentration": 0.8, "histogram": [0.1, 0, 0, 0, 0.9, 0, 0, 0]}
    plots.roses_png([Busiest(record, "", "static")] * n, 8, tmp_path / "r.png")
    fig = drawn[-1]
    caption = fig._supxlabel
    assert " ".join(caption.get_text().split()) == plots.ROSES_CAPTION
    box = caption.get_window_extent(fig.canvas.get_renderer())
    assert box.x0 >= 0
    assert box.x1 <= fig.bbox.x1
    assert box.y0 >= 0


def test_rose_titles_with_long_room_names_stay_apart(tmp_path: Path, drawn: list[Any]) -> None:
    """A room named "R12 open-plan engineering workspace north" ran each rose's title into
    the next one's and past the picture's edges."""
    from aion_cli.report.content import Busiest

    record = {"id": "p1234", "kind": "node", "direction_deg": 0.0, "concentration": 0.8,
              "histogram": [0.1, 0, 0, 0, 0.9, 0, 0, 0]}
    room = "R12 open-plan engineering workspace north"
    plots.roses_png([Busiest(record, room, "static")] * 3, 8, tmp_path / "r.png")
    fig = drawn[-1]
    renderer = fig.canvas.get_renderer()
    boxes = [ax.title.get_window_extent(renderer) for ax in fig.axes]
    for k, box in enumerate(boxes):
        assert box.x0 >= 0
        assert box.x1 <= fig.bbox.x1
        assert box.y1 <= fig.bbox.y1
        assert not any(box.overlaps(other) for other in boxes[k + 1 :])
    assert fig.axes[0].get_title().startswith("p1234\n")


@pytest.mark.parametrize(
    ("room", "shown"),
    [
        ("R3 hallway_between_kitchen_and_main_office", "R3 hallway_between_kitchen_and_ma…"),
        ("Konferenzraum_Nordfluegel_Ebene2_Ost_Seite", "Konferenzraum_Nordfluegel_Ebene2_…"),
        ("R12 open-plan engineering workspace north", "R12 open-plan engineering…"),
        ("R1  kitchen\n", "R1 kitchen"),
    ],
)
def test_a_long_room_name_keeps_what_fits(
    tmp_path: Path, drawn: list[Any], room: str, shown: str
) -> None:
    """A room name cut to the rose's width keeps its first characters: a name with no space
    within the width (``hallway_between_kitchen_and_main_office``, a label a graph tool
    writes) was shortened word by word to nothing, the title's second line a bare "…"."""
    from aion_cli.report.content import Busiest

    record = {"id": "p1", "kind": "node", "direction_deg": 0.0, "concentration": 0.8,
              "histogram": [0.1, 0, 0, 0, 0.9, 0, 0, 0]}
    plots.roses_png([Busiest(record, room, "static")], 8, tmp_path / "r.png")
    title = drawn[-1].axes[0].get_title()
    assert title.split("\n")[1] == shown
    assert len(shown) <= plots.ROSE_TITLE_CHARS


def test_a_long_observation_shows_its_last_days_and_says_so(
    tmp_path: Path, drawn: list[Any]
) -> None:
    """A map observed over 200 days: the day rows stopped at the first 120 without a word,
    the last observed window off the picture. The rows are the last 120 days, titled so."""
    from aion_cli.report.content import Observed

    day = 86_400 * NS
    start = MONDAY_TOKYO
    end = start + 200 * day - 3600 * NS
    observed = Observed(
        span=(start, end),
        first_ns=start + 9 * 3600 * NS,
        last_ns=end - 3600 * NS,
        fixed=(np.zeros(0, np.int64), np.zeros(0, np.int64)),
        hours=np.zeros((2, 24)),
        day_types=("Mon-Fri", "Sat-Sun"),
        model_zone="Asia/Tokyo",
        source="test",
    )
    plots.timeline_png(observed, resolve_zone("Asia/Tokyo"), tmp_path / "o.png")
    days_ax = drawn[-1].axes[0]
    assert "last 120 of 200 days" in days_ax.get_title()
    labels = [t.get_text() for t in days_ax.get_yticklabels()]
    assert labels[0] == "Thu 2013-01-10"  # day 81 of 200: rows 81..200
    bottom, top = days_ax.get_ylim()
    (last,) = [ln for ln in days_ax.get_lines() if ln.get_marker() == "^"]
    assert top <= last.get_ydata()[0] <= bottom  # the last window is on the picture


def test_hours_observed_never_read_negative(tmp_path: Path, drawn: list[Any]) -> None:
    """Profile bins none observed: the colour bar ran from -0.1 to 0.1 hours and every bin
    was painted its middle blue, as if observed. Zero is the bar's lowest colour; the bar
    starts at 0."""
    from aion_cli.report.content import Observed

    observed = Observed(
        span=(MONDAY_TOKYO, MONDAY_TOKYO + 3600 * NS),
        first_ns=None,
        last_ns=None,
        fixed=(np.zeros(0, np.int64), np.zeros(0, np.int64)),
        hours=np.zeros((2, 24)),
        day_types=("Mon-Fri", "Sat-Sun"),
        model_zone="UTC",
        source="test",
    )
    plots.timeline_png(observed, resolve_zone("UTC"), tmp_path / "o.png")
    (image,) = drawn[-1].axes[1].get_images()
    low, high = image.get_clim()
    assert low == 0.0
    assert high > 0.0


def test_a_rose_without_headings_says_why_it_is_empty(tmp_path: Path, drawn: list[Any]) -> None:
    """A cell where people stood (flow, an empty direction histogram) drew an empty rose that
    said nothing; it says "no heading", in the colour the map draws such a cell, and a rose
    without flow says "no flow"; a rose with headings has no such text."""
    from aion_cli.formats.scene_colours import NO_HEADING_TEAL
    from aion_cli.report.content import Busiest

    empty = [0.0] * 8
    standing = {"id": "c1", "kind": "cell", "x": 10.25, "y": 10.25, "flow": 300.0,
                "direction_deg": None, "concentration": 0.0, "histogram": empty}
    quiet = {**standing, "id": "c2", "flow": 0.0}
    walked = {**standing, "id": "c3", "flow": 5.0, "direction_deg": 22.5,
              "concentration": 1.0, "histogram": [0, 0, 0, 0, 1.0, 0, 0, 0]}
    rows = [Busiest(r, "", "static") for r in (standing, quiet, walked)]
    plots.roses_png(rows, 8, tmp_path / "r.png")
    texts = [[t for t in ax.texts if t.get_text()] for ax in drawn[-1].axes]
    assert [[t.get_text().split(":")[0] for t in ts] for ts in texts] == [
        ["no heading"], ["no flow"], []
    ]
    assert texts[0][0].get_color() == NO_HEADING_TEAL


@pytest.mark.parametrize("bins", [8, 6])
def test_a_rose_bar_fills_its_bin_and_the_arrow_gives_the_heading(
    tmp_path: Path, drawn: list[Any], bins: int
) -> None:
    """People walking exactly along +x: the engine counts heading 0 in the bin [0, 360/B)
    (its edges fall on the axes), so the bar is drawn over that bin, centred 180/B degrees
    off the axis (22.5 for 8 bins), while the red arrow gives their heading, 0 degrees. The
    gap is the bin's width, not a misplaced bar: a bar moved onto the arrow would claim
    headings of the neighbouring bin."""
    from aion_cli.engine.descriptors import bin_of
    from aion_cli.report.content import Busiest

    walked = int(bin_of(0.0, bins))
    hist = [0.0] * bins
    hist[walked] = 1.0
    record = {"id": "p1", "kind": "node", "flow": 5.0, "direction_deg": 0.0,
              "concentration": 1.0, "histogram": hist}
    plots.roses_png([Busiest(record, "", "static")], bins, tmp_path / "r.png")
    (ax,) = drawn[-1].axes
    (bar,) = [p for p in ax.patches if p.get_height() > 0]
    left, right = np.degrees([bar.get_x(), bar.get_x() + bar.get_width()]) % 360
    assert (left + right) / 2 == pytest.approx(180.0 / bins)  # the bin [0, 360/B) centred
    assert 0.0 < left < right < 360.0 / bins  # inside its bin, a gap to the next
    (arrow,) = ax.texts[-1:]
    theta, _ = arrow.xy
    assert np.degrees(theta) == pytest.approx(0.0)


def test_a_roses_grid_lines_are_its_bins_edges(tmp_path: Path, drawn: list[Any]) -> None:
    """A map of 6 direction bins (60 degrees each, edges on the axes): matplotlib's grid lines
    every 45 degrees cut its bars in two, so nothing showed which headings a bar holds. The
    radial grid lines are the bins' edges, 0, 60, ... 300 degrees, for any number of bins."""
    from aion_cli.report.content import Busiest

    hist = [0.1, 0.2, 0.3, 0.4, 0.0, 0.0]
    record = {"id": "p1", "kind": "node", "flow": 5.0, "direction_deg": 10.0,
              "concentration": 0.5, "histogram": hist}
    plots.roses_png([Busiest(record, "", "static")], 6, tmp_path / "r.png")
    fig = drawn[-1]
    fig.canvas.draw()
    (ax,) = fig.axes
    ticks = ax.xaxis.get_major_ticks() + ax.xaxis.get_minor_ticks()
    lines = sorted(round(float(np.degrees(t.get_loc())) % 360, 6) for t in ticks
                   if t.gridline.get_visible())
    assert lines == [0.0, 60.0, 120.0, 180.0, 240.0, 300.0]


def test_roses_share_one_radial_scale_labelled_in_shares(tmp_path: Path, drawn: list[Any]) -> None:
    """The roses' rings had no labels and each rose filled its own axes, so a place where half
    the headings go one way looked like one where a fifth do. Every rose of the figure has
    the same rings, labelled in shares: the 50 % bar reaches the ring labelled "50 %", the
    20 % bar the ring labelled "20 %"."""
    from aion_cli.report.content import Busiest

    half = [0.5, 0.5, 0, 0, 0, 0, 0, 0]
    fifth = [0.2] + [0.8 / 7] * 7  # a fifth one way, the rest spread evenly
    rows = [Busiest({"id": f"p{k}", "kind": "node", "flow": 5.0, "direction_deg": 0.0,
                     "concentration": 0.5, "histogram": h}, "", "static")
            for k, h in enumerate((half, fifth))]
    plots.roses_png(rows, 8, tmp_path / "r.png")
    fig = drawn[-1]
    fig.canvas.draw()
    axes = fig.axes
    assert axes[0].get_ylim() == axes[1].get_ylim()
    for ax, share in zip(axes, (0.5, 0.2), strict=True):
        rings = {t.get_text(): float(r) for t, r in zip(ax.get_yticklabels(), ax.get_yticks(),
                                                         strict=True)}
        assert all(t.get_visible() for t in ax.get_yticklabels())
        tallest = max(p.get_height() for p in ax.patches)
        assert tallest == pytest.approx(share)
        assert rings[f"{share * 100:.0f} %"] == pytest.approx(tallest)
        assert max(rings.values()) <= ax.get_ylim()[1] + 1e-9


@pytest.mark.parametrize(("top", "rings"), [
    (0.5, [0.1, 0.2, 0.3, 0.4, 0.5]),
    (1.0, [0.2, 0.4, 0.6, 0.8, 1.0]),
    (0.2, [0.05, 0.1, 0.15, 0.2]),
    (0.3, [0.1, 0.2, 0.3]),
    (0.0, [1.0]),
])
def test_share_rings_are_round_and_reach_the_longest_bar(top: float, rings: list[float]) -> None:
    assert plots.share_rings(top).tolist() == pytest.approx(rings)


@pytest.mark.parametrize("bins", [6, 8, 16])
def test_a_roses_ring_labels_stay_apart_and_the_outer_one_clear_of_the_circle(
    tmp_path: Path, drawn: list[Any], bins: int
) -> None:
    """The ring labels ran along 22.5 degrees, each into the next ("20 %" under "40 %", read
    as "40" over "%"), and the outer one ("100 %") sat on the circle, crossed by it and the
    grid lines. They stand one above the next, and the outer label is wholly outside the
    circle (every corner of its box further from the centre than the circle's radius)."""
    from aion_cli.report.content import Busiest

    hist = [1.0] + [0.0] * (bins - 1)  # one way: rings 20 % .. 100 %
    record = {"id": "p1", "kind": "node", "flow": 5.0, "direction_deg": 0.0,
              "concentration": 1.0, "histogram": hist}
    plots.roses_png([Busiest(record, "", "static")], bins, tmp_path / "r.png")
    fig = drawn[-1]
    fig.canvas.draw()
    (ax,) = fig.axes
    renderer = fig.canvas.get_renderer()
    labels = [t for t in ax.get_yticklabels() if t.get_visible() and t.get_text()]
    assert [t.get_text() for t in labels] == ["20 %", "40 %", "60 %", "80 %", "100 %"]
    boxes = [t.get_window_extent(renderer) for t in labels]
    for k, box in enumerate(boxes):
        assert not any(box.overlaps(other) for other in boxes[k + 1 :]), labels[k].get_text()
    centre = ax.transData.transform((0.0, 0.0))
    radius = np.hypot(*(ax.transData.transform((0.0, ax.get_ylim()[1])) - centre))
    outer = boxes[-1]
    corners = np.array([[outer.x0, outer.y0], [outer.x0, outer.y1],
                        [outer.x1, outer.y0], [outer.x1, outer.y1]])
    assert np.hypot(*(corners - centre).T).min() > radius
