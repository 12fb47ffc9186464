"""How heavily a top-down picture draws the scene graph under the arrows: the place edges'
width and grey, and the places' dots, from how far apart the places are drawn.

A graph drawn with its places a few pixels apart is a grey carpet: ATC's derived graph (629
places 1.5 m apart over 90 m) in a six-panel series put them 6.7 pixels apart, each with
eight edges 0.6 points wide and a dot 3.7 pixels across, and the arrows (merged over 4 m
blocks, dark red and purple) could not be told from the carpet they stood on. The graph is
the backdrop, the arrows are the picture: where the places are drawn less than
:data:`FULL_INK_PX` pixels apart, the edges get thinner and lighter and the dots smaller,
down to :data:`LIGHTEST` at :data:`FAINTEST_PX` or closer. A graph drawn wide apart (the
office, one picture or a day of 24 panels) is drawn as before. The dots are made small, never
left out: the legend's "grey: no flow" names them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.formats.scene_colours import EDGE_GREY, NO_FLOW_GREY
from aion_cli.pictures.backdrop import Color, Extent, median_nearest
from aion_cli.scene import Scene

F64 = npt.NDArray[np.float64]


@dataclass(frozen=True)
class GraphInk:
    """The place edges' ``edge_width`` (points) and ``edge_colour``, the places' dots'
    ``dot_size`` (points²) and ``dot_colour``."""

    edge_width: float
    edge_colour: Color
    dot_size: float
    dot_colour: Color


FULL = GraphInk(0.6, EDGE_GREY, 5.0, NO_FLOW_GREY)
"""The graph of places drawn far enough apart to be seen one by one."""
LIGHTEST = GraphInk(0.3, (0.8, 0.8, 0.8), 1.0, (0.62, 0.62, 0.62))
"""The graph of places drawn :data:`FAINTEST_PX` apart or closer."""
FULL_INK_PX = 18.0
"""Places drawn at least this many pixels apart get :data:`FULL` ink."""
FAINTEST_PX = 6.0
"""Places drawn this close or closer get :data:`LIGHTEST` ink (linear in between)."""


def place_spacing(scenes: Sequence[Scene]) -> float:
    """The typical distance (m, in x-y) between neighbouring places of ``scenes``: the median
    length of the place edges of the first scene that has any, else the median distance from
    each place to its nearest one; NaN with fewer than two places."""
    for scene in scenes:
        edges = np.asarray(scene.edges_xyz, dtype=np.float64)
        if len(edges):
            lengths = np.linalg.norm(edges[:, 1, :2] - edges[:, 0, :2], axis=1)
            lengths = lengths[np.isfinite(lengths) & (lengths > 0)]
            if lengths.size:
                return float(np.median(lengths))
    for scene in scenes:
        xy = np.asarray(scene.places_xyz, dtype=np.float64)[:, :2]
        xy = np.unique(xy[np.isfinite(xy).all(axis=1)], axis=0)
        if len(xy) >= 2:
            return median_nearest(xy)
    return float("nan")


def graph_ink(
    scenes: Sequence[Scene], extent: Extent, panel_width_in: float, panel_height_in: float,
    dpi: float,
) -> GraphInk:
    """The ink of the graph of ``scenes`` drawn over ``extent`` in panels ``panel_width_in``
    by ``panel_height_in`` inches at ``dpi``: x and y on one scale, the one that fits the
    window in the panel (as :func:`.arrows.arrow_block` measures it)."""
    spacing = place_spacing(scenes)
    if not np.isfinite(spacing):
        return FULL
    per_inch = max(
        (extent.x1 - extent.x0) / panel_width_in, (extent.y1 - extent.y0) / panel_height_in
    )
    return ink_at(spacing / per_inch * dpi)


def ink_at(spacing_px: float) -> GraphInk:
    """The ink of a graph whose places are drawn ``spacing_px`` pixels apart."""
    t = float(np.clip((spacing_px - FAINTEST_PX) / (FULL_INK_PX - FAINTEST_PX), 0.0, 1.0))

    def mix(a: float, b: float) -> float:
        return a + (b - a) * t

    def mix3(a: Color, b: Color) -> Color:
        return (mix(a[0], b[0]), mix(a[1], b[1]), mix(a[2], b[2]))

    return GraphInk(
        mix(LIGHTEST.edge_width, FULL.edge_width),
        mix3(LIGHTEST.edge_colour, FULL.edge_colour),
        mix(LIGHTEST.dot_size, FULL.dot_size),
        mix3(LIGHTEST.dot_colour, FULL.dot_colour),
    )
