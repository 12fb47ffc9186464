"""One panel of the top-down picture (:mod:`.topdown`): :func:`draw_topdown` draws a
:class:`~aion_cli.scene.Scene`'s backdrop, cells, arrows, paths (:class:`PathLine`) and
markers (:class:`Marker`) on one matplotlib axes; :mod:`.topdown` lays the panels out on a
page and re-exports what is here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.formats.outputs import plain_text
from aion_cli.formats.scene_colours import busy_fraction, flow_colors
from aion_cli.pictures.arrows import ArrowField, arrow_field, arrow_scale, head_style, spaced
from aion_cli.pictures.backdrop import (
    Color,
    Extent,
    Footprint,
    RoomOutlines,
    _arrays,
    _draw_footprint,
    _draw_rooms,
    draw_cells,
    mesh_footprint,
    room_outlines,
)
from aion_cli.pictures.graph_ink import FULL, GraphInk
from aion_cli.pictures.view import scene_extent
from aion_cli.scene import Scene

F64 = npt.NDArray[np.float64]

ARROW_WIDTH = 0.0035
"""Arrow shaft width as a fraction of the panel width (its height for a map taller than
wide; one large panel; small multiples draw them relatively wider,
:data:`PANEL_ARROW_WIDTH`, so they stay visible)."""
PANEL_ARROW_WIDTH = 0.006
UNDER_MERGED_ALPHA = 0.35
"""The opacity of the cells' squares under arrows merged over blocks."""
UNDER_ARROW_ALPHA = 0.45
"""The opacity of a cell's square with flow, under its own arrow (one arrow per entry)."""


@dataclass(frozen=True)
class PathLine:
    """A path to draw over the map: points f64[p,3] (x-y used), its legend label, colour,
    matplotlib line style and width (points)."""

    xyz: F64
    label: str
    color: Color
    style: str = "-"
    width: float = 2.5


@dataclass(frozen=True)
class Marker:
    """A labelled point (a plan's start or goal): ``xy``, legend label, marker symbol."""

    xy: tuple[float, float]
    label: str
    symbol: str = "o"
    color: Color = (0.0, 0.0, 0.0)
    size: float = 90.0
    z: float | None = None
    """Its height (m): on a map of several levels it is drawn on its level's panels only."""


def axis_label(axis: str, frame: str | None = None) -> str:
    """A panel's axis label: ``"x (m)"``, with the frame the map's positions are in when
    known (``"x (m), frame odom"``: a map built with ``--map-frame odom`` is drawn in it,
    which the picture did not say)."""
    return f"{axis} (m)" if not frame else f"{axis} (m), frame {plain_text(frame)}"


def draw_topdown(
    ax: Any,
    scene: Scene,
    *,
    flow_scale: float | None = None,
    extent: Extent | None = None,
    paths: Sequence[PathLine] = (),
    markers: Sequence[Marker] = (),
    title: str | None = None,
    arrow_width: float = ARROW_WIDTH,
    dot_size: float = 12.0,
    label_size: float = 7.0,
    footprint: Footprint | None = None,
    rooms: RoomOutlines | None = None,
    arrows: ArrowField | None = None,
    graph: GraphInk = FULL,
    frame: str | None = None,
) -> None:
    """Draw ``scene`` top-down into the matplotlib axes ``ax`` (see the module docstring).
    ``flow_scale``: the flow drawn at full arrow length (default: :func:`arrow_scale`'s);
    ``extent``: the window shown (default: the scene's own); ``arrow_width`` (fraction of the
    panel's width, or of its height for a map taller than wide), ``dot_size`` (points²) and
    ``label_size`` (points) for small panels;
    ``footprint`` / ``rooms``: the mesh already rendered (:func:`mesh_footprint`) and the
    room outlines already computed (:func:`room_outlines`); default: made here; ``arrows``:
    the arrows to draw (:func:`.arrows.arrow_field`; default: one per entry, their length
    capped by their spacing, :func:`.arrows.spaced`); ``graph``: how
    heavily the place edges and dots are drawn (:mod:`.graph_ink`; default: in full);
    ``frame``: the frame the axes are in (:func:`axis_label`; None: not named)."""
    from matplotlib.collections import LineCollection

    from aion_cli.pictures.ticks import FittingLocator

    scale = flow_scale if flow_scale is not None and flow_scale > 0 else arrow_scale([scene]).flow
    field = arrows if arrows is not None else spaced([arrow_field(scene)])[0]
    drawn = field.lengths(scale, scene.cell_size)
    box = extent or scene_extent([scene], paths, float(drawn.max(initial=0.0)))
    if footprint is None:
        footprint = mesh_footprint(
            scene, box, round(ax.get_window_extent().width), graph, float(ax.figure.dpi)
        )
    _draw_footprint(ax, footprint)
    _draw_rooms(ax, rooms if rooms is not None else room_outlines(scene), label_size)
    if len(scene.edges_xyz) and not (footprint is not None and footprint.edges):
        ax.add_collection(
            LineCollection(
                _arrays(scene.edges_xyz[:, :, :2]),
                colors=[graph.edge_colour],
                linewidths=graph.edge_width,
                zorder=2,
            )
        )
    # the arrows stand on squares and dots of their own colours: under merged arrows the
    # cells' squares are faint and the nodes' dots left out (drawn solid, dots overlapping
    # where arrows merge, they are a carpet that hides the arrows); a cell with flow is pale
    # under its own arrow, which was lost on a square of its colour drawn almost solid
    merged = field.block is not None
    if len(scene.cells_xyz):  # pale under an arrow; without one (no flow, no heading) solid
        arrowed = (scene.cells_flow > 0) & np.isfinite(scene.cells_angle)
        rgba = np.column_stack(
            [
                flow_colors(scene.cells_flow, scene.cells_entropy),
                np.where(arrowed, UNDER_ARROW_ALPHA, 0.85),
            ]
        )
        if merged:
            rgba[:, 3] = UNDER_MERGED_ALPHA
        draw_cells(ax, scene.cells_xyz[:, :2], scene.cell_size, rgba, as_image=merged)
    if len(scene.places_xyz):
        ax.scatter(*scene.places_xyz[:, :2].T, s=graph.dot_size, c=[graph.dot_colour],
                   linewidths=0, zorder=4)
    busy = busy_fraction(scene.node_flow, scale)
    has = busy > 0
    if merged:  # only the dots of flow no merged arrow carries: no heading (teal), no arrow
        has &= ~np.isfinite(scene.node_angle)
    if has.any():
        colors = flow_colors(scene.node_flow[has], scene.node_entropy[has])
        ax.scatter(*scene.nodes_xyz[has, :2].T, s=dot_size, c=colors, linewidths=0, zorder=5)
    # arrows for nodes and unbound cells alike (a map of cells only shows its directions too),
    # merged over blocks where the picture cannot resolve one per entry (.arrows)
    arrow = drawn > 0
    if arrow.any():
        colors = flow_colors(field.flow[arrow], field.entropy[arrow])
        length = drawn[arrow]
        angle = field.angle[arrow]
        ax.quiver(
            *field.xy[arrow].T,
            length * np.cos(angle),
            length * np.sin(angle),
            color=colors,
            angles="xy",
            scale_units="xy",
            scale=1.0,
            # a fraction of the panel's long side: of a map along y, drawn a sliver wide, a
            # fraction of its width was a shaft under a pixel, arrows nobody could see
            units="width" if box.aspect <= 1.0 else "height",
            width=arrow_width,
            # the head at most a third of the arrow (.arrows), from the longest's shaft widths
            **head_style(field.full_length(scene.cell_size) / (arrow_width * box.long_side)),
            pivot="tail",
            zorder=6,
        )
    for k, p in enumerate(paths):
        xyz = np.asarray(p.xyz, dtype=np.float64).reshape(-1, 3)
        ax.plot(
            xyz[:, 0],
            xyz[:, 1],
            p.style,
            color=p.color,
            linewidth=p.width,
            label=plain_text(p.label),  # a legend label's $ is not maths
            zorder=7 + k,
            solid_capstyle="round",
        )
    for m in markers:
        ax.scatter(
            [m.xy[0]],
            [m.xy[1]],
            s=m.size,
            marker=m.symbol,
            c=[m.color],
            edgecolors="white",
            linewidths=1.0,
            label=plain_text(m.label),  # "goal R&D $5 and $10" read as maths: "5and10"
            zorder=20,
        )
    ax.set_xlim(box.x0, box.x1)
    ax.set_ylim(box.y0, box.y1)
    ax.set_aspect("equal", adjustable="box")
    # matplotlib's default keeps two x ticks at least: a map along y, drawn a third of an
    # inch wide, ran "-2.5", "0.0" and "2.5" into one another: one tick where one fits; and
    # as many as their labels fit: six-digit UTM-like labels ran together in a series' panels
    ax.xaxis.set_major_locator(FittingLocator())
    # the map's own coordinates on the ticks: matplotlib's offset notation drew a corridor at
    # x = 200 km as "0 ... 30" with "+2e5" in a corner, easily read as the map's x
    ax.ticklabel_format(axis="both", style="plain", useOffset=False)
    ax.set_xlabel(axis_label("x", frame))
    ax.set_ylabel(axis_label("y", frame))
    if title is not None:
        ax.set_title(plain_text(title), fontsize=10)

