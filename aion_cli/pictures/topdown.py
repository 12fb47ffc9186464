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

A key draws the arrow of a stated flow in a panel's empty corner, or over the panels where
none is empty, one per figure (:mod:`.arrow_key`); the window's margin is as long as the
longest arrow (:mod:`.view`).
A colour bar labelled "direction entropy" (its ends named: one way, every way) shows the
same blue-to-red scale (0..1). Several scenes (a series of times) become small multiples
sharing axes, flow scale and colour bar.

**Where the code is.** :mod:`.topdown_panel` draws one panel's flows (:func:`draw_topdown`,
with :class:`PathLine` and :class:`Marker`) and this module lays out the panels
(:func:`topdown_figure`), re-exporting it; the window they show (:func:`scene_extent`) lives in
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
from typing import Any

import numpy as np

from aion_cli.errors import InputError
from aion_cli.formats.outputs import plain_text
from aion_cli.formats.scene_colours import NO_FLOW_GREY, display_flow_scale
from aion_cli.pictures.arrow_key import draw_arrow_key, key_of
from aion_cli.pictures.arrows import (
    ARROW_CELLS,
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
    _same_geometry,
    mesh_footprint,
    room_outlines,
)
from aion_cli.pictures.floors import by_level, levels_apart
from aion_cli.pictures.graph_ink import graph_ink
from aion_cli.pictures.layout import PANEL_WIDTH_IN, SINGLE_WIDTH_IN, wrapped
from aion_cli.pictures.layout import grid as page_grid
from aion_cli.pictures.room_labels import (
    ROOM_LABEL_POINTS,
    FittedLabels,
    fit_labels,
    label_note,
    map_per_inch,
)
from aion_cli.pictures.topdown_panel import (
    ARROW_WIDTH,
    PANEL_ARROW_WIDTH,
    Marker,
    PathLine,
    axis_label,
    draw_topdown,
)
from aion_cli.pictures.view import scene_extent
from aion_cli.scene import Scene

ENTROPY_LABEL = "direction entropy"
DPI = 120
MAX_PANELS = 24


def entropy_cmap() -> Any:
    """The colour map of ``entropy_colors`` for the colour bar: blue (0) to red (1) through
    ``(H, 0, 1 − H)``, grey for NaN."""
    from matplotlib.colors import LinearSegmentedColormap

    cmap = LinearSegmentedColormap.from_list("aion_entropy", [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0)])
    return cmap.with_extremes(bad=NO_FLOW_GREY)


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
    plan = key_of(scenes, fields, drawn, per_panel, scale, extent, (width, height))
    margined = plan is not None and plan.in_margin  # a row of its own for the arrows' key
    # a row for the legend of paths and markers over the panels: inside a panel it covered
    # the map (a corridor plan's legend hid its goal and half its paths); the figure's own
    # "outside" legends overlap its title or caption
    tops = keyed + margined
    spec = fig.add_gridspec(rows + tops, cols, height_ratios=[1e-3] * tops + [1.0] * rows)
    key = fig.add_subplot(spec[0, :]) if keyed else None
    margin = fig.add_subplot(spec[tops - 1, :]) if margined else None
    if margin is not None:
        margin.set_axis_off()
    grid = spec[tops:, :].subgridspec(rows, cols).subplots(
        sharex=True, sharey=True, squeeze=False
    )
    shared: tuple[Scene, Footprint | None, RoomOutlines] | None = None
    fitted: list[FittedLabels] = []  # the room labels that fit, each geometry's
    used = []
    for i, ax in enumerate(grid.flat):
        if i >= n:
            ax.remove()
            continue
        if shared is None or not _same_geometry(shared[0], scenes[i]):
            footprint = mesh_footprint(scenes[i], extent, round(width * dpi), ink, dpi)
            per_inch = map_per_inch(extent.x1 - extent.x0, extent.y1 - extent.y0, (width, height))
            fitted.append(fit_labels(room_outlines(scenes[i]), ROOM_LABEL_POINTS, per_inch))
            shared = (scenes[i], footprint, fitted[-1].rooms)
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
            label_size=ROOM_LABEL_POINTS,  # readable in a series too (.room_labels)
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
    if plan is not None:  # one key per figure (.arrow_key)
        draw_arrow_key(used[plan.panel], plan, margin)
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
    keys += [label_note(f) for f in fitted[:1]]
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
