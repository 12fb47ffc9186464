"""Rooms by name (aion_cli/room_names.py): any case, and a name with spaces as one shell word
with underscores, as shell completion offers it; names a shell would interpret are not
offered."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.node_ids import node_label
from aion_cli.engine.types import GraphSnapshot, Layer
from aion_cli.errors import InputError
from aion_cli.room_names import named_node, room_names, shell_word

R = ord("R") << 56
B = ord("B") << 56


def _graph(room_labels: tuple[str, ...], building_labels: tuple[str, ...] = ()) -> GraphSnapshot:
    def layer(base: int, labels: tuple[str, ...]) -> Layer:
        n = len(labels)
        ids = np.arange(n, dtype=np.uint64) + np.uint64(base)
        return Layer(ids, np.zeros((n, 3)), np.zeros(n, np.uint64), labels)

    places = Layer(np.zeros(0, np.uint64), np.zeros((0, 3)), np.zeros(0, np.uint64))
    return GraphSnapshot(0, places, np.zeros((0, 2), np.int64),
                         rooms=layer(R, room_labels), buildings=layer(B, building_labels))


def test_a_name_with_spaces_is_found_by_its_shell_word_in_any_case() -> None:
    graph = _graph(("office 1", "Meeting  Room", "kitchen", "R3"), ("main building",))
    assert room_names(graph) == ["office 1", "Meeting  Room", "kitchen", "main building"]
    for typed, room in [("office 1", R), ("office_1", R), ("OFFICE_1", R), (" office  1 ", R),
                        ("meeting_room", R + 1), ("meeting room", R + 1), ("Kitchen", R + 2),
                        ("main_building", B)]:
        assert named_node(typed, graph) == room, typed
    assert named_node("R3", graph) == R + 3  # a label that is the id: the same node either way
    assert named_node("office_2", graph) is None
    for name in room_names(graph):  # completion's word reads back as the same node
        word = shell_word(name)
        assert word is not None
        assert " " not in word
        assert named_node(word, graph) == named_node(name, graph)


def test_names_a_shell_would_interpret_are_not_offered() -> None:
    assert shell_word("office 1") == "office_1"
    assert shell_word("lab-2.north") == "lab-2.north"
    for name in ["coffee & tea", "bob's office", "store*", "$HOME", 'the "big" room', "a;b"]:
        assert shell_word(name) is None, name


def test_two_rooms_whose_names_differ_by_underscores_only_are_ambiguous() -> None:
    graph = _graph(("office 1", "office_1"))
    with pytest.raises(InputError, match="2 rooms are named 'office 1'") as err:
        named_node("office 1", graph)
    assert node_label(R) in str(err.value)
    assert node_label(R + 1) in str(err.value)


def test_the_report_labels_a_room_whose_name_is_its_id_by_the_id_alone() -> None:
    """MP3D graphs label each room with its id: the report's legend read "R0 R0"."""
    from types import SimpleNamespace

    from aion_cli.report.content import room_labels

    loaded = SimpleNamespace(graph=_graph(("R0", "kitchen", "")))
    assert room_labels(loaded) == {"R0": "", "R1": "kitchen", "R2": ""}  # type: ignore[arg-type]


def test_an_id_the_graph_holds_is_that_node_before_a_room_named_so() -> None:
    """A room Hydra named "p3" beside place p3: ``p3`` resolved to the room without a word
    (``plan --from p3`` started at the room's place nearest its centre, ``predict --node p3``
    answered for the room). The id now wins; the room is asked for by its id (R0), and a
    spelling that is no id the graph holds (``P3``) is still the room's name in any case."""
    from aion_cli.engine.nav_graph import NavGraph
    from aion_cli.room_names import with_names_resolved
    from aion_cli.routes import resolve_endpoint

    p = ord("p") << 56
    ids = np.arange(5, dtype=np.uint64) + np.uint64(p)  # p0 .. p4 along x, 1 m apart
    xyz = np.zeros((5, 3))
    xyz[:, 0] = np.arange(5)
    room = Layer(np.array([R], np.uint64), np.zeros((1, 3)), np.zeros(1, np.uint64), ("p3",))
    places = Layer(ids, xyz, np.full(5, R, np.uint64))  # every place in the room, at x = 0
    graph = GraphSnapshot(0, places, np.array([[k, k + 1] for k in range(4)]), rooms=room)
    nav = NavGraph.build(ids, xyz, graph.edges)
    assert named_node("p3", graph) == p + 3  # the place
    assert named_node("P3", graph) == R  # no such id: the room's name, in any case
    assert named_node("p9", graph) is None  # neither
    assert with_names_resolved(["p3", "R0", "p3 "], graph) == [p + 3, R, p + 3]
    assert resolve_endpoint("p3", nav, graph).node_id == p + 3
    assert resolve_endpoint("R0", nav, graph).node_id == p  # the room: its place at x = 0
