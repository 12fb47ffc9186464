"""The scene graph under the arrows is drawn lighter where its places are drawn a few pixels
apart: a real map's derived graph (ATC, 629 places 1.5 m apart over 90 m) in a six-panel
series was a grey carpet of edges and dots that hid the arrows. A graph drawn wide apart
keeps the full ink it always had."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.formats.scene_colours import EDGE_GREY, NO_FLOW_GREY
from aion_cli.pictures.backdrop import EDGES_AS_IMAGE, mesh_footprint
from aion_cli.pictures.graph_ink import (
    FAINTEST_PX,
    FULL,
    FULL_INK_PX,
    LIGHTEST,
    graph_ink,
    ink_at,
    place_spacing,
)
from aion_cli.pictures.layout import grid
from aion_cli.pictures.topdown import DPI, scene_extent, topdown_figure
from aion_cli.scene import Scene
from tests.pictures.pixels import places_scene, read_png


def _lattice(side: int, step: float, flowing: int = 0) -> Scene:
    """``side`` x ``side`` places ``step`` metres apart, each joined to its right and upper
    neighbour, without flow but for the first ``flowing`` places of the bottom row (flow 1
    along +x, entropy 0.1); no hash cells."""
    g = np.arange(side, dtype=np.float64) * step
    xyz = np.array([(x, y, 0.0) for y in g for x in g])
    k = np.arange(side * side).reshape(side, side)
    pairs = np.concatenate([np.stack([k[:, :-1].ravel(), k[:, 1:].ravel()], 1),
                            np.stack([k[:-1].ravel(), k[1:].ravel()], 1)])
    scene = places_scene(xyz)
    flow = np.zeros(len(xyz))
    flow[:flowing] = 1.0
    return replace(
        scene,
        node_flow=flow,
        node_entropy=np.where(flow > 0, 0.1, np.nan),
        node_angle=np.where(flow > 0, 0.0, np.nan),
        edges_xyz=xyz[pairs],
        cells_xyz=np.zeros((0, 3)),
        cells_flow=np.zeros(0),
        cells_entropy=np.zeros(0),
        cells_angle=np.zeros(0),
    )


def _panels(fig: Any) -> list[Any]:
    return [a for a in fig.axes if a.get_title().startswith("t")]


def _edges(ax: Any) -> Any:
    (lines,) = [c for c in ax.collections if type(c).__name__ == "LineCollection"]
    return lines


def _place_dots(ax: Any) -> Any:
    (dots,) = [c for c in ax.collections
               if type(c).__name__ == "PathCollection" and c.get_zorder() == 4]
    return dots


def test_the_spacing_is_the_edges_length_else_the_nearest_place() -> None:
    lattice = _lattice(10, 1.5)
    assert place_spacing([lattice]) == pytest.approx(1.5)
    no_edges = replace(lattice, edges_xyz=np.zeros((0, 2, 3)))
    assert place_spacing([no_edges]) == pytest.approx(1.5)
    assert np.isnan(place_spacing([places_scene([[0.0, 0.0, 0.0]])]))
    # no spacing to judge by: drawn as always
    one = places_scene([[0.0, 0.0, 0.0]])
    assert graph_ink([one], scene_extent([one]), 8.0, 5.0, DPI) == FULL


def test_the_ink_fades_from_full_to_lightest_as_places_close_up() -> None:
    assert ink_at(FULL_INK_PX) == FULL
    assert ink_at(100.0) == FULL
    assert ink_at(FAINTEST_PX) == LIGHTEST
    assert ink_at(1.0) == LIGHTEST
    between = [ink_at(px) for px in np.linspace(FAINTEST_PX, FULL_INK_PX, 6)]
    widths = [ink.edge_width for ink in between]
    greys = [ink.edge_colour[0] for ink in between]
    dots = [ink.dot_size for ink in between]
    assert widths == sorted(widths)
    assert greys == sorted(greys, reverse=True)
    assert dots == sorted(dots)
    assert min(dots) > 0  # small, never gone: the legend's "grey: no flow" names them
    assert LIGHTEST.edge_colour[0] > EDGE_GREY[0]
    assert LIGHTEST.edge_width < FULL.edge_width


def test_a_sparse_graph_keeps_its_full_ink() -> None:
    """An office's places 2 m apart over 40 m, in one picture, are 45 pixels apart: edges
    0.6 points and grey, dots 5 points², as before."""
    office = _lattice(20, 2.0, flowing=3)
    (ax,) = _panels(topdown_figure([office], ["t"]))
    edges = _edges(ax)
    assert edges.get_linewidths()[0] == pytest.approx(0.6)
    np.testing.assert_allclose(edges.get_colors()[0][:3], EDGE_GREY)
    dots = _place_dots(ax)
    assert dots.get_sizes()[0] == pytest.approx(5.0)
    np.testing.assert_allclose(dots.get_facecolors()[0][:3], NO_FLOW_GREY)


def test_a_dense_graph_in_a_series_is_drawn_light(tmp_path: Path) -> None:
    """A mall's places 2.25 m apart over 90 m, in six panels, are about 10 pixels apart: the
    edges are thinner and lighter and the dots smaller, in every panel, and the map's area
    reads light: with the full ink a quarter of its pixels were darker than 0.75 grey (a
    carpet), now about one in sixteen; the arrows keep their colour."""
    mall = _lattice(40, 2.25, flowing=40)
    extent = scene_extent([mall] * 6)
    _, _, width, height = grid(6, extent.aspect)
    spacing_px = 2.25 * DPI / max((extent.x1 - extent.x0) / width,
                                  (extent.y1 - extent.y0) / height)
    assert FAINTEST_PX < spacing_px < FULL_INK_PX - 4  # the case in question
    fig = topdown_figure([mall] * 6, [f"t{k}" for k in range(6)])
    panels = _panels(fig)
    assert len(panels) == 6
    for ax in panels:
        assert _edges(ax).get_linewidths()[0] < FULL.edge_width - 0.1
        assert _edges(ax).get_colors()[0][0] > EDGE_GREY[0] + 0.05
        assert _place_dots(ax).get_sizes()[0] < FULL.dot_size - 1.0
    out = tmp_path / "mall.png"
    fig.savefig(out, dpi=fig.dpi, facecolor="white")
    image = read_png(out)
    ax = panels[0]
    box = ax.get_window_extent()
    # the map's area inside the panel, above its bottom row (where the arrows are)
    x0, y0 = ax.transData.transform((10.0, 10.0))
    x1, y1 = ax.transData.transform((80.0, 80.0))
    rows = slice(round(image.shape[0] - y1), round(image.shape[0] - y0))
    cols = slice(round(x0), round(x1))
    assert box.x0 <= x0 < x1 <= box.x1
    area = image[rows, cols]
    dark = float((area.max(axis=2) < 0.75).mean())
    assert dark < 0.12, dark
    # the arrows of the bottom row: saturated blue-ish pixels (entropy 0.1) are drawn
    bottom = image[round(image.shape[0] - ax.transData.transform((0.0, 1.0))[1]) - 3:
                   round(image.shape[0] - ax.transData.transform((0.0, -1.0))[1]) + 3,
                   round(box.x0):round(box.x1)]
    blue = (bottom[..., 2] - bottom[..., 0] > 0.5).sum()
    assert blue > 50


def test_many_edges_drawn_as_an_image_are_drawn_light_too() -> None:
    """A graph of more than EDGES_AS_IMAGE edges is rendered into the footprint image: that
    rendering takes the same lighter ink (it was 0.72 points of EDGE_GREY whatever the
    spacing), and the full ink at the default 120 dpi is what it was."""
    big = _lattice(60, 1.5)
    assert len(big.edges_xyz) > EDGES_AS_IMAGE
    extent = scene_extent([big])
    full = mesh_footprint(big, extent, 432, FULL, DPI)
    light = mesh_footprint(big, extent, 432, LIGHTEST, DPI)
    assert full is not None
    assert light is not None
    assert full.edges
    assert light.edges

    def ink(image: np.ndarray) -> float:  # darkness times coverage, summed
        rgba = image.astype(np.float64) / 255.0
        return float(((1.0 - rgba[..., :3].mean(axis=2)) * rgba[..., 3]).sum())

    assert ink(light.image) < 0.6 * ink(full.image)
    # the six-panel series of this graph uses the light ink in its footprint
    fig = topdown_figure([big] * 6, [f"t{k}" for k in range(6)])
    (shown,) = _panels(fig)[0].get_images()
    assert ink(np.asarray(shown.get_array())) < ink(full.image)
