"""Reading pictures back for the picture tests: PNG pixels (matplotlib's own PNG reader, not
the writer under test), data -> pixel positions, panel counting, and small synthetic scenes
with known geometry."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import Mesh
from aion_cli.scene import Scene

F64 = npt.NDArray[np.float64]
WHITE = np.array([1.0, 1.0, 1.0])


def read_png(path: Path) -> F64:
    """RGB floats 0..1, rows top to bottom (``matplotlib.image.imread`` decodes PNG itself)."""
    from matplotlib.image import imread

    img = np.asarray(imread(str(path)), dtype=np.float64)
    assert img.ndim == 3, img.shape
    assert img.shape[2] in (3, 4), img.shape
    return img[:, :, :3]


def pixel_of(ax: Any, image: F64, x: float, y: float) -> tuple[int, int]:
    """Row and column of the data point (x, y) of axes ``ax`` in ``image`` (the figure saved
    at its own dpi, after the draw that placed the axes)."""
    px, py = ax.transData.transform((x, y))
    return round(float(image.shape[0] - py)), round(float(px))


def window(image: F64, row: int, col: int, half: int = 2) -> F64:
    """The pixels [k, 3] of the (2·half+1)² square around (row, col)."""
    patch = image[max(row - half, 0) : row + half + 1, max(col - half, 0) : col + half + 1]
    return patch.reshape(-1, 3)


def most_coloured(image: F64, row: int, col: int, half: int = 2) -> F64:
    """The most saturated pixel (largest max - min channel) around (row, col)."""
    patch = window(image, row, col, half)
    return np.asarray(patch[np.argmax(patch.max(axis=1) - patch.min(axis=1))])


def darkest(image: F64, row: int, col: int, half: int = 2) -> F64:
    """The darkest pixel around (row, col)."""
    patch = window(image, row, col, half)
    return np.asarray(patch[np.argmin(patch.sum(axis=1))])


def is_blank(image: F64, row: int, col: int, half: int = 3) -> bool:
    """Every pixel around (row, col) is the white background."""
    return bool(np.abs(window(image, row, col, half) - WHITE).max() < 0.02)


def panel_count(image: F64, min_fraction: float = 0.08) -> int:
    """Panels of a page: regions enclosed by the black axes frames. Dark pixels (the frames,
    tick labels, titles) are walls; the regions between them at least ``min_fraction`` of the
    page wide and high are the page background and one interior per panel (the colour bar is
    too narrow to count)."""
    from scipy import ndimage

    walls = image.max(axis=2) < 0.35
    labels, _ = ndimage.label(~walls)
    rows, cols = image.shape[:2]
    big = 0
    for box in ndimage.find_objects(labels):
        if box is None:
            continue
        high, wide = box[0].stop - box[0].start, box[1].stop - box[1].start
        big += high > min_fraction * rows and wide > min_fraction * cols
    return big - 1  # the page around the panels


def the_legend(fig: Any) -> Any:
    """The one legend of a picture (of its paths and markers), wherever it is drawn."""
    (legend,) = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    return legend


def count_near(image: F64, color: tuple[float, float, float], tol: float = 0.08) -> int:
    """How many pixels are within ``tol`` (per channel) of ``color``."""
    return int((np.abs(image - np.asarray(color)).max(axis=2) < tol).sum())


def synthetic_scene(
    flow_a: float = 10.0,
    flow_b: float = 10.0,
    entropy_a: float = 0.1,
    entropy_b: float = 0.9,
    t_ns: int | None = None,
) -> Scene:
    """Places A (0,0), B (8,0), C (0,8) in room "lab", edges A-C and B-C; node A flows along
    +x with low entropy, node B along +y with high entropy, C has no flow; one hash cell at
    (4,6) with entropy 0.5 and flow 5 along -x; a mesh triangle around (-3,5). The quadrant
    around (7,7) holds nothing."""
    places = np.array([[0.0, 0.0, 0.0], [8.0, 0.0, 0.0], [0.0, 8.0, 0.0]])
    nan = np.nan
    return Scene(
        t_ns=t_ns,
        cell_size=0.5,
        window_s=600.0,
        node_ids=np.array([1, 2, 3], dtype=np.uint64),
        nodes_xyz=places.copy(),
        node_flow=np.array([flow_a, flow_b, 0.0]),
        node_entropy=np.array([entropy_a, entropy_b, nan]),
        node_angle=np.array([0.0, np.pi / 2, nan]),
        node_concentration=np.array([0.9, 0.2, nan]),
        cells_xyz=np.array([[4.0, 6.0, 0.0]]),
        cells_flow=np.array([5.0]),
        cells_entropy=np.array([0.5]),
        cells_angle=np.array([np.pi]),
        places_xyz=places,
        edges_xyz=places[np.array([[0, 2], [1, 2]])],
        room_ids=np.array([(ord("R") << 56) | 0], dtype=np.uint64),
        room_labels=("lab",),
        room_xyz=np.array([[2.7, 2.7, 0.0]]),
        place_room=np.array([0, 0, 0], dtype=np.int64),
        mesh=Mesh(
            np.array([[-4.0, 4.0, 0.0], [-2.0, 4.0, 0.0], [-3.0, 6.0, 0.0]]),
            np.array([[0, 1, 2]], dtype=np.int32),
        ),
    )


def cells_only_scene(
    xy: npt.ArrayLike,
    flow: npt.ArrayLike,
    angle: npt.ArrayLike | None = None,
    entropy: npt.ArrayLike | None = None,
) -> Scene:
    """A map of hash cells only (no graph, no nodes, no mesh): cells at ``xy`` f64[n,2] with
    ``flow``, dominant ``angle`` (default 0) and ``entropy`` (default 0.5)."""
    from dataclasses import replace

    cells = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    n = len(cells)
    empty3 = np.zeros((0, 3))
    return replace(
        synthetic_scene(),
        node_ids=np.zeros(0, np.uint64),
        nodes_xyz=empty3,
        node_flow=np.zeros(0),
        node_entropy=np.zeros(0),
        node_angle=np.zeros(0),
        node_concentration=np.zeros(0),
        cells_xyz=np.column_stack([cells, np.zeros(n)]),
        cells_flow=np.asarray(flow, dtype=np.float64),
        cells_entropy=np.full(n, 0.5) if entropy is None else np.asarray(entropy, float),
        cells_angle=np.zeros(n) if angle is None else np.asarray(angle, dtype=np.float64),
        places_xyz=empty3,
        edges_xyz=np.zeros((0, 2, 3)),
        room_ids=np.zeros(0, np.uint64),
        room_labels=(),
        room_xyz=empty3,
        place_room=np.zeros(0, np.int64),
        mesh=None,
    )


def places_scene(xyz: npt.ArrayLike) -> Scene:
    """:func:`synthetic_scene`'s hash cell beside places at ``xyz`` f64[n,3], each a node
    flowing +x (flow 1, entropy 0.1): no edges, rooms or mesh."""
    from dataclasses import replace

    places = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    n = len(places)
    return replace(
        synthetic_scene(),
        node_ids=np.arange(n, dtype=np.uint64),
        nodes_xyz=places,
        node_flow=np.ones(n),
        node_entropy=np.full(n, 0.1),
        node_angle=np.zeros(n),
        node_concentration=np.full(n, 0.9),
        places_xyz=places,
        place_room=np.full(n, -1, np.int64),
        edges_xyz=np.zeros((0, 2, 3)),
        room_ids=np.zeros(0, np.uint64),
        room_labels=(),
        room_xyz=np.zeros((0, 3)),
        mesh=None,
    )
