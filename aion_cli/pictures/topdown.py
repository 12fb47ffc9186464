"""The top-down picture of a map's flows, drawn with matplotlib from a
:class:`~aion_cli.scene.Scene` (plain arrays; no pyplot state, no click).

What is drawn, back to front:

- **mesh** footprint: the scene graph's triangles projected to x-y, light grey (rendered
  once per picture as an image, :func:`mesh_footprint`);
- **rooms**: the convex hull of each room's places (padded by one cell), dashed, with the
  room's label (or id) at the centroid of its places (up to :data:`MAX_ROOM_LABELS` rooms);
- **edges**: the place edges as thin grey lines; **places** as small grey dots;
- **cells**: an unbound hash cell as a δ×δ square coloured by its direction entropy (grey
  without flow);
- **arrows**: one per node or unbound cell with flow, from its centre along its dominant
  direction, length
  ``ARROW_CELLS·δ·busy`` (busy = ``min(flow / flow_scale, 1)``, ``formats.export``'s
  ``busy_fraction``: proportional to flow, the busiest ``ARROW_CELLS`` cells long), coloured
  by entropy with ``formats.export.entropy_colors`` (``(H, 0, 1 − H)``: blue for one
  direction, red for every direction), on a dot of the same colour;
- **paths** (:class:`PathLine`) and **markers** (:class:`Marker`, e.g. start and goal) on top.

A colour bar labelled "direction entropy" shows the same blue-to-red scale (0..1). Several
scenes (a series of times) become small multiples sharing axes, flow scale and colour bar.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.errors import InputError
from aion_cli.formats.export import EDGE_GREY, NO_FLOW_GREY, busy_fraction, entropy_colors
from aion_cli.scene import Scene

F64 = npt.NDArray[np.float64]
Color = tuple[float, float, float]

ARROW_CELLS = 4.0
"""The arrow of the busiest flow is this many hash cells long."""
ARROW_WIDTH = 0.0035
"""Arrow shaft width as a fraction of the panel width (one large panel; small multiples
draw them relatively wider, :data:`PANEL_ARROW_WIDTH`, so they stay visible)."""
PANEL_ARROW_WIDTH = 0.006
MESH_GREY: Color = (0.9, 0.9, 0.9)
ROOM_GREY: Color = (0.45, 0.45, 0.45)
LABEL_GREY: Color = (0.3, 0.3, 0.3)
MAX_ROOM_LABELS = 60
"""Rooms are labelled up to this many (outlined always)."""
ENTROPY_LABEL = "direction entropy"
DPI = 120
MAX_PANELS = 24
SINGLE_WIDTH_IN = 8.0
PANEL_WIDTH_IN = 3.6


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


@dataclass(frozen=True)
class Extent:
    """The x-y window a picture shows (m)."""

    x0: float
    x1: float
    y0: float
    y1: float

    @property
    def aspect(self) -> float:
        """Height over width."""
        return (self.y1 - self.y0) / (self.x1 - self.x0)


def entropy_cmap() -> Any:
    """The colour map of ``entropy_colors`` for the colour bar: blue (0) to red (1) through
    ``(H, 0, 1 − H)``, grey for NaN."""
    from matplotlib.colors import LinearSegmentedColormap

    cmap = LinearSegmentedColormap.from_list("aion_entropy", [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0)])
    return cmap.with_extremes(bad=NO_FLOW_GREY)


def scene_extent(scenes: Sequence[Scene], paths: Sequence[PathLine] = ()) -> Extent:
    """The window holding every place, node, cell, mesh vertex and path of ``scenes``, with a
    margin for the arrows (at least 1 m each way)."""
    points: list[F64] = []
    margin = 0.0
    for s in scenes:
        half = s.cell_size / 2.0
        points += [s.places_xyz[:, :2], s.nodes_xyz[:, :2]]
        points += [s.cells_xyz[:, :2] - half, s.cells_xyz[:, :2] + half]
        if s.mesh is not None:
            points.append(np.asarray(s.mesh.vertices, dtype=np.float64).reshape(-1, 3)[:, :2])
        margin = max(margin, ARROW_CELLS * s.cell_size)
    points += [np.asarray(p.xyz, dtype=np.float64).reshape(-1, 3)[:, :2] for p in paths]
    xy = np.concatenate([p for p in points if len(p)] or [np.zeros((1, 2))])
    xy = xy[np.isfinite(xy).all(axis=1)]
    if len(xy) == 0:
        xy = np.zeros((1, 2))
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = max(margin, 0.04 * float((hi - lo).max()))
    centre = (lo + hi) / 2.0
    half_span = np.maximum((hi - lo) / 2.0 + pad, 1.0)
    return Extent(
        float(centre[0] - half_span[0]),
        float(centre[0] + half_span[0]),
        float(centre[1] - half_span[1]),
        float(centre[1] + half_span[1]),
    )


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
) -> None:
    """Draw ``scene`` top-down into the matplotlib axes ``ax`` (see the module docstring).
    ``flow_scale``: the flow drawn at full arrow length (default: the scene's largest);
    ``extent``: the window shown (default: the scene's own); ``arrow_width`` (fraction of the
    panel width), ``dot_size`` (points²) and ``label_size`` (points) for small panels;
    ``footprint`` / ``rooms``: the mesh already rendered (:func:`mesh_footprint`) and the
    room outlines already computed (:func:`room_outlines`); default: made here."""
    from matplotlib.collections import LineCollection, PolyCollection

    scale = flow_scale if flow_scale is not None and flow_scale > 0 else scene.max_flow
    scale = scale if scale > 0 else 1.0
    box = extent or scene_extent([scene], paths)
    if footprint is None:
        footprint = mesh_footprint(scene, box, round(ax.get_window_extent().width))
    _draw_footprint(ax, footprint)
    _draw_rooms(ax, rooms if rooms is not None else room_outlines(scene), label_size)
    if len(scene.edges_xyz):
        ax.add_collection(
            LineCollection(
                _arrays(scene.edges_xyz[:, :, :2]), colors=[EDGE_GREY], linewidths=0.6, zorder=2
            )
        )
    if len(scene.cells_xyz):
        half = scene.cell_size / 2.0
        square = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
        squares = scene.cells_xyz[:, None, :2] + square[None]
        ent = np.where(scene.cells_flow > 0, scene.cells_entropy, np.nan)
        ax.add_collection(
            PolyCollection(
                _arrays(squares),
                facecolors=entropy_colors(ent),
                edgecolors="none",
                alpha=0.85,
                zorder=3,
            )
        )
    if len(scene.places_xyz):
        ax.scatter(*scene.places_xyz[:, :2].T, s=5, c=[NO_FLOW_GREY], linewidths=0, zorder=4)
    busy = busy_fraction(scene.node_flow, scale)
    has = busy > 0
    if has.any():
        colors = entropy_colors(scene.node_entropy[has])
        ax.scatter(*scene.nodes_xyz[has, :2].T, s=dot_size, c=colors, linewidths=0, zorder=5)
    # arrows for nodes and unbound cells alike (a map of cells only shows its directions too)
    xy = np.concatenate([scene.nodes_xyz[:, :2], scene.cells_xyz[:, :2]])
    busy = busy_fraction(np.concatenate([scene.node_flow, scene.cells_flow]), scale)
    angle = np.concatenate([scene.node_angle, scene.cells_angle])
    arrow = (busy > 0) & np.isfinite(angle)
    if arrow.any():
        colors = entropy_colors(np.concatenate([scene.node_entropy, scene.cells_entropy])[arrow])
        length = ARROW_CELLS * scene.cell_size * busy[arrow]
        ax.quiver(
            *xy[arrow].T,
            length * np.cos(angle[arrow]),
            length * np.sin(angle[arrow]),
            color=colors,
            angles="xy",
            scale_units="xy",
            scale=1.0,
            units="width",
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
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if title is not None:
        ax.set_title(title, fontsize=10)


def _arrays(polygons: F64) -> Any:
    """Polygons f64[n,k,2] as handed to a matplotlib collection: the 3-d array itself, which
    matplotlib turns into paths on its fast path (typed as a sequence, hence ``Any``)."""
    return polygons


@dataclass(frozen=True)
class Footprint:
    """A mesh's footprint rendered once as an RGBA image covering ``extent`` (transparent
    where there is no triangle), drawn into every panel with ``imshow``: a mesh of 10^5..10^6
    triangles costs one rendering per picture, not one per panel."""

    image: npt.NDArray[np.uint8]
    extent: Extent


def mesh_footprint(scene: Scene, extent: Extent, pixels: int) -> Footprint | None:
    """The footprint of ``scene``'s mesh (triangles projected to x-y, :data:`MESH_GREY`) over
    ``extent``, ``pixels`` wide; None without a mesh."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure

    mesh = scene.mesh
    if mesh is None or len(mesh.faces) == 0:
        return None
    v = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)[:, :2]
    f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    f = f[((f >= 0) & (f < len(v))).all(axis=1)]
    width = max(int(pixels), 16)
    height = max(round(width * extent.aspect), 16)
    fig = Figure(figsize=(width / 100.0, height / 100.0), dpi=100)
    canvas = FigureCanvasAgg(fig)
    fig.patch.set_alpha(0.0)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.set_axis_off()
    ax.add_collection(
        PolyCollection(_arrays(v[f]), facecolors=[MESH_GREY], edgecolors="none", antialiased=False)
    )
    ax.set_xlim(extent.x0, extent.x1)
    ax.set_ylim(extent.y0, extent.y1)
    canvas.draw()
    return Footprint(np.asarray(canvas.buffer_rgba()).copy(), extent)


def _draw_footprint(ax: Any, footprint: Footprint | None) -> None:
    if footprint is None:
        return
    box = footprint.extent
    ax.imshow(
        footprint.image,
        extent=(box.x0, box.x1, box.y0, box.y1),
        origin="upper",
        interpolation="nearest",
        zorder=0,
    )


@dataclass(frozen=True)
class RoomOutlines:
    """Each room's outline (the convex hull of its places, padded by one cell; rooms with
    fewer than three places off one line have none) and its label at the centroid of its
    places; computed once per picture (the panels of a series share the map's rooms)."""

    hulls: tuple[F64, ...]
    label_xy: F64
    labels: tuple[str, ...]


def room_outlines(scene: Scene) -> RoomOutlines:
    """The :class:`RoomOutlines` of ``scene``; labels only up to :data:`MAX_ROOM_LABELS`
    rooms (more could not be read)."""
    from aion_cli.engine.node_ids import node_label

    n_rooms = len(scene.room_ids)
    room = scene.place_room
    order = np.argsort(room, kind="stable")
    bounds = np.searchsorted(room[order], np.arange(n_rooms + 1))
    hulls: list[F64] = []
    label_xy: list[F64] = []
    labels: list[str] = []
    for r in range(n_rooms):  # one hull per room: rooms are few
        xy = scene.places_xyz[order[bounds[r] : bounds[r + 1]], :2]
        hull = _padded_hull(xy, scene.cell_size)
        if hull is not None:
            hulls.append(hull)
        centre = xy.mean(axis=0) if len(xy) else scene.room_xyz[r, :2]
        if n_rooms <= MAX_ROOM_LABELS and np.isfinite(centre).all():
            name = scene.room_labels[r] if r < len(scene.room_labels) else ""
            label_xy.append(centre)
            labels.append(name or node_label(int(scene.room_ids[r])))
    xy_all = np.asarray(label_xy, dtype=np.float64).reshape(-1, 2)
    return RoomOutlines(tuple(hulls), xy_all, tuple(labels))


def _draw_rooms(ax: Any, rooms: RoomOutlines, label_size: float) -> None:
    import matplotlib.patheffects as effects
    from matplotlib.collections import PolyCollection

    if rooms.hulls:
        ax.add_collection(
            PolyCollection(
                list(rooms.hulls),
                facecolors="none",
                edgecolors=[ROOM_GREY],
                linestyles="--",
                linewidths=0.8,
                zorder=1,
            )
        )
    halo = [effects.withStroke(linewidth=2.5, foreground="white")]
    for (x, y), label in zip(rooms.label_xy.tolist(), rooms.labels, strict=True):
        ax.text(
            x,
            y,
            label,
            fontsize=label_size,
            color=LABEL_GREY,
            ha="center",
            va="center",
            zorder=15,
            path_effects=halo,
        )


def _padded_hull(xy: F64, pad: float) -> F64 | None:
    """The convex hull of ``xy`` pushed out by ``pad`` from its centroid; None for fewer than
    three points not on one line."""
    from scipy.spatial import ConvexHull, QhullError

    xy = np.unique(xy[np.isfinite(xy).all(axis=1)], axis=0)
    if len(xy) < 3:
        return None
    try:
        corners = xy[ConvexHull(xy).vertices]
    except QhullError:  # all on one line
        return None
    out = corners - corners.mean(axis=0)
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    return np.asarray(corners + out / np.maximum(norm, 1e-12) * pad)


def _same_geometry(a: Scene, b: Scene) -> bool:
    """Whether two scenes have the same mesh, places and rooms (the times of one map)."""
    same_mesh = a.mesh is b.mesh or (
        a.mesh is not None
        and b.mesh is not None
        and np.array_equal(a.mesh.vertices, b.mesh.vertices)
        and np.array_equal(a.mesh.faces, b.mesh.faces)
    )
    return (
        same_mesh
        and a.cell_size == b.cell_size
        and a.room_labels == b.room_labels
        and np.array_equal(a.room_ids, b.room_ids)
        and np.array_equal(a.place_room, b.place_room)
        and np.array_equal(a.places_xyz, b.places_xyz)
        and np.array_equal(a.room_xyz, b.room_xyz, equal_nan=True)
    )


def _grid(n: int, aspect: float) -> tuple[int, int, float, float]:
    """Rows, columns and panel size (inches) for ``n`` panels of height/width ``aspect``: one
    wide panel, or the column count that makes the page closest to 3:2 landscape."""
    if n == 1:
        return 1, 1, SINGLE_WIDTH_IN, float(np.clip(SINGLE_WIDTH_IN * aspect, 2.5, 9.0))
    height = float(np.clip(PANEL_WIDTH_IN * aspect, 1.4, 5.0))

    def badness(cols: int) -> float:
        rows = math.ceil(n / cols)
        return abs(math.log(cols * PANEL_WIDTH_IN / (rows * height) / 1.5))

    cols = min(range(1, min(n, 6) + 1), key=badness)
    return math.ceil(n / cols), cols, PANEL_WIDTH_IN, height


def topdown_figure(
    scenes: Sequence[Scene],
    titles: Sequence[str],
    *,
    suptitle: str | None = None,
    paths: Sequence[Sequence[PathLine]] | None = None,
    markers: Sequence[Marker] = (),
    dpi: float = DPI,
    flow_scale: float | None = None,
) -> Any:
    """A matplotlib ``Figure`` (Agg canvas) with one panel per scene, titled by ``titles``:
    shared axes, flow scale (default: the largest flow of all scenes) and entropy colour bar;
    ``paths[i]`` drawn on panel ``i``, ``markers`` on every panel. At most
    :data:`MAX_PANELS` panels (an :class:`InputError` beyond)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    n = len(scenes)
    if n == 0:
        raise InputError("nothing to draw: no times given")
    if n > MAX_PANELS:
        raise InputError(
            f"the picture would have {n} panels, more than {MAX_PANELS}",
            hint="use a larger --step (or a shorter --from/--to)",
        )
    per_panel = list(paths) if paths is not None else [[] for _ in scenes]
    extent = scene_extent(scenes, [p for ps in per_panel for p in ps])
    scale = flow_scale if flow_scale is not None else max(s.max_flow for s in scenes)
    scale = scale if scale > 0 else 1.0
    rows, cols, width, height = _grid(n, extent.aspect)
    fig = Figure(
        figsize=(cols * width + 1.4, rows * height + (1.2 if n == 1 else 1.0)),
        dpi=dpi,
        layout="constrained",
    )
    FigureCanvasAgg(fig)
    grid = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False)
    shared: tuple[Scene, Footprint | None, RoomOutlines] | None = None
    used = []
    for i, ax in enumerate(grid.flat):
        if i >= n:
            ax.remove()
            continue
        if shared is None or not _same_geometry(shared[0], scenes[i]):
            footprint = mesh_footprint(scenes[i], extent, round(width * dpi))
            shared = (scenes[i], footprint, room_outlines(scenes[i]))
        draw_topdown(
            ax,
            scenes[i],
            footprint=shared[1],
            rooms=shared[2],
            flow_scale=scale,
            extent=extent,
            paths=per_panel[i],
            markers=markers,
            title=titles[i],
            arrow_width=ARROW_WIDTH if n == 1 else PANEL_ARROW_WIDTH,
            dot_size=12.0 if n == 1 else 5.0,
            label_size=7.0 if n == 1 else 5.5,
        )
        last_in_column = i + cols >= n
        ax.xaxis.set_tick_params(labelbottom=last_in_column)
        if not last_in_column:
            ax.set_xlabel("")
        if i % cols:
            ax.set_ylabel("")
        used.append(ax)
    if any(ax.get_legend_handles_labels()[1] for ax in used[:1]):
        used[0].legend(loc="upper right", fontsize=7 if n > 1 else 8, framealpha=0.9)
    bar = fig.colorbar(
        ScalarMappable(Normalize(0.0, 1.0), entropy_cmap()),
        ax=used,
        shrink=0.9 if n == 1 else 0.6,
        aspect=30,
    )
    bar.set_label(ENTROPY_LABEL)
    if suptitle:
        fig.suptitle(suptitle, fontsize=12)
    window = scenes[0].window_s
    fig.supxlabel(
        f"arrows: dominant direction, length proportional to flow (the longest: {scale:.3g} "
        f"detections per {window:g}-s window); grey: no flow",
        fontsize=7,
        color=LABEL_GREY,
    )
    return fig
