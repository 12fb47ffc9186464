"""The backdrop of the top-down picture: what lies under the flows and stays the same across
the panels of a series -- the mesh footprint (:class:`Footprint`, :func:`mesh_footprint`) and
the room outlines with their labels (:class:`RoomOutlines`, :func:`room_outlines`) -- plus the
x-y window they cover (:class:`Extent`).

It is separate from :mod:`.topdown` (which draws the flows and lays out the panels) because it
is computed once per picture and shared by every panel whose scene has the same geometry
(:func:`_same_geometry`): a mesh of 10^5..10^6 triangles is rendered once, not once per panel.
matplotlib and scipy are imported inside the functions, as everywhere in :mod:`aion_cli.pictures`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aion_cli.scene import Scene

if TYPE_CHECKING:
    from aion_cli.pictures.graph_ink import GraphInk

F64 = npt.NDArray[np.float64]
Color = tuple[float, float, float]

MESH_GREY: Color = (0.9, 0.9, 0.9)
ROOM_GREY: Color = (0.45, 0.45, 0.45)
LABEL_GREY: Color = (0.3, 0.3, 0.3)
MAX_ROOM_LABELS = 60
"""Rooms are labelled up to this many (outlined always)."""
OUTLIER_SHARE = 0.0025
"""A picture may leave out groups of hash cells apart from the rest that each hold at most
this share of all the flow, nodes' included (a few stray detections far from where people
walk)..."""
OUTLIER_TOTAL = 0.01
"""...at most this share of the flow in all..."""
OUTLIER_SPAN = 1.5
"""...and only where the cells' whole span is more than this many times the span of the cells
kept, on x or y: a map with nothing far out is shown whole."""
LINK_CELLS = 4
"""Cells within about this many cells of each other (and at least :data:`LINK_M`) form one
group: a corridor's sparse tail stays with the corridor."""
LINK_M = 2.0


@dataclass(frozen=True)
class Extent:
    """The x-y window a picture shows (m), and the hash cells it leaves out (outliers,
    :func:`outlying_cells`): how many, and their share of all the flow."""

    x0: float
    x1: float
    y0: float
    y1: float
    left_out: int = 0
    left_out_share: float = 0.0
    pad: float = 0.0
    """The margin (m) it leaves around what it shows (:func:`.view.scene_extent`)."""

    @property
    def aspect(self) -> float:
        """Height over width."""
        return (self.y1 - self.y0) / (self.x1 - self.x0)

    @property
    def long_side(self) -> float:
        """The longer of its width and height (m)."""
        return max(self.x1 - self.x0, self.y1 - self.y0)

    def caption(self) -> str:
        """What the window leaves out, for the picture's legend ("" when nothing)."""
        if not self.left_out:
            return ""
        cells = f"{self.left_out:,} outlying hash cell{'s' if self.left_out > 1 else ''}"
        return (
            f"{cells} ({100.0 * self.left_out_share:.2g} % of the flow) "
            f"{'lie' if self.left_out > 1 else 'lies'} outside the view"
        )


def outlying_cells(
    xy: F64,
    weight: F64,
    cell_size: float,
    anchors: F64 | None = None,
    anchor_weight: F64 | None = None,
) -> npt.NDArray[np.bool_]:
    """Which of the hash cells at ``xy`` f64[n,2] (centres) a picture leaves out: the groups
    of cells apart from everything else that hold little of the flow.

    ``weight`` is each cell's flow; ``anchors`` f64[a,2] are the points a picture always
    shows (places, nodes, mesh, paths), ``anchor_weight`` their flow (a node's; 0 for the
    rest). NaN and negative flow count as 0; with no flow anywhere every cell weighs alike.
    Cells and anchors are grouped by touching squares of side
    ``max(LINK_CELLS·cell_size, LINK_M)`` (8-neighbours; the squares' coordinates are
    compressed, so a cell kilometres away costs nothing). The smallest groups without an
    anchor, each with at most :data:`OUTLIER_SHARE` of all the flow, are left out while they
    hold at most :data:`OUTLIER_TOTAL` together, and only where what is kept spans less than
    ``1 / OUTLIER_SPAN`` of all on x or y: one stray detection 100 m from a 20 m corridor
    would otherwise shrink the corridor to a few pixels, while a corridor's thin arms, which
    touch it, stay, and so does a cell beside a place."""
    n = len(xy)
    none = np.zeros(n, bool)
    fixed = np.zeros((0, 2)) if anchors is None else np.asarray(anchors, dtype=np.float64)
    fixed = fixed.reshape(-1, 2)
    fixed_w = np.zeros(len(fixed)) if anchor_weight is None else anchor_weight
    side = max(LINK_CELLS * cell_size, LINK_M)
    if len(fixed) > n and np.isfinite(fixed).all():
        # a mesh's 10^6 vertices mark a few thousand squares: one anchor per square
        fixed, fixed_w = _per_square(fixed, np.asarray(fixed_w, dtype=np.float64), side)
    points = np.concatenate([xy, fixed])
    w = np.concatenate([weight, fixed_w])
    w = np.where(np.isfinite(w) & (w > 0), w, 0.0)
    finite = np.isfinite(points).all(axis=1)
    if n == 0 or len(points) < 2 or not finite.all():
        return none
    if not w.sum() > 0:
        w = np.r_[np.ones(n), np.zeros(len(fixed))]
    groups, label = _touching_groups(points, side)
    if groups < 2:
        return none
    share = np.bincount(label, weights=w, minlength=groups) / float(w.sum())
    anchored = np.zeros(groups, bool)
    anchored[label[n:]] = True
    order = np.argsort(share, kind="stable")
    order = order[~anchored[order]]
    small = share[order] <= OUTLIER_SHARE
    running = np.cumsum(share[order])
    out_groups = order[small & (running <= OUTLIER_TOTAL)]
    if out_groups.size == 0:
        return none
    out_points = np.isin(label, out_groups)
    if out_points.all():
        return none
    kept = points[~out_points]
    whole = points.max(axis=0) - points.min(axis=0)
    if not np.any(whole > OUTLIER_SPAN * (kept.max(axis=0) - kept.min(axis=0))):
        return none
    out: npt.NDArray[np.bool_] = out_points[:n]
    return out


def median_nearest(points: F64) -> float:
    """The median distance (m) from each of ``points`` f64[n,2] (distinct, at least two) to
    the nearest other: how far apart a picture's places or arrows typically are."""
    from scipy.spatial import cKDTree

    distance, _ = cKDTree(points).query(points, k=2)
    return float(np.median(distance[:, 1]))


def squares_of(points: F64, side: float) -> tuple[F64, npt.NDArray[np.int64]]:
    """The occupied squares of ``side`` metres (a grid anchored at the origin) among
    ``points`` f64[n,2]: their indices f64[m,2] (sorted by x, then y) and each point's square
    (found by sorting ``x + iy`` square indices as complex numbers, several times faster than
    ``np.unique(axis=0)``)."""
    square = np.floor(points / side)
    key, of = np.unique(square[:, 0] + 1j * square[:, 1], return_inverse=True)
    return np.column_stack([key.real, key.imag]), np.asarray(of, np.int64).reshape(-1)


def _per_square(points: F64, weight: F64, side: float) -> tuple[F64, F64]:
    """One point per occupied square of ``side`` metres (its centre) with the summed
    ``weight`` of the points in it."""
    key, of = squares_of(points, side)
    summed: F64 = np.bincount(of, weight, minlength=len(key)).astype(np.float64)
    centres: F64 = (key + 0.5) * side
    return centres, summed


def _touching_groups(points: F64, side: float) -> tuple[int, npt.NDArray[np.int64]]:
    """Connected groups of ``points`` whose squares of ``side`` metres touch (8-neighbours):
    the number of groups and each point's group. Each axis's square indices are compressed
    (a gap of two or more squares becomes two), which keeps which squares touch and bounds
    the keys whatever the coordinates."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    compressed = []
    for axis in range(2):
        values, inverse = np.unique(np.floor(points[:, axis] / side), return_inverse=True)
        step = np.where(np.diff(values) == 1.0, 1, 2)
        compressed.append(np.r_[0, np.cumsum(step)][inverse.reshape(-1)])
    square = compressed[0] + 1j * compressed[1]  # sorted as (x, y) pairs
    keys, of_point = np.unique(square, return_inverse=True)
    of_point = of_point.reshape(-1)
    m = len(keys)
    kx, ky = keys.real.astype(np.int64), keys.imag.astype(np.int64)
    width = int(ky.max()) + 3
    flat = (kx + 1) * width + ky + 1  # sorted, as keys are
    rows, cols = [], []
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            if dx == dy == 0:
                continue
            target = flat + dx * width + dy
            pos = np.minimum(np.searchsorted(flat, target), m - 1)
            hit = flat[pos] == target
            rows.append(np.flatnonzero(hit))
            cols.append(pos[hit])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(r.size), (r, c)), shape=(m, m))
    groups, label = connected_components(graph, directed=False)
    return int(groups), np.asarray(label, dtype=np.int64)[of_point]


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
    edges: bool = False
    """Whether the place edges are in the image too (a graph of many edges)."""


EDGES_AS_IMAGE = 5000
"""A graph of more place edges than this has them rendered into the footprint image, once
per picture: as line paths in every panel, 10^5 edges cost seconds and tens of MB each."""


def mesh_footprint(
    scene: Scene,
    extent: Extent,
    pixels: int,
    ink: GraphInk | None = None,
    dpi: float = 100.0,
) -> Footprint | None:
    """The footprint of ``scene``'s mesh (triangles projected to x-y, :data:`MESH_GREY`) over
    ``extent``, ``pixels`` wide, with its place edges when they are more than
    :data:`EDGES_AS_IMAGE`, drawn with ``ink`` (:mod:`.graph_ink`; default: in full, grey
    lines about a pixel wide) as a panel at ``dpi`` would draw them; None with neither."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.figure import Figure

    from aion_cli.pictures.graph_ink import FULL

    ink = ink or FULL
    mesh = scene.mesh
    edges = len(scene.edges_xyz) > EDGES_AS_IMAGE
    faces = mesh is not None and len(mesh.faces) > 0
    if not (faces or edges):
        return None
    width = max(int(pixels), 16)
    height = max(round(width * extent.aspect), 16)
    fig = Figure(figsize=(width / 100.0, height / 100.0), dpi=100)
    canvas = FigureCanvasAgg(fig)
    fig.patch.set_alpha(0.0)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.set_axis_off()
    if mesh is not None and faces:
        v = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)[:, :2]
        f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
        f = f[((f >= 0) & (f < len(v))).all(axis=1)]
        ax.add_collection(
            PolyCollection(
                _arrays(v[f]), facecolors=[MESH_GREY], edgecolors="none", antialiased=False
            )
        )
    if edges:
        ax.add_collection(
            LineCollection(
                _arrays(scene.edges_xyz[:, :, :2]),
                colors=[ink.edge_colour],
                # points of this 100-dpi canvas: as wide in pixels as a panel's lines
                linewidths=ink.edge_width * dpi / 100.0,
            )
        )
    ax.set_xlim(extent.x0, extent.x1)
    ax.set_ylim(extent.y0, extent.y1)
    canvas.draw()
    return Footprint(np.asarray(canvas.buffer_rgba()).copy(), extent, edges)


MAX_CELL_IMAGE = 16_000_000
"""The most pixels (lattice cells) an image of the hash cells may have; a sparser spread of
cells is drawn as squares."""


def draw_cells(ax: Any, xy: F64, cell_size: float, rgba: F64, as_image: bool) -> None:
    """The hash cells centred at ``xy`` f64[n,2] as squares of ``cell_size`` in colours
    ``rgba`` f64[n,4]: with ``as_image``, one image of the cell lattice (a cell a pixel,
    transparent where there is none), as light to draw as the squares are many (10^5 square
    paths are 45 MB a panel); otherwise one square each (or when the lattice would be too
    large an image: a few cells kilometres apart)."""
    from matplotlib.collections import PolyCollection

    index = np.floor(xy / cell_size).astype(np.int64)
    lo = index.min(axis=0)
    width, height = index.max(axis=0) - lo + 1
    if as_image and width * height <= MAX_CELL_IMAGE:
        image = np.zeros((int(height), int(width), 4))
        image[index[:, 1] - lo[1], index[:, 0] - lo[0]] = rgba
        x0, y0 = lo * cell_size
        ax.imshow(
            image,
            extent=(x0, x0 + width * cell_size, y0, y0 + height * cell_size),
            origin="lower",
            interpolation="antialiased",
            zorder=3,
        )
        return
    half = cell_size / 2.0
    square = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    ax.add_collection(
        PolyCollection(
            _arrays(xy[:, None, :] + square[None]), facecolors=rgba, edgecolors="none", zorder=3
        )
    )


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
    """Each room's outline (the convex hull of its places grown by one cell all round, every
    place a cell inside it; a room without places has none) and its label at the centroid
    of its places; computed once per picture (the panels of a series share the map's
    rooms)."""

    hulls: tuple[F64, ...]
    label_xy: F64
    labels: tuple[str, ...]
    label_places: tuple[int, ...] = ()
    """How many places each labelled room has (the larger keep their labels first,
    :mod:`.room_labels`)."""


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
    sizes: list[int] = []
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
            sizes.append(len(xy))
    xy_all = np.asarray(label_xy, dtype=np.float64).reshape(-1, 2)
    return RoomOutlines(tuple(hulls), xy_all, tuple(labels), tuple(sizes))


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
    from aion_cli.formats.outputs import plain_text

    halo = [effects.withStroke(linewidth=2.5, foreground="white")]
    for (x, y), label in zip(rooms.label_xy.tolist(), rooms.labels, strict=True):
        ax.text(
            x,
            y,
            plain_text(label),  # the scene graph's name, its $ not maths
            fontsize=label_size,
            color=LABEL_GREY,
            ha="center",
            va="center",
            zorder=15,
            path_effects=halo,
        )


def _padded_hull(xy: F64, pad: float) -> F64 | None:
    """The convex hull of ``xy`` grown by ``pad`` all round (the hull of an octagon of
    inner radius ``pad`` around each of its corners), so every point lies at least ``pad``
    inside it, a row of points too; None without a finite point."""
    from scipy.spatial import ConvexHull, QhullError

    xy = np.unique(xy[np.isfinite(xy).all(axis=1)], axis=0)
    if len(xy) == 0:
        return None
    try:
        xy = xy[ConvexHull(xy).vertices]
    except QhullError:  # fewer than three points, or all on one line: their ends
        along = (xy - xy[0]) @ (xy[-1] - xy[0])
        xy = xy[[int(np.argmin(along)), int(np.argmax(along))]]
    turns = np.arange(8) * (np.pi / 4) + np.pi / 8
    octagon = np.column_stack([np.cos(turns), np.sin(turns)]) * (pad / np.cos(np.pi / 8))
    grown = (xy[:, None, :] + octagon[None]).reshape(-1, 2)
    return np.asarray(grown[ConvexHull(grown).vertices])


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
        and np.array_equal(a.edges_xyz, b.edges_xyz)
        and np.array_equal(a.room_xyz, b.room_xyz, equal_nan=True)
    )
