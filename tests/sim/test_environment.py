"""The office environment and the planar geometry under it."""

from __future__ import annotations

import numpy as np

from aion_cli.sim.environment import largest_component
from aion_cli.sim.geometry import (
    se2_apply,
    se2_compose,
    se2_inverse,
    segments_blocked,
)
from aion_cli.sim.office import ROOMS, office_environment, office_walls


def test_segments_blocked_by_walls_but_not_through_doorways() -> None:
    wall = np.array([[0.0, 0.0, 10.0, 0.0], [11.0, 0.0, 20.0, 0.0]])  # gap 10..11
    p = np.array([[5.0, -1.0], [10.5, -1.0], [5.0, 1.0], [10.0, -1.0], [0.0, 0.0]])
    q = np.array([[5.0, 1.0], [10.5, 1.0], [6.0, 2.0], [10.0, 1.0], [20.0, 0.0]])
    # crossing, through the gap, same side, touching the jamb, collinear along the wall
    np.testing.assert_array_equal(segments_blocked(p, q, wall), [True, False, False, False, False])


def test_se2_inverse_and_compose() -> None:
    rng = np.random.default_rng(0)
    a = rng.normal(size=(20, 3))
    b = rng.normal(size=(20, 3))
    ident = se2_compose(a, se2_inverse(a))
    np.testing.assert_allclose(ident[:, :2], 0, atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * ident[:, 2])), 0, atol=1e-12)
    pts = rng.normal(size=(20, 3))
    np.testing.assert_allclose(se2_apply(se2_compose(a, b), pts), se2_apply(a, se2_apply(b, pts)))
    # a quarter turn about z moves +x to +y and keeps z
    np.testing.assert_allclose(
        se2_apply(np.array([[1.0, 0.0, np.pi / 2]]), np.array([[1.0, 0.0, 7.0]])),
        [[1.0, 1.0, 7.0]],
        atol=1e-12,
    )


def test_office_place_graph_is_hydra_like() -> None:
    env = office_environment(6)
    assert env.n_places > 100
    # connected, neighbours 1-2.9 m apart, no edge through a wall
    assert len(largest_component(env.n_places, env.edges)) == env.n_places
    length = np.linalg.norm(env.xyz[env.edges[:, 0]] - env.xyz[env.edges[:, 1]], axis=1)
    assert length.min() >= 1.0
    assert length.max() <= 2.9
    assert not segments_blocked(
        env.xyz[env.edges[:, 0]], env.xyz[env.edges[:, 1]], office_walls()
    ).any()
    # every place lies inside the rectangle of its room
    room_of = {int(r): ROOMS[k] for k, r in enumerate(env.room_ids)}
    for xyz, rid in zip(env.xyz, env.place_room, strict=True):
        _, x0, y0, x1, y1 = room_of[int(rid)]
        assert x0 <= xyz[0] <= x1
        assert y0 <= xyz[1] <= y1
    # node symbols: places 'p', rooms 'R', one building 'B0'
    assert {chr(int(i) >> 56) for i in env.place_ids} == {"p"}
    assert {chr(int(i) >> 56) for i in env.room_ids} == {"R"}
    assert env.building_id == (ord("B") << 56)
    assert {"workspace", "hallway", "kitchen", "meeting room"} <= set(env.room_labels)
    assert env.clearance.min() > 0.5


def test_office_paths_go_through_doors() -> None:
    env = office_environment(6)
    path = env.polyline(np.array([env.roles.desks[0], env.roles.kitchen]))
    # from the workspace (y < 14) to the kitchen (y > 17) the walk crosses the hallway
    assert path[0, 1] < 14 < 17 < path[-1, 1]
    assert not segments_blocked(path[:-1], path[1:], env.walls).any()
    # mesh: floors and wall boxes, valid face indices
    mesh = env.mesh
    assert mesh is not None
    assert mesh.faces.max() < len(mesh.vertices)
    assert len(mesh.colors) == len(mesh.vertices)
    assert mesh.vertices[:, 2].max() == 2.5
