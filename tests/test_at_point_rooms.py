"""``predict --at X,Y --layer rooms``: the room that holds the place nearest the point, not
the room whose centre is nearest (a point at the end of a long hallway was answered with a
small kitchen 6.6 m away, whose centre was closer than the hallway's)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from aion_cli.engine.query import ROOM
from aion_cli.entry_selection import place_owners, select
from aion_cli.errors import InputError


def _sym(char: str, n: int) -> int:
    return (ord(char) << 56) | n


HALL, KITCHEN, HOUSE = _sym("R", 1), _sym("R", 2), _sym("B", 0)
#: a 20 m hallway along x (centre 10,0) and a kitchen beside its east end (centre 22,3)
GRAPH = SimpleNamespace(
    places=SimpleNamespace(
        ids=np.array([_sym("p", i) for i in range(4)], np.uint64),
        parent=np.array([HALL, HALL, HALL, KITCHEN], np.uint64),
        xyz=np.array([[0.0, 0, 0], [10, 0, 0], [19, 0, 0], [22, 3, 0]]),
    ),
    rooms=SimpleNamespace(ids=np.array([HALL, KITCHEN], np.uint64),
                          parent=np.array([HOUSE, HOUSE], np.uint64)),
)
ROOMS = SimpleNamespace(
    key=np.array([-1, -1]), node_id=np.array([HALL, KITCHEN], np.uint64),
    kind=np.array([ROOM, ROOM], np.int8), xyz=np.array([[10.0, 0, 0], [22, 3, 0]]),
)


def test_the_room_holding_the_nearest_place_answers() -> None:
    # 19.5,1: 9.6 m from the hallway's centre, 3.2 m from the kitchen's; 1.1 m from p2
    (row,) = select(ROOMS, "rooms", at="19.5,1", owners=place_owners(GRAPH, "rooms")).tolist()
    assert ROOMS.node_id[row] == HALL
    (row,) = select(ROOMS, "rooms", at="21.5,2.5", owners=place_owners(GRAPH, "rooms")).tolist()
    assert ROOMS.node_id[row] == KITCHEN
    # without the places, the nearest centre (the old answer)
    (row,) = select(ROOMS, "rooms", at="19.5,1").tolist()
    assert ROOMS.node_id[row] == KITCHEN


def test_buildings_own_their_rooms_places_and_far_points_are_refused() -> None:
    _, owner = place_owners(GRAPH, "buildings")
    assert owner.tolist() == [HOUSE] * 4
    assert place_owners(GRAPH, "places") is None
    with pytest.raises(InputError, match="from the nearest place"):
        select(ROOMS, "rooms", at="900,0", owners=place_owners(GRAPH, "rooms"))
