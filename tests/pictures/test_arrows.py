"""Arrows merged over blocks where a picture cannot resolve one per entry: the flow of a
block is the sum of its entries', its arrow points the way most of that flow goes (not
across a corridor walked both ways), and small maps keep one arrow per entry."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from aion_cli.pictures.arrows import ARROWS_PER_INCH, MERGE_FROM, arrow_block, arrow_field
from aion_cli.pictures.backdrop import Extent
from aion_cli.pictures.topdown import SINGLE_WIDTH_IN, scene_extent, topdown_figure
from aion_cli.scene import Scene
from tests.pictures.pixels import cells_only_scene, synthetic_scene


def test_one_arrow_per_entry_without_blocks() -> None:
    scene = synthetic_scene()  # nodes A and B flow, C does not; one cell flows
    field = arrow_field(scene)
    assert field.block is None
    assert field.flow.tolist() == [10.0, 10.0, 5.0]
    assert field.xy.tolist() == [[0.0, 0.0], [8.0, 0.0], [4.0, 6.0]]
    assert field.angle.tolist() == [0.0, math.pi / 2, math.pi]
    assert field.legend() == ""


def test_a_block_sums_its_flow_and_follows_the_majority() -> None:
    """Block [0, 2) x [0, 2): three cells walked east (flows 1, 1, 2) and two walked west
    (flows 1.5, 1.5): 4 against 3, so the arrow points east although the flow-weighted mean
    of the five directions is short; block [2, 4) x [0, 2): one cell north."""
    xy = np.array([[0.25, 0.25], [0.75, 0.25], [1.25, 0.75], [0.25, 1.75], [1.75, 1.75],
                   [2.5, 0.5]])
    flow = np.array([1.0, 1.0, 2.0, 1.5, 1.5, 0.5])
    east, west = math.radians(3.0), math.pi - math.radians(1.0)
    angle = np.array([east, east, east, west, west, math.pi / 2])
    entropy = np.array([0.2, 0.2, 0.2, 0.6, 0.6, 0.1])
    field = arrow_field(cells_only_scene(xy, flow, angle, entropy), block=2.0)
    assert field.block == 2.0
    assert field.flow.tolist() == [7.0, 0.5]
    assert field.flow.sum() == flow.sum()  # conserved
    np.testing.assert_allclose(field.xy[0], (flow[:5, None] * xy[:5]).sum(axis=0) / 7.0)
    np.testing.assert_allclose(field.xy[1], [2.5, 0.5])
    assert field.angle[0] == pytest.approx(east)
    assert field.angle[1] == pytest.approx(math.pi / 2)
    assert field.entropy[0] == pytest.approx((4 * 0.2 + 3 * 0.6) / 7)
    assert "one arrow per 2 m block" in field.legend()
    # more walked west: the arrow turns
    flow[3:5] = 2.5
    turned = arrow_field(cells_only_scene(xy, flow, angle, entropy), block=2.0)
    assert turned.angle[0] == pytest.approx(west)


def test_blocks_are_anchored_at_the_origin() -> None:
    """Every panel of a series merges over the same blocks, whatever its flows."""
    rng = np.random.default_rng(1)
    xy = rng.uniform(-20, 20, (300, 2))
    angle = rng.uniform(-math.pi, math.pi, 300)
    a = arrow_field(cells_only_scene(xy, rng.uniform(0.1, 1, 300), angle, np.full(300, 0.5)), 4.0)
    b = arrow_field(cells_only_scene(xy, rng.uniform(0.1, 1, 300), angle, np.full(300, 0.5)), 4.0)
    np.testing.assert_array_equal(np.floor(a.xy / 4.0), np.floor(b.xy / 4.0))


def test_the_legend_gives_the_block_s_edge() -> None:
    """A block of 21 cells of 0.5 m is 10.5 m: the legend said "one arrow per 10 m block"
    (two significant digits)."""
    xy = np.array([[0.25, 0.25], [20.25, 0.25]])
    field = arrow_field(cells_only_scene(xy, np.ones(2), np.zeros(2), np.full(2, 0.1)), 10.5)
    assert "one arrow per 10.5 m block" in field.legend()


def test_small_maps_keep_one_arrow_per_entry() -> None:
    office = Extent(-2.0, 42.0, -2.0, 26.0)
    assert arrow_block(office, 8.0, 0.5) is None
    campus = Extent(0.0, 160.0, 0.0, 160.0)
    block = arrow_block(campus, 8.0, 0.5)
    assert block is not None
    assert block > MERGE_FROM * 0.5


def test_a_dense_map_is_drawn_with_merged_arrows() -> None:
    side = np.arange(0.25, 100.0, 0.5)
    xy = np.array([(x, y) for x in side for y in side])
    n = len(xy)
    scene = cells_only_scene(xy, np.ones(n), np.zeros(n), np.full(n, 0.3))
    fig = topdown_figure([scene], ["t"])
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    (quiver,) = [c for c in ax.collections if type(c).__name__ == "Quiver"]
    block = arrow_block(scene_extent([scene]), SINGLE_WIDTH_IN, 0.5)  # as the figure's
    assert block is not None
    drawn = int(quiver.N)
    assert drawn == len(arrow_field(scene, block).flow)
    assert drawn <= n / MERGE_FROM**2  # blocks of more than 3 x 3 cells
    assert f"one arrow per {block:.4g} m block" in fig._supxlabel.get_text()


def _nodes_only(xy: np.ndarray, angle: float, entropy: float) -> Scene:
    """A scene graph of places at ``xy`` f64[n,2], each a node with flow 1 along ``angle``."""
    n = len(xy)
    xyz = np.column_stack([xy, np.zeros(n)])
    empty3 = np.zeros((0, 3))
    return replace(
        cells_only_scene(np.zeros((0, 2)), np.zeros(0)),
        node_ids=np.arange(n, dtype=np.uint64),
        nodes_xyz=xyz,
        node_flow=np.ones(n),
        node_entropy=np.full(n, entropy),
        node_angle=np.full(n, angle),
        node_concentration=np.full(n, 0.9),
        cells_xyz=empty3,
        places_xyz=xyz,
        place_room=np.full(n, -1, np.int64),
    )


def _flow_dots(fig: Any) -> list[Any]:
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    return [c for c in ax.collections if type(c).__name__ == "PathCollection"
            and c.get_zorder() == 5]


def test_node_dots_do_not_hide_merged_arrows() -> None:
    """A map of 10^4 places a metre apart over 100 m merges its arrows into blocks; its
    places' flow dots, overlapping about four pixels apart in the arrows' own colours, were a
    solid carpet that hid the arrows. Under merged arrows the dots are left out (the block's
    arrow carries their flow); a small map keeps one dot per node with flow."""
    side = np.arange(0.5, 100.0, 1.0)
    big = _nodes_only(np.array([(x, y) for x in side for y in side]), 0.0, 0.1)
    assert arrow_block(scene_extent([big]), SINGLE_WIDTH_IN, 0.5) is not None
    fig = topdown_figure([big], ["t"])
    assert _flow_dots(fig) == []
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    (quiver,) = [c for c in ax.collections if type(c).__name__ == "Quiver"]
    assert quiver.N > 0
    small = _nodes_only(np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]]), 0.0, 0.1)
    (dots,) = _flow_dots(topdown_figure([small], ["t"]))
    assert len(dots.get_offsets()) == 3


def test_the_cells_under_merged_arrows_are_one_image() -> None:
    """10^5 hash cells over 160 m: each panel held 10^5 square paths (about 45 MB; a series
    of 24 panels took 1.5 GB and 20 s). Under merged arrows the squares are one image of the
    cell lattice: a cell's pixel has its entropy colour, faint; no cell, transparent."""
    from aion_cli.formats.scene_colours import entropy_colors
    from aion_cli.pictures.topdown_panel import UNDER_MERGED_ALPHA

    side = np.arange(0.25, 160.0, 0.5)
    xy = np.array([(x, y) for x in side for y in side if not (40 < x < 60 and 40 < y < 60)])
    n = len(xy)
    entropy = np.where(xy[:, 0] < 80, 0.1, 0.9)
    scene = cells_only_scene(xy, np.ones(n), np.zeros(n), entropy)
    fig = topdown_figure([scene], ["t"])
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    assert [c for c in ax.collections if type(c).__name__ == "PolyCollection"] == []
    (image,) = ax.get_images()
    rgba = np.asarray(image.get_array())
    assert rgba.shape == (320, 320, 4)
    x0, x1, y0, y1 = image.get_extent()
    assert (x0, x1, y0, y1) == (0.0, 160.0, 0.0, 160.0)
    row, col = 10, 20  # the cell at x 10.25, y 5.25 (the image's first row is y 0)
    assert image.origin == "lower"
    np.testing.assert_allclose(rgba[row, col, :3], entropy_colors(np.array([0.1]))[0])
    assert rgba[row, col, 3] == pytest.approx(UNDER_MERGED_ALPHA)
    assert rgba[100, 100, 3] == 0.0  # x, y 50.25: the hole in the middle


def _grid_graph(side: int) -> Scene:
    """``side`` x ``side`` places a metre apart, joined to their right and upper neighbours,
    no flow."""
    g = np.arange(side, dtype=np.float64)
    xyz = np.array([(x, y, 0.0) for y in g for x in g])
    k = np.arange(side * side).reshape(side, side)
    pairs = np.concatenate([np.stack([k[:, :-1].ravel(), k[:, 1:].ravel()], 1),
                            np.stack([k[:-1].ravel(), k[1:].ravel()], 1)])
    return replace(_nodes_only(xyz[:, :2], 0.0, 0.1), edges_xyz=xyz[pairs])


def test_many_place_edges_are_drawn_once_for_all_panels() -> None:
    """A graph of 10^4 places has 2·10^4 edges: every panel held them all as line paths (a
    six-panel series of a 10^5-place graph took 4.5 s and 290 MB for its edges alone). Many
    edges are rendered once per picture into the footprint image every panel shows; a few
    stay lines."""
    from aion_cli.pictures.backdrop import EDGES_AS_IMAGE

    big = _grid_graph(100)
    assert len(big.edges_xyz) > EDGES_AS_IMAGE
    fig = topdown_figure([big] * 3, ["t", "t", "t"])
    panels = [a for a in fig.axes if a.get_title() == "t"]
    for ax in panels:
        assert [c for c in ax.collections if type(c).__name__ == "LineCollection"] == []
        assert len(ax.get_images()) == 1
    images = [np.asarray(ax.get_images()[0].get_array()) for ax in panels]
    assert np.array_equal(images[0], images[2])  # one rendering, shown in every panel
    rgba = images[0]
    assert (rgba[..., 3] > 0).mean() > 0.2  # the edges cover the footprint
    small = _grid_graph(5)
    (ax,) = [a for a in topdown_figure([small], ["t"]).axes if a.get_title() == "t"]
    (lines,) = [c for c in ax.collections if type(c).__name__ == "LineCollection"]
    assert len(lines.get_segments()) == len(small.edges_xyz)


def test_a_picture_without_flow_says_it_has_no_arrows() -> None:
    """Nothing flows (or nothing flowing has a direction): no arrow is drawn, and the legend
    said "the longest: 1 detections per 600-s window", the scale of no flow; it says there
    are none. A series in which one panel flows keeps the scale of that flow."""
    still = replace(synthetic_scene(flow_a=0.0, flow_b=0.0), cells_flow=np.zeros(1))
    assert len(arrow_field(still).flow) == 0
    undirected = replace(
        synthetic_scene(), node_angle=np.full(3, np.nan), cells_angle=np.full(1, np.nan)
    )
    assert len(arrow_field(undirected).flow) == 0
    for scenes in ([still], [still, undirected]):
        fig = topdown_figure(scenes, ["t"] * len(scenes))
        text = fig._supxlabel.get_text()
        assert text.startswith("no arrows: no place or cell has flow"), text
        assert "the longest" not in text
        assert not any(ax.collections and any(
            type(c).__name__ == "Quiver" for c in ax.collections) for ax in fig.axes)
    fig = topdown_figure([still, synthetic_scene()], ["quiet", "busy"])
    assert "(the longest: 10 detections per 600-s window)" in fig._supxlabel.get_text()


def test_merged_arrows_keep_the_teal_dots_of_people_standing(tmp_path: Any) -> None:
    """A 200 m corridor of places 2 m apart, walked along +x, and a place 4 m beside it
    where people stood (flow, no heading): the picture merges its arrows into blocks and left
    out every node's dot, so the standing people were drawn nowhere while the legend still
    named teal. Their dot is drawn, teal, since no merged arrow carries their flow."""
    from aion_cli.formats.scene_colours import NO_HEADING_KEY, NO_HEADING_TEAL
    from aion_cli.pictures.render import save_png
    from tests.pictures.pixels import most_coloured, pixel_of, read_png

    xy = np.column_stack([np.arange(0.0, 200.0, 2.0), np.zeros(100)])
    standing = 50
    xy[standing] = (100.0, 4.0)
    scene = _nodes_only(xy, 0.0, 0.1)
    angle, entropy = scene.node_angle.copy(), scene.node_entropy.copy()
    angle[standing], entropy[standing] = np.nan, np.nan
    scene = replace(scene, node_angle=angle, node_entropy=entropy)
    assert arrow_block(scene_extent([scene]), SINGLE_WIDTH_IN, 0.5) is not None
    fig = topdown_figure([scene], ["t"], dpi=100)
    assert NO_HEADING_KEY in fig._supxlabel.get_text().replace("\n", " ")
    image = read_png(save_png(fig, tmp_path / "m.png"))
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    seen = most_coloured(image, *pixel_of(ax, image, 100.0, 4.0), half=1)
    np.testing.assert_allclose(seen, NO_HEADING_TEAL, atol=0.06)


def test_an_even_flow_is_drawn_as_even_arrows() -> None:
    """10^5 hash cells of 0.5 m over 160 m, each with the same flow along +x: the picture's
    arrow spacing was 3.1 m, 6.2 cells, so a block held six rows and columns of cells or
    seven, and every sixth row and column of arrows was drawn up to 49/36 as long, stripes of
    flow the map does not have. A block is a whole number of cells: every block inside the
    lattice sums the same number of cells, the square of its edge in cells."""
    cell = 0.5
    side = np.arange(cell / 2, 160.0, cell)
    xy = np.array([(x, y) for x in side for y in side])
    n = len(xy)
    scene = cells_only_scene(xy, np.ones(n), np.zeros(n), np.full(n, 0.1))
    block = arrow_block(scene_extent([scene]), SINGLE_WIDTH_IN, cell)
    assert block is not None
    field = arrow_field(scene, block)
    inside = (np.floor(field.xy / block) + 1) * block <= 160.0  # blocks the lattice fills
    full = field.flow[inside.all(axis=1)]
    assert len(full) > 100
    assert np.unique(full).tolist() == [round(block / cell) ** 2]
    np.testing.assert_allclose(field.angle, 0.0)


def _arrow_gap_px(scene: Scene) -> float:
    """The median distance (pixels, at the picture's dpi) between the tails of neighbouring
    arrows drawn in ``scene``'s picture (a block cut by the map's edge has its arrow nearer)."""
    fig = topdown_figure([scene], ["t"])
    fig.canvas.draw()
    (ax,) = [a for a in fig.axes if a.get_title() == "t"]
    (quiver,) = [c for c in ax.collections if type(c).__name__ == "Quiver"]
    tails = ax.transData.transform(np.asarray(quiver.get_offsets()))
    tails = tails[np.lexsort(tails.T[::-1])]
    return float(np.median(np.hypot(*np.diff(tails, axis=0).T)))


def test_a_corridor_along_y_merges_its_arrows_as_one_along_x() -> None:
    """A corridor of 0.5 m cells 200 m long and 1 m wide, walked along it: drawn along x its
    arrows merge into blocks a dozen pixels and more apart; drawn along y (the same corridor
    turned a quarter) the picture judged the spacing by the panel's width alone and drew one
    2 m arrow per cell, 800 of them one over the next on a line 23 m an inch long (cells
    three pixels apart), a stripe without a visible arrow. Turned, its arrows are as far
    apart as along x."""
    from aion_cli.pictures.topdown import DPI

    cell = 0.5
    along = np.arange(cell / 2, 200.0, cell)
    across = np.array([0.25, 0.75])
    xy = np.array([(a, b) for a in along for b in across])
    n = len(xy)
    wide = cells_only_scene(xy, np.ones(n), np.zeros(n), np.full(n, 0.1))
    tall = cells_only_scene(xy[:, ::-1], np.ones(n), np.full(n, math.pi / 2), np.full(n, 0.1))
    least = 0.6 * DPI / ARROWS_PER_INCH  # the arrows' spacing, less the panel's ticks and title
    assert _arrow_gap_px(wide) > least  # the premise
    assert _arrow_gap_px(tall) > least


def test_the_arrows_of_a_map_along_y_are_seen(tmp_path: Any) -> None:
    """The corridor above, turned along y, is drawn a sliver wide; its arrows' shafts were a
    fraction of that width, under a pixel, and their heads a pixel: across the corridor the
    arrows' colour was one pixel wide, a line, where along x their heads are three pixels
    wide. Their width is a fraction of the panel's long side: turned, as wide as along x."""
    from aion_cli.formats.scene_colours import entropy_colors
    from aion_cli.pictures.render import save_png
    from tests.pictures.pixels import pixel_of, read_png

    cell = 0.5
    along = np.arange(cell / 2, 200.0, cell)
    xy = np.array([(a, b) for a in along for b in (0.25, 0.75)])
    n = len(xy)
    colour = entropy_colors(np.array([0.1]))[0]
    across = []  # the widest the arrows' colour is across the corridor, in pixels
    for points, angle, axis in ((xy, 0.0, 0), (xy[:, ::-1], math.pi / 2, 1)):
        scene = cells_only_scene(points, np.ones(n), np.full(n, angle), np.full(n, 0.1))
        fig = topdown_figure([scene], ["t"])
        image = read_png(save_png(fig, tmp_path / "m.png"))
        (ax,) = [a for a in fig.axes if a.get_title() == "t"]
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        (r0, c0), (r1, c1) = pixel_of(ax, image, x0, y1), pixel_of(ax, image, x1, y0)
        arrow = np.abs(image[r0:r1, c0:c1] - colour).max(axis=2) < 0.08
        across.append(int(arrow.sum(axis=axis).max()))
    wide, tall = across
    # the premise: along x, arrowheads (a third of a 17-pixel arrow, ``arrows.HEAD_SHARE``,
    # their solid colour 3 pixels wide; 6 when the heads were four shaft widths long)
    assert wide >= 3
    assert tall >= wide / 2
