"""Writing pictures: the PNG target rules (exit-2 input errors before any work) and the
atomic write (no partial file, no staging folder left behind)."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.errors import InputError
from aion_cli.formats.outputs import OutputPathError
from aion_cli.pictures.png_mark import PNG_MAGIC
from aion_cli.pictures.render import check_png_target, save_png, time_title
from aion_cli.pictures.topdown import topdown_figure
from aion_cli.timeparse import parse_time, resolve_zone
from tests.pictures.pixels import synthetic_scene


def _figure() -> object:
    return topdown_figure([synthetic_scene()], ["t"], dpi=40)


def test_writes_a_png_and_replaces_only_pngs(tmp_path: Path) -> None:
    out = tmp_path / "map.png"
    save_png(_figure(), out)
    first = out.read_bytes()
    assert first.startswith(PNG_MAGIC)
    save_png(_figure(), out)  # an existing PNG is replaced
    assert out.read_bytes().startswith(PNG_MAGIC)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.png"]  # no staging left
    other = tmp_path / "notes.png"
    other.write_text("my notes")
    with pytest.raises(OutputPathError, match="not a picture aion drew"):
        save_png(_figure(), other)
    assert other.read_text() == "my notes"
    foreign = tmp_path / "photo.png"  # a real PNG, drawn by someone else
    foreign.write_bytes(PNG_MAGIC + b"\x00\x00\x00\rIHDR" + bytes(17))
    with pytest.raises(OutputPathError, match="not a picture aion drew"):
        save_png(_figure(), foreign)
    assert foreign.read_bytes().startswith(PNG_MAGIC + b"\x00\x00\x00\rIHDR")


@pytest.mark.parametrize(
    ("name", "error", "fragment"),
    [
        ("folder", OutputPathError, "is a folder"),
        ("missing/map.png", OutputPathError, "does not exist"),
        ("map.jpg", InputError, ".png"),
    ],
)
def test_bad_targets(tmp_path: Path, name: str, error: type, fragment: str) -> None:
    (tmp_path / "folder").mkdir()
    with pytest.raises(error, match=fragment):
        check_png_target(tmp_path / name, "--png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"]


def test_a_device_is_refused() -> None:
    with pytest.raises(OutputPathError, match="device"):
        check_png_target(Path("/dev/null"))


def test_a_failed_draw_leaves_nothing(tmp_path: Path) -> None:
    class Broken:
        dpi = 40

        def savefig(self, path: Path, **kwargs: object) -> None:
            Path(path).write_bytes(PNG_MAGIC)  # half a picture, then the disk fills
            raise OSError(28, "No space left on device")

    with pytest.raises(InputError, match="No space left"):
        save_png(Broken(), tmp_path / "map.png")
    assert list(tmp_path.iterdir()) == []


def test_titles_are_in_the_maps_zone() -> None:
    zone = resolve_zone("Europe/Berlin")
    t = parse_time("2026-01-12 08:40", zone)
    assert time_title(t, zone) == "Mon 2026-01-12 08:40 Europe/Berlin"
    assert time_title(t, resolve_zone("UTC")) == "Mon 2026-01-12 07:40 UTC"
    assert time_title(t, zone, clock_only=True) == "08:40"
    assert "historical" in time_title(None, None)


def test_a_title_in_the_hour_a_clock_change_repeats_says_which() -> None:
    """Berlin, 2026-10-25: 02:30 comes at 00:30 UTC (+02:00) and again at 01:30 UTC
    (+01:00). Both pictures (export --time, plan --png) were titled "Sun 2026-10-25 02:30
    Europe/Berlin"; each now gives its offset, as a series' panel titles do. The hours
    around it, and the hour spring skips over, keep the plain title."""
    zone = resolve_zone("Europe/Berlin")
    summer = parse_time("2026-10-25T02:30:00+02:00", zone)
    winter = parse_time("2026-10-25T02:30:00+01:00", zone)
    assert winter - summer == 3600 * 10**9
    assert time_title(summer, zone) == "Sun 2026-10-25 02:30 +02:00 Europe/Berlin"
    assert time_title(winter, zone) == "Sun 2026-10-25 02:30 +01:00 Europe/Berlin"
    assert time_title(winter, zone, clock_only=True) == "02:30 +01:00"
    for iso, title in (
        ("2026-10-25T01:30:00+02:00", "Sun 2026-10-25 01:30 Europe/Berlin"),
        ("2026-10-25T03:30:00+01:00", "Sun 2026-10-25 03:30 Europe/Berlin"),
        ("2026-03-29T03:30:00+02:00", "Sun 2026-03-29 03:30 Europe/Berlin"),
    ):
        assert time_title(parse_time(iso, zone), zone) == title
    utc = resolve_zone("UTC")
    assert time_title(summer, utc) == "Sun 2026-10-25 00:30 UTC"


def test_panels_at_hours_no_log_observed_say_extrapolated() -> None:
    """A map whose manifest lists only 08:00-09:00 (UTC) as observed: the 03:00 panel is
    marked, the 08:30 one is not; a historical picture and an older map are left alone."""
    from types import SimpleNamespace

    from aion_cli.pictures.render import _mark_unobserved

    day = 1_795_392_000 * 10**9  # 2026-11-23 00:00 UTC
    families = {"flow": {"profile": 1}, "observed_bins": [8]}
    loaded = SimpleNamespace(
        manifest={"state": {}, "config": {"timezone": "UTC"}, "families": families}
    )
    times = [day + 3 * 3600 * 10**9, day + 8 * 3600 * 10**9 + 1800 * 10**9]
    assert _mark_unobserved(loaded, times, ["03:00", "08:30"]) == [  # type: ignore[arg-type]
        "03:00 (extrapolated)", "08:30"
    ]
    assert _mark_unobserved(loaded, [None], ["observed"]) == ["observed"]  # type: ignore[arg-type]
    # one time: the mark of predict --time's table, on a line of its own under the title
    assert _mark_unobserved(loaded, times[:1], ["Mon 03:00"]) == [  # type: ignore[arg-type]
        "Mon 03:00\n(extrapolated: an hour no log observed)"
    ]
    assert _mark_unobserved(loaded, times[1:], ["Mon 08:30"]) == ["Mon 08:30"]  # type: ignore[arg-type]
    older = SimpleNamespace(
        manifest={"state": {}, "config": {}, "families": {"flow": {"static": 1}}}
    )
    assert _mark_unobserved(older, times, ["a", "b"]) == ["a", "b"]  # type: ignore[arg-type]


def test_only_aion_s_own_software_text_marks_a_picture(tmp_path: Path) -> None:
    """A PNG whose Software text merely starts with "aion" ("aionic tools") is someone else's
    and is not replaced; one aion drew is."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from aion_cli.pictures.png_mark import is_aion_png

    theirs = tmp_path / "theirs.png"
    fig = plt.figure(figsize=(1, 1))
    fig.savefig(theirs, format="png", metadata={"Software": "aionic tools"})
    plt.close(fig)
    assert not is_aion_png(theirs)
    before = theirs.read_bytes()
    with pytest.raises(OutputPathError, match="not a picture aion drew"):
        save_png(_figure(), theirs)
    assert theirs.read_bytes() == before
    ours = tmp_path / "ours.png"
    save_png(_figure(), ours)
    assert is_aion_png(ours)


def _tall_map_with_a_long_caption() -> object:
    """ETH's hotel in synthetic form: hash cells 1 m apart over 8 m x 15 m (a tall map; so
    far apart that the arrows keep their full length, without a line on it), one cell 100
    times as busy as the rest and five with flow but no heading: a three-line caption."""
    import numpy as np

    from tests.pictures.pixels import cells_only_scene

    xs, ys = np.arange(-3.25, 4.3, 1.0), np.arange(-10.25, 4.3, 1.0)
    xy = np.array([(x, y) for x in xs for y in ys])
    n = len(xy)
    flow, angle, entropy = np.ones(n), np.zeros(n), np.full(n, 0.5)
    flow[0] = 100.0
    angle[1:6] = entropy[1:6] = np.nan
    return topdown_figure([cells_only_scene(xy, flow, angle, entropy)], ["t"],
                          suptitle="hotel.aion")


def test_a_label_cut_by_the_first_layout_is_drawn_again_whole(tmp_path: Path) -> None:
    """The first layout of the hotel's picture left its "y (m)" 4 pixels past the page's
    left edge (matplotlib's constrained layout with a panel of fixed aspect: more layouts
    settle it). A picture whose text is cut is laid out again and redrawn; the label is on
    the page, with the margin of every other picture."""
    from typing import Any

    from aion_cli.pictures.layout import text_cut_off

    fresh: Any = _tall_map_with_a_long_caption()
    fresh.savefig(tmp_path / "plain.png", dpi=fresh.dpi)
    assert text_cut_off(fresh)  # the case in question: a plain save cuts it
    fig: Any = _tall_map_with_a_long_caption()
    save_png(fig, tmp_path / "hotel.png")
    assert not text_cut_off(fig)
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    label = ax.yaxis.label.get_window_extent(fig.canvas.get_renderer())
    assert label.x0 >= 4.0
    assert (tmp_path / "hotel.png").read_bytes().startswith(PNG_MAGIC)


def test_the_ticks_of_a_row_drawn_without_axes_are_not_cut_text() -> None:
    """A row over the panels (the legend of a plan's paths, the arrows' key of a map that
    fills every corner) is an axes with its axis off: its tick labels, never drawn, lay past
    the page's edges, and every such picture was laid out five times (a series of eight
    panels 2.2 s -> 3.3 s). Only drawn text counts; a visible axis's ticks still do."""
    from typing import Any

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from aion_cli.pictures.layout import text_cut_off

    fig: Any = Figure(figsize=(4, 3), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    spec = fig.add_gridspec(2, 1, height_ratios=[1e-3, 1.0])
    row = fig.add_subplot(spec[0, 0])
    row.set_axis_off()
    fig.add_subplot(spec[1, 0]).plot([0, 1], [0, 1])
    fig.canvas.draw()
    renderer, page = fig.canvas.get_renderer(), fig.bbox
    ticks = [t.get_window_extent(renderer) for axis in (row.xaxis, row.yaxis)
             for t in axis.get_ticklabels() if t.get_text()]
    # the premise: the row's tick labels, laid out as not drawn, lie past the page's edges
    assert any(b.x0 < -0.5 or b.y1 > page.y1 + 0.5 for b in ticks)
    assert not text_cut_off(fig)
