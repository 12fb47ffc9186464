"""``aion export --format png`` and ``aion plan --png``: PNG pictures of the office map read
back (matplotlib's PNG reader), panels counted, path colours found, bad targets refused."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from aion_cli.errors import InputError
from aion_cli.formats.scene_colours import PATH_GREEN
from aion_cli.pictures.plan import DISTANCE_ORANGE, TEMPORAL_GREEN
from aion_cli.pictures.png_mark import PNG_MAGIC
from tests.cli.conftest import (
    Office,
    assert_one_line_error,
    figure_texts,
    kept_figures,
    run,
    run_json,
    run_process,
)
from tests.pictures.pixels import count_near, panel_count, read_png

AT = "2026-11-23 08:30"
BLUE = (0.0, 0.0, 1.0)


def test_one_time_is_one_panel_with_the_flows(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "map.png"
    result = run("export", office.map, "--time", AT, "--format", "png", "-o", out)
    assert result.exit_code == 0, result.stderr
    assert f"wrote {out}" in result.stderr.replace("\n", "")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.png"]
    image = read_png(out)
    assert panel_count(image) == 1
    # track 1 walks +x past p1 all the time: one direction, entropy ~0, drawn blue
    predicted = run_json("predict", office.map, "--time", AT, "--node", "p1", "--format", "json")
    assert predicted["entries"][0]["entropy"] < 0.2
    assert count_near(image, BLUE, tol=0.25) > 20


def test_series_is_small_multiples_with_the_path(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "day.png"
    result = run(
        "export",
        office.map,
        "--from",
        "2026-11-23 08:00",
        "--to",
        "2026-11-23 09:00",
        "--step",
        "30m",
        "--format",
        "png",
        "-o",
        out,
        "--path-from",
        "p0",
        "--path-to",
        "p4",
    )
    assert result.exit_code == 0, result.stderr
    image = read_png(out)
    assert panel_count(image) == 3
    assert count_near(image, PATH_GREEN, tol=0.1) > 3 * 50  # the path in every panel
    single = tmp_path / "one.png"
    assert run("export", office.map, "--historical", "--format", "png", "-o", single).exit_code == 0
    assert count_near(read_png(single), PATH_GREEN, tol=0.1) == 0  # no path asked for


def test_a_picture_aion_drew_is_replaced_another_png_is_not(
    office: Office, tmp_path: Path
) -> None:
    out = tmp_path / "map.png"
    for _ in range(2):  # the second run replaces the picture the first drew
        assert run("export", office.map, "--historical", "-o", out).exit_code == 0
    assert panel_count(read_png(out)) == 1
    other = tmp_path / "photo.png"
    other.write_bytes(PNG_MAGIC + b"someone else's")
    result = run("export", office.map, "--historical", "-o", other)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "not a picture aion drew")
    assert other.read_bytes() == PNG_MAGIC + b"someone else's"


@pytest.mark.parametrize(
    ("target", "fragment"),
    [
        ("folder", "is a folder"),
        ("missing/map.png", "does not exist"),
        ("map.jpg", ".png"),
        ("notes.png", "not a picture aion drew"),
    ],
)
def test_bad_png_targets_exit_2(office: Office, tmp_path: Path, target: str, fragment: str) -> None:
    (tmp_path / "folder").mkdir()
    (tmp_path / "notes.png").write_text("keep me")
    result = run("export", office.map, "--time", AT, "--format", "png", "-o", tmp_path / target)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, fragment)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder", "notes.png"]
    assert (tmp_path / "notes.png").read_text() == "keep me"
    assert list((tmp_path / "folder").iterdir()) == []


def test_too_many_panels_hints_a_larger_step(office: Office, tmp_path: Path) -> None:
    whole_day = run(
        "export", office.map, "--from", "2026-11-23 00:00", "--to", "2026-11-23 23:00",
        "--format", "png", "-o", tmp_path / "24.png",
    )  # fmt: skip
    assert whole_day.exit_code == 0, whole_day.stderr  # 24 hourly panels: the most there is
    assert panel_count(read_png(tmp_path / "24.png")) == 24
    (tmp_path / "24.png").unlink()
    result = run(
        "export",
        office.map,
        "--from",
        "2026-11-23 06:00",
        "--to",
        "2026-11-23 20:00",
        "--step",
        "30m",
        "--format",
        "png",
        "-o",
        tmp_path / "day.png",
    )
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "29 panels", "24")
    assert "--step" in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_an_exported_path_says_where_it_starts_and_ends(office: Office, tmp_path: Path) -> None:
    """``export --format png --path-from p0 --path-to p4``: the path was a green line with
    "planned path" in the legend, which end its start and which its goal unsaid (the
    temporal path is planned one way, against the flows it meets). The goal is a magenta
    star at the path's end at p4, (4, 2) m, right of and above the path's middle (p0 is at
    the origin); the start a circle, as ``plan --png`` draws them."""
    import numpy as np
    from scipy.ndimage import label

    from aion_cli.pictures.plan import GOAL_COLOR

    out = tmp_path / "path.png"
    args = ["--time", AT, "--format", "png", "-o", out, "--path-from", "p0", "--path-to", "p4"]
    assert run("export", office.map, *args).exit_code == 0
    image = read_png(out)

    def parts(colour: tuple[float, ...]) -> list[np.ndarray]:
        """The connected patches of ``colour``, largest first, as their pixels' (row,
        column)."""
        patches, n = label(np.abs(image - colour).max(axis=2) < 0.1)
        found = [np.argwhere(patches == k) for k in range(1, n + 1)]
        return sorted(found, key=len, reverse=True)

    path = parts(PATH_GREEN)[0]  # the path on the map (the legend's line is shorter)
    stars = parts(GOAL_COLOR)  # the star on the map and the legend's
    assert stars, "no goal marker"
    near = [float(np.hypot(*(path - star.mean(axis=0)).T).min()) for star in stars]
    assert min(near) < 12  # a star on the path
    centre = stars[int(np.argmin(near))].mean(axis=0)
    assert centre[1] > path[:, 1].mean()  # right of its middle (x 4 m, the start's 0)
    assert centre[0] < path[:, 0].mean()  # above it (y 2 m; rows run down)


def test_plan_png_shows_both_routes(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "plan.png"
    args: list[str | Path] = [
        "plan",
        office.map,
        "--from",
        "p0",
        "--to",
        "p4",
        "--time",
        AT,
        "--format",
        "json",
    ]
    doc = run_json(*args, "--png", out)
    assert doc["png"] == str(out)
    plain = run_json(*args)
    assert {k: v for k, v in doc.items() if k != "png"} == plain  # the same plan
    image = read_png(out)
    assert panel_count(image) == 1
    assert count_near(image, TEMPORAL_GREEN, tol=0.1) > 50
    assert count_near(image, DISTANCE_ORANGE, tol=0.1) > 50


def test_plan_png_into_a_missing_folder_exits_2_before_planning(
    office: Office, tmp_path: Path
) -> None:
    result = run(
        "plan", office.map, "--from", "p0", "--to", "p4", "--time", AT,
        "--png", tmp_path / "nowhere" / "plan.png",
    )  # fmt: skip
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "--png", "does not exist")
    assert result.stdout == ""
    assert list(tmp_path.iterdir()) == []


def test_plan_png_in_a_subprocess(office: Office, tmp_path: Path) -> None:
    """The console script draws without a display (Agg, no pyplot)."""
    out = tmp_path / "plan.png"
    proc = run_process(
        "plan", office.map, "--from", "p0", "--to", "p3", "--time", AT, "--png", out,
        "--format", "json",
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["png"] == str(out)
    assert out.read_bytes().startswith(PNG_MAGIC)


def test_the_api_draws_what_the_cli_draws(office: Office, tmp_path: Path) -> None:
    from aion_cli.api import Map

    cli_out = tmp_path / "cli.png"
    args = ["--time", AT, "--tz", "UTC", "--path-from", "p0", "--path-to", "p4"]
    assert run("export", office.map, *args, "--format", "png", "-o", cli_out).exit_code == 0
    m = Map.load(office.map)
    out = m.picture(tmp_path / "api.png", time=AT, tz="UTC", path=("p0", "p4"))
    assert out == tmp_path / "api.png"
    assert out.read_bytes() == cli_out.read_bytes()
    with pytest.raises(InputError, match="not both"):
        m.picture(tmp_path / "x.png", time=AT, historical=True)
    with pytest.raises(InputError, match="is a folder"):
        m.picture(tmp_path, historical=True)


def test_a_name_the_font_cannot_draw_prints_no_python_warning(
    office: Office, tmp_path: Path
) -> None:
    """A map named in Japanese (its name is the picture's title; DejaVu Sans has no kana):
    matplotlib warned once per character, `.../png_mark.py:18: UserWarning: Glyph 12525
    (\\N{KATAKANA LETTER RO}) missing from font(s) DejaVu Sans.` and the source line, on the
    terminal of a command that succeeded."""
    named = tmp_path / "ログ 地図.aion"
    named.write_bytes(office.map.read_bytes())
    out = tmp_path / "出力.png"
    proc = run_process("export", named, "--time", AT, "--format", "png", "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert out.read_bytes().startswith(PNG_MAGIC)
    assert "Glyph" not in proc.stderr, proc.stderr
    assert "Warning" not in proc.stderr, proc.stderr


@pytest.mark.parametrize(
    "text",
    [
        "Glyph 12525 (\\N{KATAKANA LETTER RO}) missing from font(s) DejaVu Sans.",  # 3.9 on
        "Glyph 12525 (\\N{KATAKANA LETTER RO}) missing from current font.",  # 3.7, 3.8
    ],
)
def test_the_missing_glyph_warning_of_every_supported_matplotlib_is_left_out(
    text: str, tmp_path: Path
) -> None:
    """pyproject asks for matplotlib>=3.7, whose 3.7 and 3.8 word the warning "missing from
    current font." (the filter matched only 3.9's "missing from font(s) ...")."""
    import warnings

    from aion_cli.pictures.png_mark import save_marked_png

    class Figure:
        def savefig(self, path: Path, **options: object) -> None:
            warnings.warn(text, UserWarning, stacklevel=1)
            Path(path).write_bytes(PNG_MAGIC)

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        save_marked_png(Figure(), tmp_path / "x.png")
    assert (tmp_path / "x.png").read_bytes() == PNG_MAGIC


def _axis_labels(loaded: Any, out: Path, monkeypatch: pytest.MonkeyPatch) -> set[tuple[str, str]]:
    """The (x, y) labels of the panels of ``loaded``'s picture at ``AT`` (the figure kept as
    :func:`~aion_cli.pictures.render.save_png` saves it)."""
    from aion_cli.api_time import to_ns
    from aion_cli.pictures import render

    figures = kept_figures(monkeypatch)
    render.render_map_png(loaded, to_ns(AT), None, out)
    (fig,) = figures
    return {(ax.get_xlabel(), ax.get_ylabel()) for ax in fig.axes if ax.get_title()}


def test_the_axes_name_the_frame_the_map_is_in(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A map's positions are in the frame it was built in (``--map-frame``, ``map`` by
    default, as ``aion info`` says): the picture's axes say which, and say nothing for a
    map that does not record it."""
    from dataclasses import replace

    from aion_cli.mapquery import load_map

    loaded = load_map(office.map)
    info = run_json("info", office.map, "--format", "json")
    frame = info["map_frame"]
    assert frame == "map"  # the build's default
    assert _axis_labels(loaded, tmp_path / "a.png", monkeypatch) == {
        ("x (m), frame map", "y (m), frame map")
    }
    odom = replace(loaded, manifest={**loaded.manifest, "map_frame": "odom"})
    assert _axis_labels(odom, tmp_path / "b.png", monkeypatch) == {
        ("x (m), frame odom", "y (m), frame odom")
    }
    unknown = {k: v for k, v in loaded.manifest.items() if k != "map_frame"}
    assert _axis_labels(replace(loaded, manifest=unknown), tmp_path / "c.png", monkeypatch) == {
        ("x (m)", "y (m)")
    }


def test_a_picture_names_what_it_shows_beside_the_map_s_days(
    sample_map: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``aion export MAP --format png`` without ``--time`` draws the forecast now, and its
    title was today's date alone, with nothing to say the sample's data (Monday 2026-01-05 to
    Friday 2026-01-09, samples/README.md) lies months before; ``--historical``'s title did not
    name those days either. Both name them now; a time within a week of the data (before or
    after) does not."""
    days = "the map's data (2026-01-05 to 2026-01-09)"

    def texts(*args: str) -> str:
        out = tmp_path / "map.png"
        (said,) = figure_texts(monkeypatch, "export", sample_map, *args, "-o", out)
        return said

    assert f"after {days}" in texts("--format", "png")  # now: after 2026-01-16
    assert f"before {days}" in texts("--time", "2025-12-01 08:40", "--tz", "UTC")
    assert "7 weeks after" in texts("--time", "2026-02-27 08:40", "--tz", "UTC", "--format", "png")
    assert "as observed (historical), 2026-01-05 to 2026-01-09 UTC" in texts("--historical")
    assert "map's data" not in texts("--time", "2026-01-12 08:40", "--tz", "UTC")
    # nor within a week before it, as after (3 days before had been named)
    assert "map's data" not in texts("--time", "2026-01-02 08:40", "--tz", "UTC")
    plan = tmp_path / "plan.png"  # aion plan --png departs now as well
    (said,) = figure_texts(monkeypatch, "plan", sample_map, "--from", "p1", "--to", "p2",
                           "--png", plan)  # fmt: skip
    assert f"after {days}" in said


def test_a_historical_path_is_named_the_shortest_by_distance(
    sample_map: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``export --historical --format png --path-from --path-to`` draws the shortest path by
    distance (there is no time to forecast costs at; stderr notes it), but the picture's
    legend called it "planned path", as it calls one planned against the flows at
    ``--time``; a picture outlives the note beside it. The legend says which it is."""
    ends = ("--path-from", "p1", "--path-to", "p2", "--format", "png", "-o", tmp_path / "p.png")
    (observed,) = figure_texts(monkeypatch, "export", sample_map, "--historical", *ends)
    assert "shortest path (by distance)" in observed
    assert "planned path" not in observed
    (at_time,) = figure_texts(
        monkeypatch, "export", sample_map, "--time", "2026-01-07 08:40", "--tz", "UTC", *ends
    )
    assert "planned path" in at_time
    assert "by distance" not in at_time
