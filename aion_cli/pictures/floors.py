"""The levels of a map seen from above: a building whose places, nodes and hash cells lie at
heights apart by more than :data:`LEVEL_GAP` (floors of a multi-storey map) is drawn one
panel per level, so the floors' flows are not drawn over each other.

A map's heights split where two consecutive distinct heights of its places, nodes and cells
are more than :data:`LEVEL_GAP` apart; the places of one floor of a Hydra graph fill its
free space (heights 0.1 to 3 m, a few centimetres apart), so one floor is one level, and
floors joined by a staircase of places stay one level too (drawn over each other, as
before). Each item goes to the level its height falls in (the boundaries half way between
two levels), a mesh triangle by its lowest corner (a wall stands on its floor), an edge when
both its ends are on the level, a room when any of its places is; a path keeps its points on
the level (the rest are gaps in its line).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aion_cli.scene import Scene

if TYPE_CHECKING:
    from aion_cli.pictures.topdown_panel import Marker, PathLine

F64 = npt.NDArray[np.float64]

LEVEL_GAP = 1.5
"""Heights (m) further apart than this, with nothing between, are different levels."""


def levels(scenes: Sequence[Scene]) -> list[tuple[float, float]]:
    """The levels ``(lowest, highest)`` height (m) of the places, nodes and cells of
    ``scenes``, bottom up; one level (or none, for a scene with nothing) when no gap splits
    them."""
    z = np.concatenate(
        [np.zeros(0)]
        + [a[:, 2] for s in scenes for a in (s.places_xyz, s.nodes_xyz, s.cells_xyz)]
    )
    z = np.unique(z[np.isfinite(z)])
    if len(z) == 0:
        return []
    cut = np.flatnonzero(np.diff(z) > LEVEL_GAP)
    starts = np.r_[0, cut + 1]
    ends = np.r_[cut, len(z) - 1]
    return [(float(z[a]), float(z[b])) for a, b in zip(starts, ends, strict=True)]


def levels_apart(scenes: Sequence[Scene], most: int) -> list[tuple[float, float]]:
    """The :func:`levels` drawn a panel each: none (all drawn in one panel) for one level,
    and for more than ``most`` (the panels a picture holds): no ``--step`` could make room
    for them, so they are drawn over each other, as before levels were drawn apart."""
    found = levels(scenes)
    return found if 1 < len(found) <= most else []


def level_title(extent: tuple[float, float]) -> str:
    """``"level z 4.0 m"`` for a level at one height, ``"level z 0.0 to 0.5 m"`` for one
    spread over heights (:func:`level_extents`: a hash cell's by its bottom and top)."""
    lo, hi = extent
    if hi - lo < 0.05:
        return f"level z {_metres(lo)} m"
    return f"level z {_metres(lo)} to {_metres(hi)} m"


def _metres(value: float) -> str:
    """A height to the centimetre, trailing zeros dropped but one decimal kept: ``0.0``,
    ``0.5``, ``4.25`` (one decimal read a 0.25 m cell centre "0.2")."""
    from aion_cli.number_text import fixed

    text = fixed(value, 2).rstrip("0")
    return text + "0" if text.endswith(".") else text


def level_extents(
    scenes: Sequence[Scene], found: Sequence[tuple[float, float]]
) -> list[tuple[float, float]]:
    """Each level's lowest and highest height (m) as what lies on it covers them: places
    and nodes at their heights, a hash cell from its bottom to its top (its centre ± half
    the cell size: people detected at z 0 fill the cell 0 to 0.5 m, centred at 0.25)."""
    bounds = level_bounds(found)
    parts = [np.zeros((0, 3))]
    for s in scenes:
        for a in (s.places_xyz, s.nodes_xyz):
            z = a[:, 2]
            parts.append(np.column_stack([z, z, z]))
        z, half = s.cells_xyz[:, 2], 0.5 * float(s.cell_size)
        parts.append(np.column_stack([z, z - half, z + half]))
    rows = np.concatenate(parts)
    rows = rows[np.isfinite(rows).all(axis=1)]
    level = _level_of(rows[:, 0], bounds)
    out = []
    for k, (lo, hi) in enumerate(found):
        on = level == k
        out.append((float(rows[on, 1].min()), float(rows[on, 2].max())) if on.any() else (lo, hi))
    return out


def _level_of(z: F64, bounds: F64) -> npt.NDArray[np.int64]:
    """The level of each height (``bounds``: the heights half way between two levels)."""
    return np.searchsorted(bounds, z, side="right").astype(np.int64)


def level_bounds(found: Sequence[tuple[float, float]]) -> F64:
    """The heights half way between consecutive levels."""
    return np.array([(found[k][1] + found[k + 1][0]) / 2.0 for k in range(len(found) - 1)])


def on_level(scene: Scene, level: int, bounds: F64) -> Scene:
    """``scene`` with only what lies on level ``level`` (the module docstring)."""
    node = _level_of(scene.nodes_xyz[:, 2], bounds) == level
    cell = _level_of(scene.cells_xyz[:, 2], bounds) == level
    place = _level_of(scene.places_xyz[:, 2], bounds) == level
    edge = (_level_of(scene.edges_xyz[:, :, 2], bounds) == level).all(axis=1)
    rooms = np.unique(scene.place_room[place & (scene.place_room >= 0)])
    room_row = np.full(len(scene.room_ids), -1, np.int64)
    room_row[rooms] = np.arange(len(rooms))
    mesh = scene.mesh
    if mesh is not None:
        faces = np.asarray(mesh.faces).reshape(-1, 3)
        lowest = np.asarray(mesh.vertices, np.float64).reshape(-1, 3)[faces, 2].min(axis=1)
        mesh = replace(mesh, faces=faces[_level_of(lowest, bounds) == level])
    return replace(
        scene,
        node_ids=scene.node_ids[node],
        nodes_xyz=scene.nodes_xyz[node],
        node_flow=scene.node_flow[node],
        node_entropy=scene.node_entropy[node],
        node_angle=scene.node_angle[node],
        node_concentration=scene.node_concentration[node],
        cells_xyz=scene.cells_xyz[cell],
        cells_flow=scene.cells_flow[cell],
        cells_entropy=scene.cells_entropy[cell],
        cells_angle=scene.cells_angle[cell],
        places_xyz=scene.places_xyz[place],
        edges_xyz=scene.edges_xyz[edge],
        room_ids=scene.room_ids[rooms],
        room_labels=tuple(
            scene.room_labels[r] if r < len(scene.room_labels) else "" for r in rooms
        ),
        room_xyz=scene.room_xyz[rooms],
        place_room=_rows(scene.place_room[place], room_row),
        mesh=mesh,
    )


def _rows(room: npt.NDArray[np.int64], row: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Each place's room row renumbered by ``row`` (-1, no room, stays)."""
    out = np.full(len(room), -1, np.int64)
    has = room >= 0
    out[has] = row[room[has]]
    return out


def path_on_level(xyz: F64, level: int, bounds: F64) -> F64:
    """A path's points f64[p,3] with those off level ``level`` as NaN (gaps in its line)."""
    pts = np.asarray(xyz, dtype=np.float64).reshape(-1, 3).copy()
    pts[_level_of(pts[:, 2], bounds) != level] = np.nan
    return pts


def point_on_level(z: float | None, level: int, bounds: F64) -> bool:
    """Whether a marker at height ``z`` (None: any) belongs on level ``level``."""
    return z is None or int(_level_of(np.array([z]), bounds)[0]) == level


def by_level(
    scenes: Sequence[Scene],
    titles: Sequence[str],
    paths: Sequence[Sequence[PathLine]],
    markers: Sequence[Marker],
    found: Sequence[tuple[float, float]],
) -> tuple[list[Scene], list[str], list[Sequence[PathLine]], list[list[Marker]]]:
    """One panel per scene and level (:mod:`.floors`), time by time, bottom level first:
    its scene, title (the level's height added), paths and markers on that level."""
    bounds = level_bounds(found)
    extents = level_extents(scenes, found)
    out: tuple[list[Scene], list[str], list[Sequence[PathLine]], list[list[Marker]]] = (
        [], [], [], []
    )
    for scene, title, lines in zip(scenes, titles, paths, strict=True):
        for k, extent in enumerate(extents):
            out[0].append(on_level(scene, k, bounds))
            # the level on a line of its own: a time's title and the level's in one line
            # ran into the next panel's
            level = level_title(extent)
            out[1].append(f"{title}\n{level}" if title else level)
            out[2].append([replace(p, xyz=path_on_level(p.xyz, k, bounds)) for p in lines])
            out[3].append([m for m in markers if point_on_level(m.z, k, bounds)])
    return out
