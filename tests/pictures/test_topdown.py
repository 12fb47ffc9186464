"""The top-down picture, checked by its pixels: a synthetic scene of known geometry is drawn
at a fixed dpi, written as PNG, read back, and the pixels at the data -> pixel positions of
its places, arrows and empty space are compared with what the drawing rules say."""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.errors import InputError
from aion_cli.formats.scene_colours import DISPLAY_QUANTILE, DISPLAY_QUANTILE_FROM, entropy_colors
from aion_cli.pictures.render import save_png
from aion_cli.pictures.topdown import (
    ARROW_CELLS,
    ENTROPY_LABEL,
    MAX_PANELS,
    SINGLE_WIDTH_IN,
    ArrowScale,
    arrow_scale,
    topdown_figure,
)
from aion_cli.scene import Scene
from tests.pictures.pixels import (
    F64,
    cells_only_scene,
    darkest,
    is_blank,
    most_coloured,
    panel_count,
    pixel_of,
    read_png,
    synthetic_scene,
    window,
)

DPI = 100
L = ARROW_CELLS * 0.5  # the full arrow length of the synthetic scene (cell 0.5 m)


def _drawn(
    tmp_path: Path, scenes: list[Scene], name: str = "map.png"
) -> tuple[Any, list[Any], F64]:
    fig = topdown_figure(scenes, [f"panel {i}" for i in range(len(scenes))], dpi=DPI)
    out = save_png(fig, tmp_path / name)
    image = read_png(out)
    # the whole figure, not cropped (a fraction of a pixel is cut: a thin map's height is
    # not a whole number of pixels)
    assert abs(image.shape[0] - fig.get_figheight() * DPI) < 1
    assert abs(image.shape[1] - fig.get_figwidth() * DPI) < 1
    panels = [ax for ax in fig.axes if ax.get_title().startswith("panel")]
    return fig, panels, image


def test_arrows_are_drawn_along_the_dominant_direction_and_empty_space_is_blank(
    tmp_path: Path,
) -> None:
    _, (ax,), image = _drawn(tmp_path, [synthetic_scene()])
    # A points along +x: its shaft is coloured halfway along, nothing behind it
    assert not is_blank(image, *pixel_of(ax, image, L / 2, 0.0))
    assert is_blank(image, *pixel_of(ax, image, -L / 2 - 0.3, 0.0))
    # B points along +y
    assert not is_blank(image, *pixel_of(ax, image, 8.0, L / 2))
    assert is_blank(image, *pixel_of(ax, image, 8.0, -L / 2 - 0.3))
    # nothing lives around (7, 7) and beyond the last place
    assert is_blank(image, *pixel_of(ax, image, 7.0, 7.0))
    assert is_blank(image, *pixel_of(ax, image, 6.0, 9.0))
    # the edge A-C is a grey line, the mesh triangle light grey, the cell purple
    edge = darkest(image, *pixel_of(ax, image, 0.0, 4.0), half=1)
    assert edge.max() - edge.min() < 0.05
    assert edge.max() < 0.85
    mesh = image[pixel_of(ax, image, -3.0, 4.7)]
    assert np.allclose(mesh, 0.9, atol=0.02)
    cell = image[pixel_of(ax, image, 4.0, 6.0 + 0.17)]  # beside its arrow: pale under it
    assert abs(cell[0] - cell[2]) < 0.05  # purple: as red as blue
    assert cell[1] < cell[0] - 0.15
    # the cell's arrow (flow 5 of 10: half length) points along -x
    behind = most_coloured(image, *pixel_of(ax, image, 4.0 - 0.35 * L, 6.0))
    assert abs(behind[0] - behind[2]) < 0.1
    assert behind[0] > 0.3
    assert is_blank(image, *pixel_of(ax, image, 4.0 + 0.35 * L, 6.0), half=1)


def test_arrow_colour_follows_entropy(tmp_path: Path) -> None:
    _, (ax,), image = _drawn(tmp_path, [synthetic_scene(entropy_a=0.1, entropy_b=0.9)])
    low = most_coloured(image, *pixel_of(ax, image, L / 2, 0.0))
    high = most_coloured(image, *pixel_of(ax, image, 8.0, L / 2))
    assert low[0] - low[2] < -0.5  # blue: one direction
    assert high[0] - high[2] > 0.5  # red: every direction
    assert high[0] - high[2] > low[0] - low[2]
    # the exact colours of formats.scene_colours.entropy_colors
    assert np.allclose(low, entropy_colors([0.1])[0], atol=0.12)
    assert np.allclose(high, entropy_colors([0.9])[0], atol=0.12)


def test_colour_bar_is_labelled_and_axes_are_metres(tmp_path: Path) -> None:
    fig, (ax,), _ = _drawn(tmp_path, [synthetic_scene()])
    labels = [a.get_ylabel() for a in fig.axes if a is not ax]
    assert ENTROPY_LABEL in labels
    # a normalised entropy has no unit: the bar says what its ends are (it said neither)
    (bar,) = [a for a in fig.axes if a.get_ylabel() == ENTROPY_LABEL]
    assert bar.get_ylim() == (0.0, 1.0)
    ends = {round(t.get_position()[1], 6): t.get_text() for t in bar.get_yticklabels()}
    assert ends[0.0] == "0 one way"
    assert ends[1.0] == "1 every way"
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x (m)", "y (m)")
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    box = ax.get_window_extent()
    assert box.width / (x1 - x0) == pytest.approx(box.height / (y1 - y0), rel=0.01)  # equal


def test_small_multiples_share_the_flow_scale(tmp_path: Path) -> None:
    """Five panels; the flows are 10 in the first and 5 in the others, so on the shared
    scale node A's arrow is full length in the first panel and half as long in the others
    (each panel on its own scale would draw it full length in every panel)."""
    scenes = [synthetic_scene(flow_a=10.0 if k == 0 else 5.0, flow_b=5.0) for k in range(5)]
    fig, panels, image = _drawn(tmp_path, scenes)
    assert len(panels) == 5
    assert panel_count(image) == 5
    far = [is_blank(image, *pixel_of(ax, image, 0.8 * L, 0.0), half=1) for ax in panels]
    near = [is_blank(image, *pixel_of(ax, image, 0.25 * L, 0.0), half=1) for ax in panels]
    assert far == [False, True, True, True, True]
    assert near == [False] * 5
    limits = {(ax.get_xlim(), ax.get_ylim()) for ax in panels}
    assert len(limits) == 1  # shared axes
    bars = [a for a in fig.axes if a.get_ylabel() == ENTROPY_LABEL]
    assert len(bars) == 1  # one colour bar for all panels


@pytest.mark.parametrize("n", [1, 3, 7])
def test_panel_count_is_the_number_of_scenes(tmp_path: Path, n: int) -> None:
    _, panels, image = _drawn(tmp_path, [synthetic_scene() for _ in range(n)])
    assert len(panels) == n
    assert panel_count(image) == n


def test_too_many_panels_is_an_input_error() -> None:
    with pytest.raises(InputError, match="25 panels"):
        topdown_figure([synthetic_scene()] * (MAX_PANELS + 1), ["t"] * (MAX_PANELS + 1))
    with pytest.raises(InputError):
        topdown_figure([], [])


def test_a_scene_without_flow_or_graph_draws(tmp_path: Path) -> None:
    """A map of hash cells only (no graph, no flow): cells are grey squares, no arrows."""
    scene = cells_only_scene([[4.0, 6.0]], [0.0])
    _, (ax,), image = _drawn(tmp_path, [scene])
    grey = image[pixel_of(ax, image, 4.0, 6.0)]
    assert grey.max() - grey.min() < 0.03  # no flow: grey
    assert grey.max() < 0.7


def _inside_by(hull: F64, points: F64) -> F64:
    """How far inside the closed convex polygon ``hull`` each point lies (negative: outside):
    its least distance to the polygon's edge lines, signed."""
    a, b = hull, np.roll(hull, -1, axis=0)
    edge = b - a
    normal = np.column_stack([edge[:, 1], -edge[:, 0]]) / np.linalg.norm(edge, axis=1)[:, None]
    centre = hull.mean(axis=0)
    normal *= np.sign(((a - centre) * normal).sum(axis=1))[:, None]  # outward
    return np.asarray(((a[None] - points[:, None]) * normal[None]).sum(axis=2).min(axis=1))


def test_room_outlines_are_padded_hulls_labelled_at_the_centroid() -> None:
    """Every place of a room lies a cell inside its outline, whatever the room's shape: the
    outline pushed the hull's corners out from the centroid, so a long hallway's outline ran
    through its places, tapering to points at its ends, and a room of places in one row
    (a corridor) had no outline at all."""
    import dataclasses

    from aion_cli.pictures.topdown import room_outlines

    scene = synthetic_scene()
    rooms = room_outlines(scene)
    (hull,) = rooms.hulls
    places = scene.places_xyz[:, :2]
    assert _inside_by(hull, places).min() >= scene.cell_size - 1e-9
    assert _inside_by(hull, places).min() <= 1.1 * scene.cell_size  # no more than a cell
    assert rooms.labels == ("lab",)
    assert np.allclose(rooms.label_xy, [places.mean(axis=0)])
    # a hallway: 40 places in a row and one door off it; a corridor of places in one row
    row = [[x, 15.5, 0.0] for x in np.arange(0.5, 40.0, 1.0)]
    for xyz in ([*row, [20.0, 17.0, 0.0]], row):
        hallway = np.array(xyz)
        long = dataclasses.replace(
            scene,
            places_xyz=hallway,
            place_room=np.zeros(len(hallway), np.int64),
            room_labels=("",),
        )
        outlines = room_outlines(long)
        (hull,) = outlines.hulls
        assert _inside_by(hull, hallway[:, :2]).min() >= scene.cell_size - 1e-9
        assert outlines.labels == ("R0",)  # an unnamed room is labelled by its id


def _many_cells(flows: F64) -> Scene:
    """The synthetic scene plus a row of hash cells at y = -6, one per flow, 3 m apart,
    pointing along +x."""
    from dataclasses import replace

    base = synthetic_scene()
    n = len(flows)
    xyz = np.column_stack([3.0 * np.arange(n), np.full(n, -6.0), np.zeros(n)])
    return replace(
        base,
        node_flow=np.zeros(3),
        cells_xyz=xyz,
        cells_flow=np.asarray(flows, dtype=np.float64),
        cells_entropy=np.full(n, 0.2),
        cells_angle=np.zeros(n),
    )


def test_the_arrow_scale_is_the_busiest_flow_unless_one_dwarfs_the_rest() -> None:
    even = np.linspace(1.0, 2.0, 30)
    assert arrow_scale([_many_cells(even)]) == ArrowScale(2.0, 2.0)
    tail = np.r_[np.ones(29), 100.0]  # one entrance with 100, the rest 1
    scale = arrow_scale([_many_cells(tail)])
    assert scale.largest == 100.0
    assert scale.flow == pytest.approx(np.quantile(tail, DISPLAY_QUANTILE))
    assert "the largest 100" in scale.legend(600.0)
    few = np.r_[np.ones(DISPLAY_QUANTILE_FROM - 2), 100.0]  # too few entries to judge a tail
    assert arrow_scale([_many_cells(few)]) == ArrowScale(100.0, 100.0)
    # every panel of a series shares one scale: the pooled flows'
    pooled = arrow_scale([_many_cells(np.ones(15)), _many_cells(np.r_[np.ones(14), 100.0])])
    assert pooled.flow == pytest.approx(np.quantile(np.r_[np.ones(29), 100.0], DISPLAY_QUANTILE))


@pytest.mark.parametrize(
    ("flows", "shown"),
    [
        (np.r_[np.ones(29), 1567.7], ["up to 1 detection per", "the largest 1,570)"]),
        (np.linspace(100.0, 1567.7, 30), ["(the longest: 1,570 detections per 600-s window)"]),
        (np.linspace(0.1, 0.974, 30), ["(the longest: 0.974 detections per 600-s window)"]),
    ],
)
def test_the_arrow_legend_writes_flows_without_an_exponent(
    flows: np.ndarray, shown: list[str]
) -> None:
    """UCY's students003 (a crowded square) has 1,570 detections a window at its busiest
    place: the legend read "the longest: 1.57e+03 detections per 600-s window". Flows are
    written to three significant digits in plain figures, as below 1,000 they were."""
    legend = arrow_scale([_many_cells(flows)]).legend(600.0)
    assert "e+" not in legend
    for text in shown:
        assert text in legend, legend


def test_a_heavy_tail_leaves_the_other_arrows_visible(tmp_path: Path) -> None:
    """With the busiest cell 100 times the others, scaled to the busiest their arrows would be
    1 % of full length (a dot); scaled to the 95th percentile they are full length."""
    flows = np.r_[np.ones(29), 100.0]
    fig, (ax,), image = _drawn(tmp_path, [_many_cells(flows)])
    assert not is_blank(image, *pixel_of(ax, image, 0.8 * L, -6.0), half=1)  # cell 0: flow 1
    assert "the largest 100" in fig.get_supxlabel()


def test_a_corridor_series_is_stacked_full_width_without_white_rows() -> None:
    """Seven times of a 100 m x 2 m corridor: each panel was 3.6 inches wide in rows 1.4
    inches high holding a strip 0.3 inches high, the page four-fifths white. A strip's panels
    are stacked, each as wide as a single picture, rows as high as the strip and its text."""
    side = np.arange(0.25, 100.0, 0.5)
    xy = np.array([(x, y) for x in side for y in (0.25, 0.75, 1.25, 1.75)])
    n = len(xy)
    scene = cells_only_scene(xy, np.ones(n), np.zeros(n), np.full(n, 0.1))
    fig = topdown_figure([scene] * 7, [f"t{k}" for k in range(7)])
    fig.canvas.draw()
    panels = [a for a in fig.axes if a.get_title()]
    assert len({round(a.get_position().x0, 3) for a in panels}) == 1  # one column
    for ax in panels:
        assert ax.get_window_extent().width >= 0.8 * SINGLE_WIDTH_IN * fig.dpi
    drawn = sum(ax.get_window_extent().height for ax in panels)
    assert drawn >= 0.4 * fig.bbox.height
    # a single picture of it: no more than the strip, its text and the colour bar's room
    (one,) = [a for a in topdown_figure([scene], ["t"]).axes if a.get_title()]
    assert one.figure.get_size_inches()[1] <= 3.2


def test_arrows_stand_out_from_the_cells_they_are_drawn_on(tmp_path: Path) -> None:
    """A map of hash cells only (THÖR, ATC built without a graph): each cell's square and its
    arrow have the same entropy colour; the squares, drawn almost solid, hid the arrows on
    them. The squares are pale beside the arrow on them."""
    side = np.arange(0.25, 5.0, 0.5)
    xy = np.array([(x, y) for x in side for y in side])
    n = len(xy)
    scene = cells_only_scene(xy, np.ones(n), np.zeros(n), np.full(n, 0.5))
    _, (ax,), image = _drawn(tmp_path, [scene])
    x, y = 1.75, 2.25  # an arrow from this cell's centre along +x, 2 m long
    shaft = darkest(image, *pixel_of(ax, image, x + 0.6, y), half=1)
    square = window(image, *pixel_of(ax, image, x + 0.6, y + 0.17), half=0)[0]
    assert np.abs(shaft - square).max() > 0.3


def test_names_with_dollars_are_drawn_as_they_are() -> None:
    """A map named ``cost$1$.aion`` was titled "cost1.aion" (matplotlib read ``$1$`` as
    mathematics), and so were room names and panel titles holding two dollars."""
    import dataclasses

    scene = dataclasses.replace(synthetic_scene(), room_labels=("$lab$",))
    fig = topdown_figure([scene, scene], ["t$1$", "t$2$"], suptitle="cost$1$.aion")
    fig.canvas.draw()
    texts = [fig._suptitle, *(ax.title for ax in fig.axes)]
    texts += [t for ax in fig.axes for t in ax.texts]
    shown = {}
    for text in texts:
        if text is not None and text.get_text():
            s, math = text._preprocess_math(text.get_text())
            assert not math, s
            shown[s] = text
    assert {"cost$1$.aion", "t$1$", "t$2$", "$lab$"} <= set(shown)


def test_legend_labels_with_dollars_are_drawn_as_they_are() -> None:
    """``aion plan --from kitchen --to "R&D $5 and $10" --png``: the legend's goal read
    "goal R&D 5and10" (matplotlib read ``$5 and $`` as mathematics), though the title, drawn
    as plain text, named the room whole; a path's label alike."""
    from aion_cli.pictures.plan import end_markers
    from aion_cli.pictures.topdown_panel import PathLine

    xyz = np.array([[0.0, 0.0, 0.0], [2.0, 1.0, 0.0]])
    markers = end_markers(xyz, "kitchen (p1)", "R&D $5 and $10 (p4)")
    paths = [[PathLine(xyz, "path $a$", (0.0, 0.7, 0.0))]]
    fig = topdown_figure([synthetic_scene()], ["t"], paths=paths, markers=markers)
    fig.canvas.draw()
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    shown = set()
    for text in (t for legend in legends for t in legend.get_texts()):
        s, math = text._preprocess_math(text.get_text())
        assert not math, s
        shown.add(s)
    assert {"goal R&D $5 and $10 (p4)", "start kitchen (p1)", "path $a$"} <= shown


def test_flow_without_a_heading_does_not_shrink_the_arrows(tmp_path: Path) -> None:
    """Three cells walked +x (flow 5) and one where people stand (flow 300, no heading, so no
    arrow): the arrows' scale is that of the walked cells, whose arrows are full length; with
    the standing flow in the scale they were 5/300 of it, dots under their tails."""
    scene = cells_only_scene(
        [[0.0, 0.0], [0.0, 3.0], [0.0, 6.0], [6.0, 3.0]],
        [5.0, 5.0, 5.0, 300.0],
        angle=[0.0, 0.0, 0.0, np.nan],
        entropy=[0.0, 0.0, 0.0, np.nan],
    )
    assert arrow_scale([scene]) == ArrowScale(5.0, 5.0)
    fig, (ax,), image = _drawn(tmp_path, [scene])
    assert "300" not in fig._supxlabel.get_text()
    for y in (0.0, 3.0, 6.0):  # blue three quarters along the full length, blank past its tip
        tip = most_coloured(image, *pixel_of(ax, image, 0.75 * L, y))
        assert tip[2] - tip[0] > 0.5
        assert is_blank(image, *pixel_of(ax, image, L + 0.4, y), half=1)


def test_a_corridor_along_y_is_drawn_on_a_narrow_page_with_its_text_inside() -> None:
    """A 100 m corridor along y, 2 m wide: the single picture was 9.4 inches wide for a map
    drawn 0.4 inches wide (the page nine-tenths white) and a series' panels 3.6 inches each;
    the pages are narrowed to the map, and the title and legend, which ran past the edges of
    a narrow page on one line, are broken into lines that fit."""
    from aion_cli.pictures.layout import NARROW_IN

    n = 40
    scene = cells_only_scene(
        np.column_stack([np.zeros(n), 2.5 * np.arange(n)]),
        np.r_[np.ones(n - 1), 100.0],
        angle=np.r_[np.zeros(n - 2), np.nan, 0.0],
        entropy=np.r_[np.full(n - 2, 0.3), np.nan, 0.3],
    )
    title = "a-long-map-name.aion: Mon 2026-01-12 06:00 to 20:00 Europe/Berlin, 3 times"
    for k, least in ((1, NARROW_IN[0]), (3, NARROW_IN[1])):
        fig = topdown_figure([scene] * k, ["t"] * k, suptitle=title)
        assert fig.get_figwidth() <= k * least + 1.5
        fig.canvas.draw()
        for text in (fig._suptitle, fig._supxlabel):
            box = text.get_window_extent()
            assert box.x0 >= 0, text.get_text()
            assert box.x1 <= fig.bbox.x1, text.get_text()
        assert "teal: flow without a heading" in fig._supxlabel.get_text().replace("\n", " ")


def test_the_x_tick_labels_of_a_narrow_map_do_not_run_together() -> None:
    """A corridor along y, 2 m wide, drawn 100 m high: its panel is a fraction of an inch
    wide, and its three x tick labels ("-2.5", "0.0", "2.5") were drawn over one another."""
    n = 40
    scene = cells_only_scene(np.column_stack([np.zeros(n), 2.5 * np.arange(n)]), np.ones(n))
    fig = topdown_figure([scene], ["t"])
    fig.canvas.draw()
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    lo, hi = ax.get_xlim()
    labels = [t for t in ax.get_xticklabels() if t.get_text() and lo <= t.get_position()[0] <= hi]
    assert labels  # the axis still says where it is
    boxes = sorted((t.get_window_extent() for t in labels), key=lambda b: b.x0)
    for left, right in pairwise(boxes):
        assert left.x1 <= right.x0, [t.get_text() for t in labels]


def test_six_digit_x_tick_labels_of_small_panels_do_not_run_together() -> None:
    """A 100 m square map at UTM-like coordinates (x = 400 000 m), nine times in one picture:
    each panel's six x tick labels ("400000", "400020", ... "400100") ran into one another.
    The labels still read the map's own coordinates (no "+4e5" offset), fewer of them."""
    xs, ys = np.meshgrid(np.arange(0.0, 100.0, 2.0), np.arange(0.0, 100.0, 2.0))
    xy = np.column_stack([xs.ravel() + 400_000.0, ys.ravel() + 5_000_000.0])
    scene = cells_only_scene(xy, np.ones(len(xy)))
    fig = topdown_figure([scene] * 9, ["t"] * 9, dpi=DPI)
    fig.canvas.draw()
    boxes = []
    for ax in [a for a in fig.axes if a.get_title() == "t"]:
        lo, hi = ax.get_xlim()
        labels = [t for t in ax.get_xticklabels()
                  if t.get_visible() and t.get_text() and lo <= t.get_position()[0] <= hi]
        assert all(float(t.get_text()) >= 400_000 for t in labels)  # the map's own x
        assert ax.xaxis.get_offset_text().get_text() == ""
        boxes += [t.get_window_extent() for t in labels]
    assert boxes
    for k, box in enumerate(boxes):  # none overlaps another, in its panel or the next
        assert not any(box.overlaps(other) for other in boxes[k + 1 :])
