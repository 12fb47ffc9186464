"""Reading a stream of scene graphs by what changed (:mod:`formats.dsg_delta`) gives exactly
what reading each payload whole gives (:func:`formats.dsg_binary.read_graph`, itself tested
against spark_dsg in ``test_dsg_fast.py``), and reads by changes only where that is exact.

Every comparison is field by field, dtypes included: a live stream's edits (places moved and
stamped, a name renamed, a node added, an edge added, the mesh changed), every single-byte
change of a payload (hypothesis: any position, any value), and a build of a moving stream
whose map must equal the build that reads every graph whole.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.formats import dsg_delta
from aion_cli.formats.dsg_binary import BinaryGraph, read_graph
from aion_cli.formats.dsg_delta import GraphReader
from tests.formats.dsg_builders import hydra_graph, sym


def assert_same_graph(a: BinaryGraph | None, b: BinaryGraph | None) -> None:
    assert (a is None) == (b is None)
    if a is None or b is None:
        return
    for f in dataclasses.fields(BinaryGraph):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if f.name == "mesh":
            assert (x is None) == (y is None)
            if x is not None:
                for u, v in zip(x, y, strict=True):
                    assert u.dtype == v.dtype
                    np.testing.assert_array_equal(u, v)
        elif isinstance(x, np.ndarray):
            assert x.dtype == y.dtype, f.name
            assert x.shape == y.shape, f.name
            np.testing.assert_array_equal(x, y, err_msg=f.name)
        else:
            assert x == y, f.name


def streamed_equals_alone(payload: bytes, t_ns: int, reader: GraphReader) -> Any:
    """The snapshot ``fast_navigation`` makes of ``payload`` through the stream's ``reader``,
    checked equal to the one it makes of the payload alone (layer and frontiers too)."""
    from aion_cli.formats.dsg_fast import fast_navigation
    from tests.formats.snapshot_checks import assert_same_snapshot

    streamed = fast_navigation(payload, t_ns, None, reader)
    alone = fast_navigation(payload, t_ns, None)
    assert streamed is not None
    assert alone is not None
    assert_same_snapshot(streamed.snapshot, alone.snapshot)
    assert streamed.layer == alone.layer
    assert streamed.frontiers == alone.frontiers
    return streamed


def _graph() -> Any:
    return hydra_graph()


def _payload(G: Any) -> bytes:
    return bytes(G.to_binary(True))


def _move(G: Any, ids: list[int], dx: float, stamp: int) -> Any:
    for i in ids:
        attrs = G.get_node(i).attributes
        attrs.position = np.asarray(attrs.position) + np.array([dx, -dx, 0.0])
        attrs.last_update_time_ns = stamp
    return G


def _places(G: Any) -> list[int]:
    return sorted(n.id.value for n in G.get_layer("MESH_PLACES").nodes)


def _read_after(first: bytes, then: bytes) -> tuple[BinaryGraph | None, GraphReader]:
    reader = GraphReader()
    reader.read(first)
    return reader.read(then), reader


def test_moved_places_are_read_by_changes_and_equal_a_whole_read() -> None:
    G = _graph()
    first = _payload(G)
    moved = _places(G)[::3]
    then = _payload(_move(G, moved, 0.004, 1_700_000_000_123_456_789))
    got, reader = _read_after(first, then)
    assert reader.delta_reads == 1
    assert reader.whole_reads == 1
    assert (reader.records_in_place, reader.records_parsed) == (len(moved), 0)  # not parsed
    whole = read_graph(then)
    assert_same_graph(got, whole)
    assert got is not None
    before = read_graph(first)
    assert before is not None
    changed = np.flatnonzero((got.xyz != before.xyz).any(axis=1))
    assert sorted(got.ids[changed].tolist()) == moved  # the moves, nothing else


def test_a_long_stream_stays_equal() -> None:
    """Ten graphs in a row, each moving other places (each read against the one before)."""
    G = _graph()
    reader = GraphReader()
    places = _places(G)
    rng = np.random.default_rng(3)
    for k in range(10):
        which = rng.choice(places, 4, replace=False).tolist()
        payload = _payload(_move(G, which, float(rng.uniform(-0.01, 0.01)), 10**18 + k))
        assert_same_graph(reader.read(payload), read_graph(payload))
    assert reader.delta_reads == 9


def test_a_renamed_node_of_the_same_length_is_read_by_changes() -> None:
    G = _graph()
    renamed = _places(G)[2]
    node = G.get_node(renamed).attributes
    node.name = "kitchen"
    first = _payload(G)
    node.name = "hallway"
    then = _payload(G)
    got, reader = _read_after(first, then)
    assert reader.delta_reads == 1
    assert (reader.records_in_place, reader.records_parsed) == (0, 1)  # a string: parsed
    assert_same_graph(got, read_graph(then))
    assert got is not None
    row = int(np.flatnonzero(got.ids == renamed)[0])
    start = int(got.name_start[row])
    assert bytes(got.data[start : start + 7]) == b"hallway"


@pytest.mark.parametrize("edit", ["add node", "add edge", "longer name", "mesh", "remove node"])
def test_structural_changes_are_read_whole(edit: str) -> None:
    import spark_dsg as dsg

    G = _graph()
    first = _payload(G)
    places = _places(G)
    if edit == "add node":
        a = dsg.PlaceNodeAttributes()
        a.position = np.array([1.0, 2.0, 0.0])
        G.add_node(G.get_node(places[0]).layer, sym("p", 9999), a)
    elif edit == "add edge":
        G.insert_edge(places[0], places[-1])
    elif edit == "longer name":
        G.get_node(places[1]).attributes.name = "a much longer name than before"
    elif edit == "mesh":
        m = dsg.Mesh()
        m.set_vertices(np.ones((6, 3)))
        m.set_faces(np.zeros((3, 1), dtype=np.int32))
        G.mesh = m
    else:
        G.remove_node(places[4])
    then = _payload(G)
    got, reader = _read_after(first, then)
    assert reader.delta_reads == 0
    assert reader.whole_reads == 2
    assert_same_graph(got, read_graph(then))


def test_an_identical_payload_reuses_the_graph() -> None:
    first = _payload(_graph())
    got, reader = _read_after(first, bytes(first))
    assert reader.delta_reads == 1
    assert_same_graph(got, read_graph(first))


_FIRST = _payload(_graph())


@settings(max_examples=300, deadline=None)
@given(st.integers(0, len(_FIRST) - 1), st.integers(0, 255))
def test_any_changed_byte_reads_as_a_whole_read(at: int, value: int) -> None:
    """Whatever byte changes to whatever value — a tag, a length, a kind, an id, a value, a
    metadata character — reading by changes gives what the whole read gives (None included:
    then spark_dsg decodes)."""
    changed = bytearray(_FIRST)
    changed[at] = value
    got, _ = _read_after(_FIRST, bytes(changed))
    assert_same_graph(got, read_graph(bytes(changed)))


@settings(max_examples=200, deadline=None)
@given(
    st.integers(0, 40),
    st.integers(0, 7),
    st.integers(0, 7),
    st.lists(st.tuples(st.integers(0, 39), st.integers(1, 255)), max_size=6),
)
def test_differing_bytes_at_any_alignment(
    n: int, shift_a: int, shift_b: int, edits: list[tuple[int, int]]
) -> None:
    """The bytes at which two payloads differ are every differing byte, ascending, wherever
    each payload starts in memory (the same 8-byte boundary, another one, or none within a
    short payload): the words are compared from a common boundary when there is one."""
    rng = np.random.default_rng(n * 64 + shift_a * 8 + shift_b)
    data = rng.integers(0, 256, n, dtype=np.uint8)
    a_mem = np.zeros(n + 16, np.uint8)  # fresh arrays start on an 8-byte boundary
    b_mem = np.zeros(n + 16, np.uint8)
    a, b = a_mem[shift_a : shift_a + n], b_mem[shift_b : shift_b + n]
    a[:] = data
    b[:] = data
    for at, delta in edits:
        if at < n:
            b[at] ^= delta
    expected = np.flatnonzero(a != b)
    got = dsg_delta._differing_bytes(a, b)
    if expected.size == 0:
        assert got is None
    else:
        assert got is not None
        assert got.tolist() == expected.tolist()


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, len(_FIRST) - 1), st.integers(0, 255)), max_size=8))
def test_any_changed_bytes_read_as_a_whole_read(edits: list[tuple[int, int]]) -> None:
    """A few bytes changed at once, anywhere — values of some records read in place, tags or
    lengths of others parsed again in the same payload — give what the whole read gives."""
    changed = bytearray(_FIRST)
    for at, value in edits:
        changed[at] = value
    got, _ = _read_after(_FIRST, bytes(changed))
    assert_same_graph(got, read_graph(bytes(changed)))


def test_values_and_a_rename_in_one_payload() -> None:
    """Places moved (read in place) and another renamed (parsed again) in one payload."""
    G = _graph()
    places = _places(G)
    G.get_node(places[1]).attributes.name = "kitchen"
    first = _payload(G)
    G.get_node(places[1]).attributes.name = "hallway"
    then = _payload(_move(G, places[4:10], 0.003, 10**18 + 7))
    got, reader = _read_after(first, then)
    assert (reader.records_in_place, reader.records_parsed) == (6, 1)
    assert_same_graph(got, read_graph(then))


def test_a_build_of_a_moving_stream_equals_reading_every_graph_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The live-Hydra stream of the benchmarks (places moved by millimetres every second):
    the map is the same, and the graphs after the first were read by changes."""
    from aion_cli.formats.mapfile import read_map
    from aion_cli.pipeline import BuildOptions, build_map
    from benchmarks.build_logs import SITE, MovingPayload, places_graph, steady_times, write_log

    xyz, edges = places_graph(*SITE, 300)
    log = tmp_path / "moving.mcap"
    write_log(log, steady_times(120.0), 2, (SITE[0], SITE[1]), MovingPayload(xyz, edges), 1.0)
    opts = {"logs": (log,), "graph_period_ns": 0}
    changes = build_map(BuildOptions(output=tmp_path / "changes.aion", **opts))
    monkeypatch.setattr(dsg_delta, "_changed_records", lambda buf, last: None)
    whole = build_map(BuildOptions(output=tmp_path / "whole.aion", **opts))
    assert changes.graph_decoded == whole.graph_decoded >= 100
    assert changes.graphs_read_by_changes == changes.graph_decoded - 1
    assert whole.graphs_read_by_changes == 0
    assert changes.to_dict()["graph"]["read_by_changes"] == changes.graph_decoded - 1
    a, ma = read_map(tmp_path / "changes.aion")
    b, mb = read_map(tmp_path / "whole.aion")
    assert sorted(a) == sorted(b)
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert ma["state"] == mb["state"]


def test_a_stream_read_by_changes_gives_the_snapshots_of_whole_reads() -> None:
    """Through :func:`fast_navigation` with the stream's reader (records re-read by changes,
    layer labels kept between graphs): every snapshot equals the one read alone — places
    moved, a place named, renamed and unnamed again, a room renamed."""
    G = _graph()
    places = _places(G)
    rooms = sorted(n.id.value for n in G.get_layer("ROOMS").nodes)
    edits = [
        lambda: _move(G, places[:5], 0.002, 10**18),
        lambda: setattr(G.get_node(places[3]).attributes, "name", "kitchen"),
        lambda: setattr(G.get_node(places[3]).attributes, "name", "hallway"),
        lambda: _move(G, places[3:9], -0.001, 10**18 + 1),
        lambda: setattr(G.get_node(places[3]).attributes, "name", ""),
        lambda: setattr(G.get_node(rooms[0]).attributes, "name", "lab"),
    ]
    reader = GraphReader()
    labels = set()
    for k, edit in enumerate([lambda: None, *edits]):
        edit()
        payload = _payload(G)
        streamed = streamed_equals_alone(payload, 100 + k, reader)
        labels.add(streamed.snapshot.places.labels)
    assert reader.delta_reads >= 3
    assert len(labels) >= 3  # the names did reach the labels


def _with_agents(G: Any, n: int = 4) -> Any:
    """``G`` with a robot's agent nodes (partition 'a' of the agents layer)."""
    import datetime

    import spark_dsg as dsg

    for i in range(n):
        a = dsg.AgentNodeAttributes()
        a.position = np.array([float(i), 1.0, 0.0])
        a.timestamp = datetime.timedelta(microseconds=1000 * (i + 1))
        G.add_node(2, sym("a", i), a, ord("a"))
    return G


def test_snapshots_of_moved_nodes_are_moved_not_made_again(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A payload that moved and re-stamped nodes only (places, rooms, agents) gives the last
    snapshot with the new positions and trajectory, made without a new layer scan; a rename
    or a frontier flag changed makes it again. Every snapshot equals the one read alone."""
    import datetime

    from aion_cli.formats import dsg_fast
    from tests.formats.snapshot_checks import assert_same_snapshot

    made = []
    scan = dsg_fast._navigation

    def counting(*args: Any) -> Any:
        made.append(1)
        return scan(*args)

    monkeypatch.setattr(dsg_fast, "_navigation", counting)
    G = _with_agents(_graph())
    places = _places(G)
    rooms = sorted(n.id.value for n in G.get_layer("ROOMS").nodes)

    def agents_moved() -> None:
        for i in range(2):
            a = G.get_node(sym("a", i)).attributes
            a.position = np.asarray(a.position) + 0.25
            a.timestamp = datetime.timedelta(microseconds=9000 - i)  # reorders the trajectory

    def room_moved() -> None:
        a = G.get_node(rooms[0]).attributes
        a.position = np.asarray(a.position) + 0.5

    steps: list[tuple[Any, bool]] = [
        (lambda: None, False),  # the first graph: made
        (lambda: _move(G, places[:7], 0.003, 10**18), True),
        (agents_moved, True),
        (room_moved, True),
        (lambda: setattr(G.get_node(places[2]).attributes, "name", "lab"), False),
        (lambda: _move(G, places[1:3], -0.002, 10**18 + 5), True),
    ]
    reader = GraphReader()
    parsed_before = 0
    for k, (edit, moved) in enumerate(steps):
        edit()
        payload = _payload(G)
        before = len(made)
        streamed = dsg_fast.fast_navigation(payload, 500 + k, None, reader)
        assert reader.values_only == moved, k
        assert (len(made) == before) == moved, k  # moved: no new scan
        if moved:  # agents (their pose and stamp) and rooms too: read in place
            assert reader.records_parsed == parsed_before, k
        parsed_before = reader.records_parsed
        alone = scan(read_graph(payload), 500 + k, None)[0]
        assert streamed is not None
        assert_same_snapshot(streamed.snapshot, alone.snapshot)
        assert streamed.snapshot.t_ns == 500 + k
        assert streamed.frontiers == alone.frontiers
        assert streamed.snapshot.agents is not None
        assert alone.snapshot.agents is not None
        np.testing.assert_array_equal(streamed.snapshot.agents.t_ns, alone.snapshot.agents.t_ns)
        np.testing.assert_array_equal(streamed.snapshot.agents.xyz, alone.snapshot.agents.xyz)


REAL = ["apartment_dsg.json", "mp3d_x8F5xyUWy9e_dsg.json"]


@pytest.mark.parametrize("name", REAL)
def test_real_hydra_graphs_moved_read_by_changes(name: str) -> None:
    """The real Hydra graphs of ``../shared/data/dsg`` (with their meshes), sent as a stream:
    25 places and a room moved by millimetres and re-stamped, twice in a row, then a place
    renamed. Every graph and every snapshot equals the whole read's; the moves are read by
    changes (the rename too when the new name has the old one's length)."""
    from aion_cli.formats import dsg as fdsg
    from tests.shared_data import SHARED_DATA

    path = SHARED_DATA / "dsg" / name
    if not path.exists():
        pytest.skip(f"{path} not available (real Hydra graphs: ../shared/data/dsg)")
    G = fdsg.read_dsg_file(path).graph
    layer = G.get_layer("MESH_PLACES") if G.has_layer("MESH_PLACES") else G.get_layer("PLACES")
    ids = sorted(n.id.value for n in layer.nodes)
    rooms = sorted(n.id.value for n in G.get_layer("ROOMS").nodes) if G.has_layer("ROOMS") else []
    old_name = G.get_node(ids[0]).attributes.name
    rng = np.random.default_rng(0)
    graphs, snapshots = GraphReader(), GraphReader()
    for k in range(4):
        if k in (1, 2):
            _move(G, rng.choice(ids, min(25, len(ids)), replace=False).tolist(), 0.002, 10**18 + k)
            _move(G, rooms[:1], 0.001, 10**18 + k)
        elif k == 3:
            G.get_node(ids[0]).attributes.name = "x" * len(old_name) if old_name else "lab"
        payload = bytes(G.to_binary(True))
        assert_same_graph(graphs.read(payload), read_graph(payload))
        streamed_equals_alone(payload, 10 + k, snapshots)
    assert graphs.delta_reads == (3 if old_name else 2)
    assert snapshots.delta_reads == graphs.delta_reads
