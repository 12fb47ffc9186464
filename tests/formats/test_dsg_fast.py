"""The numpy reader of DsgUpdate payloads (:mod:`formats.dsg_binary`, :mod:`formats.dsg_fast`)
gives exactly what spark_dsg gives, and hands every payload it does not vouch for to spark_dsg.

Compared with ``formats.dsg.navigation`` of the graph ``spark_dsg.DynamicSceneGraph.from_binary``
decodes: every snapshot array (ids, xyz, parents, labels of places, rooms and buildings, edges,
mesh, agents), the layer chosen and the frontiers left out. On the real Hydra graphs of
``../shared/data/dsg`` (with and without a mesh), on graphs shaped like Hydra output, on
generated graphs covering every attribute type the reader knows (hypothesis), and on damaged
payloads (where the reader must either give spark_dsg's result or step aside).
"""

from __future__ import annotations

import datetime
import itertools
import json
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.engine.types import GraphSnapshot
from aion_cli.errors import MessageDecodeError
from aion_cli.formats import dsg as fdsg
from aion_cli.formats.dsg_binary import read_graph
from aion_cli.formats.dsg_fast import fast_navigation
from tests.formats.dsg_builders import (
    hydra_graph,
    legacy_mesh_graph,
    payload_pair_1_1_2,
    sym,
    tricky_graph,
)
from tests.formats.snapshot_checks import assert_same_snapshot
from tests.shared_data import SHARED_DATA

DATA = SHARED_DATA / "dsg"
REAL = [
    "apartment_dsg.json",
    "mp3d_x8F5xyUWy9e_dsg.json",
    "mp3d_x8F5xyUWy9e_partial_600_dsg.json",
    "apartment_igx_dsg.json",
]
LAYERS: list[str | None] = [None, "PLACES", "MESH_PLACES", "ROOMS", "BUILDINGS", "OBJECTS", "20"]


def _mesh_equal(a: GraphSnapshot, b: GraphSnapshot) -> None:
    assert (a.mesh is None) == (b.mesh is None)
    if a.mesh is not None and b.mesh is not None:
        for name in ("vertices", "faces", "colors"):
            x, y = getattr(a.mesh, name), getattr(b.mesh, name)
            assert x.dtype == y.dtype, name
            assert x.shape == y.shape, name
            np.testing.assert_array_equal(x, y)


def _spark(payload: bytes, layer: str | None) -> Any:
    """spark_dsg's navigation of the payload, or the exception it raises."""
    try:
        return fdsg.navigation(fdsg.read_dsg_payload(payload)[0], 123, layer)
    except Exception as exc:  # any failure: compared below
        return exc


def _assert_same(payload: bytes, layers: list[str | None], expect_fast: bool = True) -> int:
    """For every layer: the fast reader's NavGraph equals spark_dsg's, or (never when
    ``expect_fast``) the fast reader stepped aside. A layer spark_dsg lacks must make the fast
    reader step aside too (spark_dsg then raises the error). Returns the layers compared."""
    compared = 0
    for layer in layers:
        fast = fast_navigation(payload, 123, layer)
        ref = _spark(payload, layer)
        if isinstance(ref, Exception):
            assert fast is None, (layer, ref)
            continue
        if fast is None:
            assert not expect_fast, f"the fast reader stepped aside ({layer})"
            continue
        assert_same_snapshot(fast.snapshot, ref.snapshot)
        _mesh_equal(fast.snapshot, ref.snapshot)
        assert fast.layer == ref.layer
        assert fast.frontiers == ref.frontiers
        compared += 1
    return compared


def _with_mesh(G: Any, n: int = 50, seed: int = 0, colors: bool = True) -> Any:
    import spark_dsg as dsg

    rng = np.random.default_rng(seed)
    m = dsg.Mesh(colors, True, True, seed % 2 == 0)
    v = np.vstack([rng.normal(size=(3, n)) * 10, rng.integers(0, 256, (3, n)) / 255.0])
    m.set_vertices(v)
    m.set_faces(rng.integers(0, n, (3, 2 * n)).astype(np.int32))
    G.mesh = m
    return G


@pytest.mark.parametrize("name", REAL)
def test_real_hydra_graphs(name: str) -> None:
    path = DATA / name
    if not path.exists():
        pytest.skip(f"{path} not available (real Hydra graphs: ../shared/data/dsg)")
    G = fdsg.read_dsg_file(path).graph
    assert _assert_same(G.to_binary(True), LAYERS) >= 4
    assert _assert_same(_with_mesh(G).to_binary(True), [None]) == 1
    assert _assert_same(G.to_binary(False), [None]) == 1


def test_hydra_shaped_graphs() -> None:
    for G in (hydra_graph(), legacy_mesh_graph(), tricky_graph()):
        assert _assert_same(G.to_binary(True), LAYERS) >= 3
        assert _assert_same(_with_mesh(G, colors=False).to_binary(True), [None]) == 1


def test_graphs_that_name_their_own_layers() -> None:
    """Layer keys and names only from the payload (spark_dsg decodes into an empty graph): a
    graph naming one layer FOO, one naming none, one naming PLACES another key."""
    import spark_dsg as dsg

    shapes = [([7], {"FOO": 7}), ([], {}), ([3, 9], {"PLACES": 9, "ROOMS": 3})]
    for keys, names in shapes:
        G = dsg.DynamicSceneGraph(
            [dsg.LayerKey(k) for k in keys], {n: dsg.LayerKey(k) for n, k in names.items()}
        )
        for i in range(6):
            a = dsg.PlaceNodeAttributes()
            a.position = np.array([float(i), 1.0, 2.0])
            G.add_node(7 if keys == [7] else 3 + 6 * (i % 2), sym("p", i), a)
        G.insert_edge(sym("p", 0), sym("p", 2))
        G.insert_edge(sym("p", 1), sym("p", 2))  # a parent across layers 9 > 3
        assert _assert_same(G.to_binary(False), [None, "FOO", "7", "9", "PLACES", "ROOMS"]) >= 2


def test_live_hydra_benchmark_graphs() -> None:
    """The 1 Hz stream of benchmarks/build_logs.py (every payload different)."""
    from benchmarks.build_logs import SITE, MovingPayload, places_graph

    xyz, edges = places_graph(*SITE, 400)
    stream = MovingPayload(xyz, edges, moved=20)
    for t in range(3):
        assert _assert_same(stream(10**9 * t), [None, "PLACES"]) == 2


# -- generated graphs ------------------------------------------------------------------------
NAMES = st.sampled_from(["", "kitchen", "p(3)", "p3", "R0", "é ünïcode ☃", "a\x00b", "{}"])
META = st.sampled_from([{}, {"k": 1}, {"a": [1, 2.5, "x"], "b": None}, {"é": {"x": True}}])


@st.composite
def graphs(draw: st.DrawFn) -> Any:
    """A spark_dsg graph with nodes of every attribute type the reader knows, in layers and
    partitions (3D and 2D places, objects, rooms, buildings, two robots' agents), names,
    metadata, mesh connections, frontiers, edges within, across and between partitions of
    layers, and maybe a mesh."""
    import spark_dsg as dsg

    G = dsg.DynamicSceneGraph()
    G.add_layer(3, 1, "MESH_PLACES")
    ids: dict[str, list[int]] = {}
    f = st.floats(-1e6, 1e6, allow_nan=False)

    def base(a: Any) -> Any:
        a.position = np.array([draw(f), draw(f), draw(f)])
        a.last_update_time_ns = draw(st.integers(0, 2**63))
        a.is_active = draw(st.booleans())
        if draw(st.booleans()):
            a.metadata.set(draw(META))
        if hasattr(a, "name"):
            a.name = draw(NAMES)
        return a

    def nvi() -> Any:
        v = dsg.NearestVertexInfo()
        v.block = [draw(st.integers(-5, 5)) for _ in range(3)]
        v.voxel_pos = [draw(f) for _ in range(3)]
        v.vertex = draw(st.integers(0, 2**40))
        v.label = draw(st.none() | st.integers(0, 2**32 - 1))
        return v

    def add(kind: str, cat: str, layer: Any, make: Any, n: int, partition: int = 0) -> None:
        for i in range(n):
            nid = sym(cat, draw(st.integers(0, 2**20)) * 8 + i)
            if nid in itertools.chain.from_iterable(ids.values()):
                continue
            if partition:
                G.add_node(layer, nid, make(), partition)
            else:
                G.add_node(layer, nid, make())
            ids.setdefault(kind, []).append(nid)

    def place() -> Any:
        a = base(dsg.PlaceNodeAttributes())
        a.distance = draw(f)
        a.real_place = draw(st.booleans())
        a.voxblox_mesh_connections = [nvi() for _ in range(draw(st.integers(0, 3)))]
        a.pcl_mesh_connections = draw(st.lists(st.integers(0, 2**63), max_size=3))
        a.mesh_vertex_labels = draw(st.lists(st.integers(0, 255), max_size=3))
        a.deformation_connections = draw(st.lists(st.integers(0, 2**63), max_size=2))
        return a

    def place2d() -> Any:
        a = base(dsg.Place2dNodeAttributes())
        a.boundary = [np.array([draw(f), draw(f), 0.0]) for _ in range(draw(st.integers(0, 3)))]
        a.voxblox_mesh_connections = [nvi() for _ in range(draw(st.integers(0, 2)))]
        a.pcl_boundary_connections = draw(st.lists(st.integers(0, 99), max_size=2))
        return a

    def room() -> Any:
        a = base(dsg.RoomNodeAttributes())
        a.semantic_class_probabilities = draw(st.dictionaries(NAMES, f, max_size=3))
        return a

    def obj() -> Any:
        a = base(dsg.ObjectNodeAttributes())
        a.mesh_connections = draw(st.lists(st.integers(0, 2**40), max_size=3))
        a.registered = draw(st.booleans())
        return a

    def agent() -> Any:
        a = base(dsg.AgentNodeAttributes())
        a.timestamp = datetime.timedelta(microseconds=draw(st.integers(-(10**15), 10**15)))
        a.external_key = draw(st.integers(0, 2**63))
        if draw(st.booleans()):
            a.dbow_ids = np.array(draw(st.lists(st.integers(0, 2**32 - 1), max_size=3)), np.uint32)
        return a

    add("places", "p", dsg.DsgLayers.PLACES, place, draw(st.integers(0, 12)))
    add("mesh_places", "P", dsg.LayerKey(3, 1), place2d, draw(st.integers(0, 12)))
    add("objects", "O", dsg.DsgLayers.OBJECTS, obj, draw(st.integers(0, 3)))
    add("rooms", "R", dsg.DsgLayers.ROOMS, room, draw(st.integers(0, 3)))
    add("buildings", "B", dsg.DsgLayers.BUILDINGS, lambda: base(dsg.SemanticNodeAttributes()), 2)
    add("agents", "a", 2, agent, draw(st.integers(0, 5)), partition=ord("a"))
    add("agents_b", "b", 2, agent, draw(st.integers(0, 3)), partition=ord("b"))
    add("plain", "n", 7, lambda: base(dsg.NodeAttributes()), draw(st.integers(0, 2)))
    every = list(itertools.chain.from_iterable(ids.values()))
    if len(every) >= 2:
        pairs = st.tuples(st.sampled_from(every), st.sampled_from(every))
        for a, b in draw(st.lists(pairs, max_size=40)):
            if a != b:
                G.insert_edge(a, b)
    if draw(st.booleans()):
        G.metadata.set(draw(META))
    if draw(st.booleans()):
        _with_mesh(G, draw(st.integers(0, 30)), draw(st.integers(0, 9)), draw(st.booleans()))
    return G


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(graphs())
def test_generated_graphs(G: Any) -> None:
    assert _assert_same(G.to_binary(True), LAYERS) >= 1


# -- payloads the reader must step aside for -------------------------------------------------
def _payload() -> bytes:
    G = _with_mesh(hydra_graph())
    return bytes(G.to_binary(True))


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_damaged_payloads_never_differ(data: st.DataObject) -> None:
    """A byte changed, a run cut out or the end cut off: the fast reader gives spark_dsg's
    result or steps aside (spark_dsg then decodes, or raises)."""
    payload = bytearray(_PAYLOAD)
    n = len(payload)
    how = data.draw(st.sampled_from(["flip", "cut", "truncate"]))
    i = data.draw(st.integers(0, n - 1))
    if how == "flip":
        payload[i] = data.draw(st.integers(0, 255))
    elif how == "cut":
        del payload[i : i + data.draw(st.integers(1, 40))]
    else:
        del payload[i:]
    _assert_same(bytes(payload), [None], expect_fast=False)


_PAYLOAD = _payload()


def test_outside_the_reader_steps_aside() -> None:
    import spark_dsg as dsg

    good = _PAYLOAD
    assert read_graph(good) is not None
    # trailing bytes (spark_dsg ignores them), a cut-off mesh, an unknown attribute type
    assert read_graph(good + b"\x00") is None
    assert read_graph(good[:-3]) is None
    G = dsg.DynamicSceneGraph()
    G.add_node(dsg.DsgLayers.PLACES, sym("p", 1), dsg.TraversabilityNodeAttributes())
    assert read_graph(G.to_binary(False)) is None
    # metadata nlohmann refuses: the graph's (spark_dsg warns), a node's (spark_dsg throws)
    meta = b"\xdd\x02\x00\x00\x00{}"
    i = good.index(meta)
    bad = good[:i] + b"\xdd\x02\x00\x00\x00{x" + good[i + 7 :]
    assert read_graph(bad) is None
    i = good.index(meta, i + 7)
    bad = good[:i] + b"\xdd\x02\x00\x00\x00{x" + good[i + 7 :]
    assert read_graph(bad) is None
    with pytest.raises(MessageDecodeError):
        fdsg.decode_dsg(bad, 0)
    # the layout of spark_dsg 1.1.2 (no anti_frontier): spark_dsg's versioned fallback reads it
    new, old = payload_pair_1_1_2()
    assert read_graph(new) is not None
    assert read_graph(old) is None
    assert fdsg.decode_dsg(old, 1).version == "1.1.2"


def test_self_edge_steps_aside() -> None:
    """spark_dsg refuses a self-edge with a warning on stderr: left to it."""
    import spark_dsg as dsg

    G = dsg.DynamicSceneGraph()
    for i in range(2):
        G.add_node(dsg.DsgLayers.PLACES, sym("p", i), dsg.PlaceNodeAttributes())
    G.insert_edge(sym("p", 0), sym("p", 1))
    payload = bytes(G.to_binary(False))
    target = (sym("p", 1)).to_bytes(8, "little")
    source = (sym("p", 0)).to_bytes(8, "little")
    j = payload.rindex(b"\xcf" + target)
    assert payload[j - 9 : j] == b"\xcf" + source
    looped = payload[: j + 1] + source + payload[j + 9 :]
    assert read_graph(payload) is not None
    assert read_graph(looped) is None


def test_agent_stamps_truncate_like_spark() -> None:
    """Agent timestamps below a microsecond (spark_dsg hands out a ``timedelta``): truncated
    toward zero, negative ones too."""
    import spark_dsg as dsg

    G = dsg.DynamicSceneGraph()
    stamps = [1_234_567, -1_500, -2_000, 999, -1, 10**15 + 7]
    for i in range(len(stamps)):
        a = dsg.AgentNodeAttributes()
        a.position = np.array([float(i), 0.0, 0.0])
        a.timestamp = datetime.timedelta(microseconds=i + 1)
        G.add_node(2, sym("a", i), a, ord("a"))
    payload = bytearray(G.to_binary(False))
    for i, ns in enumerate(stamps):
        old = b"\xd3" + ((i + 1) * 1000).to_bytes(8, "little", signed=True)
        assert payload.count(old) == 1
        k = payload.index(old)
        payload[k + 1 : k + 9] = ns.to_bytes(8, "little", signed=True)
    fast = fast_navigation(bytes(payload), 0, None)
    assert fast is not None
    assert fast.snapshot.agents is not None
    assert _assert_same(bytes(payload), [None]) == 1
    assert sorted(fast.snapshot.agents.t_ns.tolist()) == sorted(
        int(ns / 1000) * 1000 for ns in stamps
    )


@pytest.mark.parametrize("version", [None, "1.1.3"])
def test_decode_dsg_fast_equals_spark(version: str | None) -> None:
    for payload in (_PAYLOAD, hydra_graph().to_binary(False)):
        a = fdsg.decode_dsg(payload, 5, version)
        b = fdsg.decode_dsg(payload, 5, version, fast=False)
        assert_same_snapshot(a.snapshot, b.snapshot)
        _mesh_equal(a.snapshot, b.snapshot)
        assert (a.version, a.layer) == (b.version, b.layer)
    with pytest.raises(fdsg.GraphLayerError, match="no layer named NOPE"):
        fdsg.decode_dsg(_PAYLOAD, 5, layer="NOPE")


def test_metadata_texts() -> None:
    from aion_cli.formats.dsg_binary import _json_ok

    assert _json_ok({b"{}", b'{"a": [1, 2.5]}', json.dumps({"é": 1}, ensure_ascii=False).encode()})
    for bad in (b"", b"{x", b"NaN", b'{"a": Infinity}', b'"\\ud800"', b"\xff"):
        assert not _json_ok({bad})


def test_fields_read_keep_the_messages_recording() -> None:
    """A graph message the stream checked as a whole update (``aion_cli.graph_thin``) goes on
    with its fields read, and with the recording it came from (``RawMessage.recording``):
    before, it came on as recording 0, so a build of robots at once could not tell whose
    graph it was (:mod:`aion_cli.session_graphs`)."""
    from aion_cli.formats.dsg_update_fast import DsgUpdateFields, FieldsRead
    from aion_cli.formats.raw import from_recording, raw_message

    fields = DsgUpdateFields(1, 2, memoryview(b"\x00"))
    for recording in (0, 1, 3):
        msg = raw_message("/hydra/backend/dsg", "hydra_msgs/msg/DsgUpdate", 5, b"", "cdr")
        read = FieldsRead.of(from_recording(msg, recording), fields)
        assert read.recording == recording
        assert read.fields is fields
