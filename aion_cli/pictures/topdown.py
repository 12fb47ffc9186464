"""The top-down picture of a map's flows, drawn with matplotlib from a
:class:`~aion_cli.scene.Scene` (plain arrays; no pyplot state, no click).

What is drawn, back to front:

- **mesh** footprint: the scene graph's triangles projected to x-y, light grey (rendered
  once per picture as an image, :func:`mesh_footprint`, with the place edges when they are
  many);
- **rooms**: the convex hull of each room's places (padded by one cell), dashed, with the
  room's label (or id) at the centroid of its places (up to :data:`MAX_ROOM_LABELS` rooms);
- **edges**: the place edges as thin grey lines; **places** as small grey dots (lighter,
  thinner and smaller where the places are drawn a few pixels apart: :mod:`.graph_ink`);
- **cells**: an unbound hash cell as a δ×δ square coloured by its direction entropy, pale
  under its arrow (grey without flow, teal with flow but no heading: ``flow_colors``);
- **arrows**: one per node or unbound cell with flow, from its centre along its dominant
  direction, length
  ``ARROW_CELLS·δ·busy`` (at most ``REACH`` times the arrows' typical spacing, so that the
  busiest do not run across their neighbours: :meth:`.arrows.ArrowField.full_length`;
  busy = ``min(flow / flow_scale, 1)``, ``formats.scene_colours``'
  ``busy_fraction``: proportional to flow up to ``flow_scale``, drawn ``ARROW_CELLS`` cells
  long; :func:`arrow_scale` chooses it, as the 3D scenes' sizes), coloured
  by entropy with ``formats.scene_colours.entropy_colors`` (``(H, 0, 1 − H)``: blue for one
  direction, red for every direction), on a dot of the same colour;
  where the picture cannot resolve one arrow per entry, one per block instead
  (:mod:`.arrows`), over fainter cells and without the nodes' dots (but the teal ones of
  nodes with flow and no heading, which no arrow carries);
- **paths** (:class:`PathLine`) and **markers** (:class:`Marker`, e.g. start and goal) on top.

A key draws the arrow of a stated flow in a panel's emptiest corner, one per figure
(:mod:`.arrow_key`); the window's margin is as long as the longest arrow (:mod:`.view`).
A colour bar labelled "direction entropy" (its ends named: one way, every way) shows the
same blue-to-red scale (0..1). Several scenes (a series of times) become small multiples
sharing axes, flow scale and colour bar.

**Where the code is.** This module draws the flows (:func:`draw_topdown`) and lays out the
panels (:func:`topdown_figure`); the window they show (:func:`scene_extent`) lives in
:mod:`.view`; the backdrop they are drawn over -- the window's :class:`Extent`, the mesh
footprint (:class:`Footprint`, :func:`mesh_footprint`) and the room
outlines (:class:`RoomOutlines`, :func:`room_outlines`), computed once per picture -- lives in
:mod:`.backdrop`; both are re-exported here for :mod:`.plan`, :mod:`.render` and the tests; the
arrows, their scale (:class:`ArrowScale`, :func:`arrow_scale`, re-exported too) and the
legend's lines in :mod:`.arrows`; the page's rows, columns and panel sizes in :mod:`.layout`;
the levels of a multi-storey map in :mod:`.floors`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.errors import InputError
from aion_cli.formats.outputs import plain_text
from aion_cli.formats.scene_colours import (
    NO_FLOW_GREY,
    busy_fraction,
    display_flow_scale,
    flow_colors,
)
from aion_cli.pictures.arrow_key import draw_arrow_key, drawn_points
from aion_cli.pictures.arrows import (
    ARROW_CELLS,
    ArrowField,
    ArrowScale,
    arrow_block,
    arrow_field,
    arrow_scale,
    legend_lines,
    spaced,
)
from aion_cli.pictures.backdrop import (
    LABEL_GREY,
    MAX_ROOM_LABELS,
    MESH_GREY,
    ROOM_GREY,
    Color,
    Extent,
    Footprint,
    RoomOutlines,
    _arrays,
    _draw_footprint,
    _draw_rooms,
    _same_geometry,
    draw_cells,
    mesh_footprint,
    room_outlines,
)
from aion_cli.pictures.floors import by_level, levels_apart
from aion_cli.pictures.graph_ink import FULL, GraphInk, graph_ink
from aion_cli.pictures.layout import PANEL_WIDTH_IN, SINGLE_WIDTH_IN, wrapped
from aion_cli.pictures.layout import grid as page_grid
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
ENTROPY_LABEL = "direction entropy"
DPI = 120
MAX_PANELS = 24


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


def entropy_cmap() -> Any:
    """The colour map of ``entropy_colors`` for the colour bar: blue (0) to red (1) through
    ``(H, 0, 1 − H)``, grey for NaN."""
    from matplotlib.colors import LinearSegmentedColormap

    cmap = LinearSegmentedColormap.from_list("aion_entropy", [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0)])
    return cmap.with_extremes(bad=NO_FLOW_GREY)


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
            headwidth=3.5,
            headlength=4.0,
            headaxislength=3.5,
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
            label=p.label,
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
            label=m.label,
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


def topdown_figure(
    scenes: Sequence[Scene],
    titles: Sequence[str],
    *,
    suptitle: str | None = None,
    paths: Sequence[Sequence[PathLine]] | None = None,
    markers: Sequence[Marker] = (),
    dpi: float = DPI,
    flow_scale: float | None = None,
    frame: str | None = None,
) -> Any:
    """A matplotlib ``Figure`` (Agg canvas) with one panel per scene, titled by ``titles``:
    shared axes, flow scale (default: :func:`arrow_scale` of all scenes) and entropy colour bar;
    ``paths[i]`` drawn on panel ``i``, ``markers`` on every panel; the axes labelled with
    ``frame``, the map's frame, when given (:func:`axis_label`). At most
    :data:`MAX_PANELS` panels (an :class:`InputError` beyond)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    if not scenes:
        raise InputError("nothing to draw: no times given")
    per_panel: list[Sequence[PathLine]] = (
        list(paths) if paths is not None else [[] for _ in scenes]
    )
    panel_markers = [list(markers) for _ in scenes]
    found = levels_apart(scenes, MAX_PANELS)
    if len(found) > 1:  # floors apart: one panel per time and level, not drawn over each other
        if len(scenes) == 1:  # one time: its title over the page, each panel's its level's
            suptitle = "\n".join(filter(None, (suptitle, *titles)))
            titles = [""]
        scenes, titles, per_panel, panel_markers = by_level(
            scenes, titles, per_panel, markers, found
        )
    n = len(scenes)
    if n > MAX_PANELS:
        raise InputError(
            f"the picture would have {n} panels, more than {MAX_PANELS}",
            hint="use a larger --step (or a shorter --from/--to)",
        )
    every_path = [p for ps in per_panel for p in ps]
    extent = scene_extent(scenes, every_path)
    rows, cols, width, height = page_grid(n, extent.aspect, max(len(found), 1))
    block = arrow_block(extent, width, min(s.cell_size for s in scenes), height)
    fields = spaced([arrow_field(s, block) for s in scenes])  # one length cap for all
    if block is None:
        arrows = arrow_scale(scenes)
    else:  # merged arrows: the scale of the blocks' summed flows
        arrows = ArrowScale(*display_flow_scale(np.concatenate([f.flow for f in fields])))
    if flow_scale is not None and flow_scale > 0:
        arrows = ArrowScale(flow_scale, max(flow_scale, arrows.largest))
    scale = arrows.flow
    drawn = [f.lengths(scale, s.cell_size) for f, s in zip(fields, scenes, strict=True)]
    longest = max(float(d.max(initial=0.0)) for d in drawn)
    if longest > extent.pad:  # a margin as long as the longest arrow: none runs out of view
        extent = scene_extent(scenes, every_path, longest)
        rows, cols, width, height = page_grid(n, extent.aspect, max(len(found), 1))
    ink = graph_ink(scenes, extent, width, height, dpi)  # places a few pixels apart: lighter
    fig = Figure(
        figsize=(cols * width + 1.4, rows * height + (1.2 if n == 1 else 1.0)),
        dpi=dpi,
        layout="constrained",
    )
    FigureCanvasAgg(fig)
    keyed = any(len(p) for p in per_panel) or any(panel_markers)
    # a row for the legend of paths and markers over the panels: inside a panel it covered
    # the map (a corridor plan's legend hid its goal and half its paths); the figure's own
    # "outside" legends overlap its title or caption
    spec = fig.add_gridspec(rows + keyed, cols, height_ratios=[1e-3] * keyed + [1.0] * rows)
    key = fig.add_subplot(spec[0, :]) if keyed else None
    grid = spec[int(keyed) :, :].subgridspec(rows, cols).subplots(
        sharex=True, sharey=True, squeeze=False
    )
    shared: tuple[Scene, Footprint | None, RoomOutlines] | None = None
    used = []
    for i, ax in enumerate(grid.flat):
        if i >= n:
            ax.remove()
            continue
        if shared is None or not _same_geometry(shared[0], scenes[i]):
            footprint = mesh_footprint(scenes[i], extent, round(width * dpi), ink, dpi)
            shared = (scenes[i], footprint, room_outlines(scenes[i]))
        draw_topdown(
            ax,
            scenes[i],
            footprint=shared[1],
            rooms=shared[2],
            flow_scale=scale,
            extent=extent,
            paths=per_panel[i],
            markers=panel_markers[i],
            title=titles[i],
            arrow_width=ARROW_WIDTH if n == 1 else PANEL_ARROW_WIDTH,
            dot_size=12.0 if n == 1 else 5.0,
            label_size=7.0 if n == 1 else 5.5,
            arrows=fields[i],
            graph=ink,
            frame=frame,
        )
        last_in_column = i + cols >= n
        ax.xaxis.set_tick_params(labelbottom=last_in_column)
        if not last_in_column:
            ax.set_xlabel("")
        if i % cols:
            ax.set_ylabel("")
        used.append(ax)
    with_arrows = [i for i in range(len(used)) if (drawn[i] > 0).any()]
    if with_arrows:  # one key per figure, in the emptiest corner of the last with arrows
        last = with_arrows[-1]
        tails = fields[last].xy
        ends = tails + drawn[last][:, None] * np.column_stack(
            [np.cos(fields[last].angle), np.sin(fields[last].angle)]
        )
        draw_arrow_key(
            used[last],
            scale,
            fields[last].full_length(scenes[last].cell_size),
            scenes[last].window_s,
            drawn_points(scenes[last], tails, ends, per_panel[last]),
            (width, height),
        )
    # one legend for every panel's paths and markers (a goal on an upper level is drawn on
    # that level's panel only), in its row over the panels
    legend: dict[str, Any] = {}
    for ax in used:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    if key is not None:
        key.set_axis_off()
        if legend:
            key.legend(
                list(legend.values()),
                list(legend.keys()),
                loc="lower center",
                bbox_to_anchor=(0.5, 0.0),
                ncols=min(len(legend), 4),
                fontsize=7 if n > 1 else 8,
                frameon=False,
            )
    bar = fig.colorbar(
        ScalarMappable(Normalize(0.0, 1.0), entropy_cmap()),
        ax=used,
        shrink=0.9 if n == 1 else 0.6,
        aspect=30,
    )
    bar.set_label(ENTROPY_LABEL)
    # normalised, without a unit: the ends say what it means
    bar.set_ticks([0.0, 0.2, 0.4, 0.6, 0.8, 1.0])
    bar.set_ticklabels(["0 one way", "0.2", "0.4", "0.6", "0.8", "1 every way"])
    if suptitle:  # it may hold a file name: UTF-8 text whatever its bytes, its $ not maths
        fig.suptitle(plain_text(wrapped([suptitle], fig.get_figwidth(), 12)), fontsize=12)
    keys = legend_lines(arrows.legend(scenes[0].window_s), fields, scenes)
    caption = wrapped([*keys, extent.caption()], fig.get_figwidth(), 7)
    fig.supxlabel(caption, fontsize=7, color=LABEL_GREY)
    return fig


__all__ = [
    "ARROW_CELLS",
    "ARROW_WIDTH",
    "DPI",
    "ENTROPY_LABEL",
    "LABEL_GREY",
    "MAX_PANELS",
    "MAX_ROOM_LABELS",
    "MESH_GREY",
    "PANEL_ARROW_WIDTH",
    "PANEL_WIDTH_IN",
    "ROOM_GREY",
    "SINGLE_WIDTH_IN",
    "ArrowScale",
    "Color",
    "Extent",
    "Footprint",
    "Marker",
    "PathLine",
    "RoomOutlines",
    "arrow_scale",
    "axis_label",
    "draw_topdown",
    "entropy_cmap",
    "mesh_footprint",
    "room_outlines",
    "scene_extent",
    "topdown_figure",
]
