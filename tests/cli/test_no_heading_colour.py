"""A place where people stand still has flow but no heading: every export draws it in one
colour of its own (``formats.scene_colours.NO_HEADING_TEAL``), not the grey of "no flow", and
the pictures' legends say so. Checked on a map built from a log of known walks: people walk
+x along y = 1.25 and stand at (10.25, 10.25), read back from the PLY (open3d), the MCAP
(Foxglove's decoder), the PNG (its pixels) and the report's caption."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
import open3d as o3d
import pytest

from aion_cli.formats.scene_colours import NO_FLOW_GREY, NO_HEADING_TEAL
from tests.cli.conftest import run, run_json
from tests.pictures.pixels import count_near, read_png

AT = "2026-01-05 09:00"
STAND = (10.25, 10.25)  # the centre of the 0.5 m cell the standing people are in
COLOR_TOL = 1.5 / 255


@pytest.fixture(scope="module")
def standing_map(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two hours of ATC-layout tracks: a walker every minute along y = 1.25 at +1 m/s (heading
    0), and every two minutes someone standing a minute at STAND (speed 0: no heading)."""
    folder = tmp_path_factory.mktemp("standing")
    t0 = dt.datetime(2026, 1, 5, 8, 0, tzinfo=dt.UTC).timestamp()
    rows = []
    for k, start in enumerate(range(0, 7200, 60)):
        rows += [(t0 + start + s, k, s + 0.25, 1.25, 1.0, 0.0) for s in range(6)]
    for k, start in enumerate(range(0, 7200, 120), 1000):
        rows += [(t0 + start + s, k, *STAND, 0.0, 0.0) for s in range(60)]
    csv = folder / "tracks.csv"
    csv.write_text("".join(",".join(f"{v:.3f}" for v in r) + "\n" for r in sorted(rows)))
    log, out = folder / "tracks.mcap", folder / "tracks.aion"
    assert run("convert", csv, "--layout", "atc", "-o", log, "-q").exit_code == 0
    assert run("build", log, "-o", out, "-q").exit_code == 0
    return out


def _standing_entry(entries: list[dict]) -> dict:
    (entry,) = [e for e in entries if (e["x"], e["y"]) == STAND]
    return entry


def test_the_map_has_flow_without_heading_where_people_stand(standing_map: Path) -> None:
    entries = run_json("predict", standing_map, "--time", AT, "--format", "json")["entries"]
    standing = _standing_entry(entries)
    assert standing["flow"] > 0
    assert standing["entropy"] is None
    assert standing["direction_deg"] is None
    walking = [e for e in entries if e["y"] == 1.25]
    assert walking
    assert all(e["direction_deg"] == 0.0 for e in walking)


def test_ply_cells_are_teal_where_people_stand_blue_where_they_walk(
    standing_map: Path, tmp_path: Path
) -> None:
    assert run("export", standing_map, "--time", AT, "-o", tmp_path, "-q").exit_code == 0
    mesh = o3d.io.read_triangle_mesh(tmp_path / "cells.ply")
    squares = np.asarray(mesh.vertices).reshape(-1, 4, 3)  # a flat square of 4 per cell
    colours = np.asarray(mesh.vertex_colors).reshape(-1, 4, 3)[:, 0]
    centres = squares.mean(axis=1)[:, :2]
    at_stand = np.all(np.isclose(centres, STAND), axis=1)
    assert at_stand.sum() == 1
    np.testing.assert_allclose(colours[at_stand][0], NO_HEADING_TEAL, atol=COLOR_TOL)
    walking = np.isclose(centres[:, 1], 1.25)
    assert walking.sum() >= 5
    np.testing.assert_allclose(colours[walking], [[0.0, 0.0, 1.0]] * walking.sum(), atol=0.02)
    assert not np.any(np.all(np.isclose(colours, NO_FLOW_GREY, atol=COLOR_TOL), axis=1))


def test_mcap_cube_is_teal_where_people_stand(standing_map: Path, tmp_path: Path) -> None:
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    out = tmp_path / "scene.mcap"
    assert run("export", standing_map, "--time", AT, "-o", out, "-q").exit_code == 0
    with out.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        (update,) = [m for _, _, _, m in reader.iter_decoded_messages(topics=["/aion/scene"])]
    cubes = [c for e in update.entities for c in e.cubes]
    (cube,) = [c for c in cubes if (c.pose.position.x, c.pose.position.y) == STAND]
    assert (cube.color.r, cube.color.g, cube.color.b) == pytest.approx(NO_HEADING_TEAL)


def test_png_draws_the_standing_cell_teal_and_says_what_teal_means(
    standing_map: Path, tmp_path: Path
) -> None:
    from aion_cli.formats.scene_colours import NO_HEADING_KEY
    from aion_cli.mapquery import load_map
    from aion_cli.pictures.topdown import topdown_figure
    from aion_cli.scene import scene_at

    out = tmp_path / "map.png"
    assert run("export", standing_map, "--time", AT, "--format", "png", "-o", out).exit_code == 0
    image = read_png(out)
    # the square drawn solid (no arrow on it) over the white panel: 0.85 teal, 0.15 white
    solid = 0.85 * np.asarray(NO_HEADING_TEAL) + 0.15
    assert count_near(image, tuple(solid), tol=0.05) > 20
    loaded = load_map(standing_map)
    t_ns = int(dt.datetime(2026, 1, 5, 9, 0, tzinfo=dt.UTC).timestamp()) * 10**9
    fig = topdown_figure([scene_at(loaded, t_ns)], ["t"])
    legend = fig._supxlabel.get_text()
    fig.canvas.draw()  # the legend, a line longer than before, is not cut at the page's edges
    box = fig._supxlabel.get_window_extent()
    assert box.x0 >= 0
    assert box.x1 <= fig.bbox.x1
    assert NO_HEADING_KEY in legend
    assert "grey: no flow" not in legend  # every cell has flow: no grey is drawn to name


def test_the_colour_key_names_the_colours_drawn() -> None:
    from aion_cli.formats.scene_colours import NO_HEADING_KEY, colour_key, has_no_flow

    assert colour_key(True, True) == f"grey: no flow; {NO_HEADING_KEY}"
    assert colour_key(False, True) == "grey: no flow"
    assert colour_key(True, False) == NO_HEADING_KEY
    assert colour_key(False, False) == ""
    assert has_no_flow([1.0, 0.0])
    assert has_no_flow([1.0, np.nan])
    assert not has_no_flow([2.0, 1.0])


def test_report_caption_leaves_the_colours_to_the_pictures_legend(
    standing_map: Path, tmp_path: Path
) -> None:
    """The caption under the map from above names no colour the picture may lack (it said
    'grey: no flow' under pictures without grey); the picture's own legend names the ones
    drawn (teal here: test_png_draws_the_standing_cell_teal_and_says_what_teal_means)."""
    out = tmp_path / "report"
    assert run("report", standing_map, "--time", AT, "-o", out, "-q").exit_code == 0
    page = (out / "index.html").read_text()
    assert "the legend under the picture names the other colours it draws" in page
    assert "grey: no flow" not in page  # every cell of this map has flow: no grey drawn
    assert "dashed outlines" not in page  # a map of hash cells: no rooms to outline
