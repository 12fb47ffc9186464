"""The paper's synthetic office (section IV): an open-plan workspace, a hallway and four rooms.

Layout in metres (x east, y north), walls 2.5 m high, places 1 m above the floor like Hydra's
GVD places::

    y=24 +---------+-----------+--------+--------+
         | kitchen | meeting   | office | office |
    y=17 +--door---+---door----+--door--+--door--+-----------+
         |                  hallway                       entrance (x=40)
    y=14 +---door------------door------+-----------------------+
         |     open-plan workspace      |
    y=0  +------------------------------+  x=24

Places form a 2 m grid inside rooms and a 1.5 m line along the hallway, plus one place in every
doorway; edges join neighbours within 2.9 m that see each other (no edge through a wall).
"""

from __future__ import annotations

import numpy as np

from aion_cli.engine.types import F64, I64, Mesh
from aion_cli.sim.environment import (
    BUILDING_CHAR,
    PLACE_CHAR,
    ROOM_CHAR,
    Environment,
    Roles,
    symbol,
)
from aion_cli.sim.geometry import point_segment_distance

PLACE_Z = 1.0
WALL_HEIGHT = 2.5
DOOR_HALF = 0.7
EDGE_RADIUS = 2.9

# name, xmin, ymin, xmax, ymax
ROOMS: tuple[tuple[str, float, float, float, float], ...] = (
    ("workspace", 0.0, 0.0, 24.0, 14.0),
    ("hallway", 0.0, 14.0, 40.0, 17.0),
    ("kitchen", 0.0, 17.0, 8.0, 24.0),
    ("meeting room", 8.0, 17.0, 18.0, 24.0),
    ("office 1", 18.0, 17.0, 24.0, 24.0),
    ("office 2", 24.0, 17.0, 30.0, 24.0),
)
WORKSPACE_DOORS = (5.0, 19.0)  # on y = 14
ROOM_DOORS = (4.0, 13.0, 21.0, 27.0)  # on y = 17
ENTRANCE_Y = 15.5  # gap in the east wall x = 40


def _wall_with_gaps(
    fixed: float, lo: float, hi: float, gaps: tuple[float, ...], horizontal: bool
) -> list[tuple[float, float, float, float]]:
    """Segments of a straight wall from lo to hi with door gaps of width 2·DOOR_HALF."""
    cuts = [lo]
    for g in sorted(gaps):
        cuts += [g - DOOR_HALF, g + DOOR_HALF]
    cuts.append(hi)
    out = []
    for a, b in zip(cuts[::2], cuts[1::2], strict=True):
        out.append((a, fixed, b, fixed) if horizontal else (fixed, a, fixed, b))
    return out


def office_walls() -> F64:
    """Wall segments (x0, y0, x1, y1) of the office, doorways left open."""
    w: list[tuple[float, float, float, float]] = [
        (0.0, 0.0, 24.0, 0.0),
        (0.0, 0.0, 0.0, 24.0),
        (24.0, 0.0, 24.0, 14.0),
        (0.0, 24.0, 30.0, 24.0),
        (30.0, 17.0, 30.0, 24.0),
        (30.0, 17.0, 40.0, 17.0),
        (24.0, 14.0, 40.0, 14.0),
        (8.0, 17.0, 8.0, 24.0),
        (18.0, 17.0, 18.0, 24.0),
        (24.0, 17.0, 24.0, 24.0),
    ]
    w += _wall_with_gaps(14.0, 0.0, 24.0, WORKSPACE_DOORS, horizontal=True)
    w += _wall_with_gaps(17.0, 0.0, 30.0, ROOM_DOORS, horizontal=True)
    w += _wall_with_gaps(40.0, 14.0, 17.0, (ENTRANCE_Y,), horizontal=False)
    return np.asarray(w, dtype=np.float64)


def _grid(x0: float, x1: float, y0: float, y1: float) -> F64:
    xs = np.arange(x0, x1 + 1e-9, 2.0)
    ys = np.arange(y0, y1 + 1e-9, 2.0)
    gx, gy = np.meshgrid(xs, ys)
    return np.column_stack([gx.ravel(), gy.ravel()])


def office_places() -> tuple[F64, I64]:
    """Place positions (x, y) and each place's room row in :data:`ROOMS`."""
    blocks = [
        (_grid(1.0, 23.0, 1.0, 13.0), 0),
        (np.column_stack([np.arange(0.75, 40.0, 1.5), np.full(27, 15.5)]), 1),
        (_grid(1.0, 7.0, 18.5, 22.5), 2),
        (_grid(9.0, 17.0, 18.5, 22.5), 3),
        (_grid(19.0, 23.0, 18.5, 22.5), 4),
        (_grid(25.0, 29.0, 18.5, 22.5), 5),
        (np.array([[x, 14.0] for x in WORKSPACE_DOORS] + [[x, 17.0] for x in ROOM_DOORS]), 1),
    ]
    xy = np.concatenate([b for b, _ in blocks])
    room = np.concatenate([np.full(len(b), r, dtype=np.int64) for b, r in blocks])
    return xy, room


def _edges(xyz: F64, walls: F64) -> I64:
    from aion_cli.sim.geometry import segments_blocked

    d = np.linalg.norm(xyz[:, None, :2] - xyz[None, :, :2], axis=-1)
    i, j = np.nonzero(np.triu(d <= EDGE_RADIUS, k=1))
    ok = ~segments_blocked(xyz[i], xyz[j], walls)
    return np.column_stack([i[ok], j[ok]]).astype(np.int64)


def _nearest(xy: F64, x: float, y: float) -> int:
    return int(np.argmin(np.linalg.norm(xy - np.array([x, y]), axis=1)))


def office_mesh(walls: F64) -> Mesh:
    """Floor quads per room and a 0.1 m thick box per wall segment, as triangles."""
    verts: list[F64] = []
    faces: list[I64] = []
    colors: list[F64] = []
    box_faces = np.array(
        [
            [0, 1, 2],
            [0, 2, 3],
            [4, 6, 5],
            [4, 7, 6],
            [0, 4, 5],
            [0, 5, 1],
            [1, 5, 6],
            [1, 6, 2],
            [2, 6, 7],
            [2, 7, 3],
            [3, 7, 4],
            [3, 4, 0],
        ]
    )
    for k, (_, x0, y0, x1, y1) in enumerate(ROOMS):
        base = sum(len(v) for v in verts)
        verts.append(np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]]))
        faces.append(np.array([[0, 1, 2], [0, 2, 3]]) + base)
        shade = 0.55 + 0.06 * k
        colors.append(np.full((4, 3), shade))
    for x0, y0, x1, y1 in walls:
        base = sum(len(v) for v in verts)
        d = np.array([x1 - x0, y1 - y0])
        n = np.array([-d[1], d[0]]) / max(float(np.linalg.norm(d)), 1e-9) * 0.05
        p0, p1 = np.array([x0, y0]), np.array([x1, y1])
        corners = np.array([p0 - n, p1 - n, p1 + n, p0 + n])
        low = np.column_stack([corners, np.zeros(4)])
        high = np.column_stack([corners, np.full(4, WALL_HEIGHT)])
        verts.append(np.concatenate([low, high]))
        faces.append(box_faces + base)
        colors.append(np.full((8, 3), 0.85))
    return Mesh(
        vertices=np.concatenate(verts),
        faces=np.concatenate(faces).astype(np.int32),
        colors=np.concatenate(colors),
    )


def office_environment(n_desks: int = 6) -> Environment:
    """The office of the Aion paper's synthetic dataset, with ``n_desks`` desks."""
    walls = office_walls()
    xy, room_row = office_places()
    xyz = np.column_stack([xy, np.full(len(xy), PLACE_Z)])
    room_ids = symbol(ROOM_CHAR, np.arange(len(ROOMS)))
    room_xyz = np.array([[(r[1] + r[3]) / 2, (r[2] + r[4]) / 2, PLACE_Z] for r in ROOMS])
    desk_xy = [(3, 5), (7, 5), (11, 9), (15, 5), (19, 9), (21, 20.5), (27, 20.5), (3, 11)]
    desks = np.array([_nearest(xy, x, y) for x, y in desk_xy], dtype=np.int64)
    patrol_xy = [
        (21.75, 15.5),
        (19, 13),
        (23, 1),
        (1, 1),
        (1, 13),
        (5, 20.5),
        (13, 20.5),
        (21, 20.5),
        (27, 20.5),
        (39.75, 15.5),
        (21.75, 15.5),
    ]
    roles = Roles(
        entrance=_nearest(xy, 39.75, 15.5),
        kitchen=_nearest(xy, 5.0, 20.5),
        meeting=_nearest(xy, 13.0, 20.5),
        dock=_nearest(xy, 21.75, 15.5),
        desks=np.resize(desks, n_desks).astype(np.int64),
        patrol=np.array([_nearest(xy, x, y) for x, y in patrol_xy], dtype=np.int64),
    )
    return Environment(
        name="office",
        place_ids=symbol(PLACE_CHAR, np.arange(len(xy))),
        xyz=xyz,
        edges=_edges(xyz, walls),
        place_room=room_ids[room_row],
        clearance=point_segment_distance(xy, walls),
        room_ids=room_ids,
        room_xyz=room_xyz,
        room_labels=tuple(r[0] for r in ROOMS),
        building_id=int(symbol(BUILDING_CHAR, 0)),
        roles=roles,
        walls=walls,
        mesh=office_mesh(walls),
    )
