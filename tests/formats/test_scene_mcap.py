"""The scene MCAP writer: read back with mcap's reader and the Foxglove protobuf / mcap-ros2
decoders; sizes, colours, directions and ids from the drawing rules; atomic output."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.SceneEntityDeletion_pb2 import SceneEntityDeletion
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory as ProtobufDecoders
from mcap_ros2.decoder import DecoderFactory as Ros2Decoders
from ruamel.yaml import YAML

from aion_cli.engine.types import Mesh
from aion_cli.formats import msgdefs
from aion_cli.formats.export import ExportError
from aion_cli.formats.outputs import OutputPathError
from aion_cli.formats.scene_markers import marker_array, tf_static
from aion_cli.formats.scene_mcap import (
    LAST_STEP_NS,
    SceneMcapWriter,
    SceneTimeError,
    check_scene_target,
)
from aion_cli.formats.scene_style import SceneStyle, style_scene

DELTA = 0.5
NODES = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [10.0, 0.0, 1.0], [15.0, 0.0, 0.0]])
FLOW = np.array([0.0, 5.0, 10.0, 2.0])
ENTROPY = np.array([np.nan, 0.0, 1.0, 0.5])
ANGLE = np.array([np.nan, 0.0, math.pi / 2, -3 * math.pi / 4])
NODE_IDS = ["p0", "p1", "p2", "p3"]
CELLS = np.array([[1.0, 3.0, 0.0], [2.0, 3.0, 0.0]])
CELL_FLOW = np.array([4.0, 0.0])
CELL_ENTROPY = np.array([0.25, np.nan])
CELL_IDS = ["c11", "c12"]
EDGES = np.stack([NODES[[0, 1, 2]], NODES[[1, 2, 3]]], axis=1)  # [3, 2, 3]
PATH = NODES[[0, 1, 2]]
MESH = Mesh(
    vertices=np.array([[0.0, 0, -1], [1, 0, -1], [0, 1, -1], [1, 1, -1]]),
    faces=np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int32),
    colors=np.array([[1.0, 1, 0], [0, 1, 0], [0, 1, 1], [1, 1, 1]]),
)
T0 = 1_795_420_800_000_000_000  # 2026-11-23 08:00 UTC
STEP = 3_600_000_000_000
GREY = (0.5, 0.5, 0.5)


def scene(flow_scale: float | None = None, path: bool = True) -> SceneStyle:
    return style_scene(
        NODES,
        FLOW,
        ENTROPY,
        ANGLE,
        CELLS,
        CELL_FLOW,
        CELL_ENTROPY,
        EDGES,
        MESH,
        PATH if path else None,
        DELTA,
        flow_scale=flow_scale,
    )


def write(target: Path, steps: int = 3, **kwargs: Any) -> Path:
    with SceneMcapWriter(target, {"map": "test.aion"}) as writer:
        for k in range(steps):
            writer.write_step(T0 + k * STEP, scene(**kwargs), NODE_IDS, CELL_IDS)
    return target


def read(path: Path) -> dict[str, list[tuple[int, Any]]]:
    """Decoded messages per topic, as (log time, message)."""
    out: dict[str, list[tuple[int, Any]]] = {}
    with path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[ProtobufDecoders(), Ros2Decoders()])
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out


def rgb(color: Any) -> tuple[float, float, float]:
    return (color.r, color.g, color.b)


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[tuple[int, Any]]]:
    return read(write(tmp_path_factory.mktemp("mcap") / "scene.mcap"))


def test_topics_schemas_and_one_message_per_step(tmp_path: Path) -> None:
    path = write(tmp_path / "scene.mcap")
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    channels = {c.topic: c for c in summary.channels.values()}
    schemas = {t: summary.schemas[c.schema_id] for t, c in channels.items()}
    assert {t: (s.name, s.encoding) for t, s in schemas.items()} == {
        "/aion/scene": ("foxglove.SceneUpdate", "protobuf"),
        "/aion/markers": ("visualization_msgs/msg/MarkerArray", "ros2msg"),
        "/tf_static": ("tf2_msgs/msg/TFMessage", "ros2msg"),
    }
    qos = YAML(typ="safe").load(channels["/tf_static"].metadata["offered_qos_profiles"])
    assert [(q["durability"], q["reliability"], q["depth"]) for q in qos] == [(1, 1, 1)]  # latched
    assert {t: c.message_encoding for t, c in channels.items()} == {
        "/aion/scene": "protobuf",
        "/aion/markers": "cdr",
        "/tf_static": "cdr",
    }
    assert summary.statistics is not None
    counts = summary.statistics.channel_message_counts
    assert {summary.channels[i].topic: n for i, n in counts.items()} == {
        "/aion/scene": 3,
        "/aion/markers": 3,
        "/tf_static": 1,
    }
    messages = read(path)
    assert [t for t, _ in messages["/aion/scene"]] == [T0, T0 + STEP, T0 + 2 * STEP]
    assert [t for t, _ in messages["/aion/markers"]] == [T0, T0 + STEP, T0 + 2 * STEP]


def test_scene_update_entities_sizes_colours_and_arrows(written: dict[str, Any]) -> None:
    _, update = written["/aion/scene"][0]
    assert [(d.type, d.timestamp.seconds) for d in update.deletions] == [
        (SceneEntityDeletion.ALL, T0 // 10**9)
    ]
    by_id = {e.id: e for e in update.entities}
    assert list(by_id) == [*NODE_IDS, *CELL_IDS, "aion/edges", "aion/path", "aion/mesh"]
    assert {e.frame_id for e in update.entities} == {"map"}
    busy = FLOW / FLOW.max()  # no flow_scale given: the busiest node is drawn at full size
    for i, node in enumerate(NODE_IDS):
        (sphere,) = by_id[node].spheres
        p = sphere.pose.position
        assert (p.x, p.y, p.z) == tuple(NODES[i])
        diameter = 2 * DELTA * (0.2 + 0.8 * busy[i])
        assert sphere.size.x == sphere.size.y == sphere.size.z == pytest.approx(diameter)
        meta = {m.key: m.value for m in by_id[node].metadata}
        assert meta["kind"] == "node"
        assert float(meta["flow"]) == pytest.approx(FLOW[i], rel=1e-3)
    colours = [rgb(by_id[n].spheres[0].color) for n in NODE_IDS]
    assert colours == [GREY, (0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.5, 0.0, 0.5)]
    assert by_id["p0"].arrows == []  # no flow: no arrow
    for i in (1, 2, 3):
        (arrow,) = by_id[NODE_IDS[i]].arrows
        q = arrow.pose.orientation
        yaw = 2 * math.atan2(q.z, q.w)
        assert math.isclose(math.remainder(yaw - ANGLE[i], 2 * math.pi), 0.0, abs_tol=1e-9)
        length = arrow.shaft_length + arrow.head_length
        assert length == pytest.approx(DELTA * (0.2 + 0.8 * busy[i]) + DELTA * (0.3 + 2 * busy[i]))
        assert arrow.shaft_length > arrow.head_length > 0
        assert rgb(arrow.color) == colours[i]


def test_cells_edges_path_and_mesh(written: dict[str, Any]) -> None:
    _, update = written["/aion/scene"][1]
    by_id = {e.id: e for e in update.entities}
    for i, cell in enumerate(CELL_IDS):
        (cube,) = by_id[cell].cubes
        assert (cube.size.x, cube.size.y) == (DELTA, DELTA)
        assert 0 < cube.size.z < 0.05 * DELTA  # flat
        p = cube.pose.position
        assert (p.x, p.y, p.z) == tuple(CELLS[i])
    assert rgb(by_id["c11"].cubes[0].color) == (0.25, 0.0, 0.75)
    assert rgb(by_id["c12"].cubes[0].color) == GREY  # no flow
    (edges,) = by_id["aion/edges"].lines
    assert edges.type == LinePrimitive.LINE_LIST
    np.testing.assert_array_equal([(p.x, p.y, p.z) for p in edges.points], EDGES.reshape(-1, 3))
    (path,) = by_id["aion/path"].lines
    assert path.type == LinePrimitive.LINE_STRIP
    np.testing.assert_array_equal([(p.x, p.y, p.z) for p in path.points], PATH)
    (tri,) = by_id["aion/mesh"].triangles
    np.testing.assert_array_equal([(p.x, p.y, p.z) for p in tri.points], MESH.vertices)
    np.testing.assert_array_equal(list(tri.indices), MESH.faces.reshape(-1))
    np.testing.assert_allclose([rgb(c) for c in tri.colors], MESH.colors)


def test_marker_array_matches_the_scene(written: dict[str, Any]) -> None:
    _, markers = written["/aion/markers"][2]
    first, *rest = markers.markers
    assert first.action == 3  # DELETEALL
    nodes = [m for m in rest if m.ns == "nodes"]
    assert [m.type for m in nodes] == [2] * 4  # SPHERE
    assert [m.id for m in nodes] == [0, 1, 2, 3]
    assert [m.text for m in nodes] == NODE_IDS
    busy = FLOW / FLOW.max()
    np.testing.assert_allclose([m.scale.x for m in nodes], 2 * DELTA * (0.2 + 0.8 * busy))
    np.testing.assert_allclose(
        [(m.color.r, m.color.g, m.color.b) for m in nodes],
        [GREY, (0, 0, 1), (1, 0, 0), (0.5, 0, 0.5)],
    )
    arrows = [m for m in rest if m.ns == "arrows"]
    assert [(m.type, m.id, m.text) for m in arrows] == [(0, i, NODE_IDS[i]) for i in (1, 2, 3)]
    yaws = [2 * math.atan2(m.pose.orientation.z, m.pose.orientation.w) for m in arrows]
    np.testing.assert_allclose(np.cos(yaws), np.cos(ANGLE[1:]), atol=1e-12)
    np.testing.assert_allclose(np.sin(yaws), np.sin(ANGLE[1:]), atol=1e-12)
    lists = {m.ns: m for m in rest if m.ns not in ("nodes", "arrows")}
    assert {ns: m.type for ns, m in lists.items()} == {
        "cells": 6,
        "edges": 5,
        "mesh": 11,
        "path": 4,
    }
    points = {ns: [(p.x, p.y, p.z) for p in m.points] for ns, m in lists.items()}
    np.testing.assert_array_equal(points["cells"], CELLS)
    assert (lists["cells"].scale.x, lists["cells"].scale.y) == (DELTA, DELTA)
    np.testing.assert_allclose(
        [(c.r, c.g, c.b) for c in lists["cells"].colors], [(0.25, 0, 0.75), GREY]
    )
    np.testing.assert_array_equal(points["edges"], EDGES.reshape(-1, 3))
    np.testing.assert_array_equal(points["path"], PATH)
    corners = MESH.faces.reshape(-1)
    np.testing.assert_array_equal(points["mesh"], MESH.vertices[corners])
    np.testing.assert_allclose(
        [(c.r, c.g, c.b) for c in lists["mesh"].colors], MESH.colors[corners], atol=1e-7
    )
    assert {m.header.frame_id for m in markers.markers} == {"map"}
    assert {(m.header.stamp.sec, m.header.stamp.nanosec) for m in markers.markers} == {
        divmod(T0 + 2 * STEP, 10**9)
    }


def test_tf_static_declares_the_map_frame(written: dict[str, Any]) -> None:
    ((t, msg),) = written["/tf_static"]
    assert t == T0
    (tf,) = msg.transforms
    assert (tf.header.frame_id, tf.child_frame_id) == ("world", "map")
    r, v = tf.transform.rotation, tf.transform.translation
    assert (r.x, r.y, r.z, r.w, v.x, v.y, v.z) == (0, 0, 0, 1, 0, 0, 0)


def test_cdr_bytes_are_rosbags_own_serialization() -> None:
    """Our numpy CDR equals what rosbags' serializer makes of the decoded message."""
    store = msgdefs.typestore(2)
    # a map of hash cells only: its cells carry arrows (one here, the cell with flow)
    cells_only = style_scene(
        np.zeros((0, 3)), [], [], [], CELLS, CELL_FLOW, CELL_ENTROPY, cells_dominant_angle=[1, 2]
    )
    assert np.isfinite(cells_only.cell_arrow_angle).sum() == 1
    for payload, msgtype in (
        (marker_array(T0 + 123, scene(), NODE_IDS, CELL_IDS), "visualization_msgs/msg/MarkerArray"),
        (
            marker_array(T0, scene(path=False), NODE_IDS, CELL_IDS),
            "visualization_msgs/msg/MarkerArray",
        ),
        (marker_array(T0, cells_only, [], CELL_IDS), "visualization_msgs/msg/MarkerArray"),
        (tf_static(T0 + 5), "tf2_msgs/msg/TFMessage"),
    ):
        message = store.deserialize_cdr(payload, msgtype)
        assert bytes(store.serialize_cdr(message, msgtype)) == payload


def test_flow_scale_fixes_sizes_across_steps(tmp_path: Path) -> None:
    with write(tmp_path / "s.mcap", 1, flow_scale=20.0).open("rb") as fh:
        ((_, _, message),) = make_reader(fh).iter_messages(topics=["/aion/scene"])
    update = SceneUpdate.FromString(message.data)  # the raw bytes, no MCAP decoder
    sizes = [e.spheres[0].size.x for e in update.entities if e.spheres]
    np.testing.assert_allclose(sizes, 2 * DELTA * (0.2 + 0.8 * FLOW / 20.0))


def test_no_path_no_path_entity(tmp_path: Path) -> None:
    messages = read(write(tmp_path / "s.mcap", 1, path=False))
    ids = [e.id for e in messages["/aion/scene"][0][1].entities]
    assert "aion/path" not in ids
    assert "aion/edges" in ids
    assert "path" not in {m.ns for m in messages["/aion/markers"][0][1].markers}


def test_target_checks(tmp_path: Path) -> None:
    with pytest.raises(OutputPathError, match="is a folder"):
        check_scene_target(tmp_path)
    with pytest.raises(OutputPathError, match=r"\.mcap"):
        check_scene_target(tmp_path / "scene.ply")
    other = tmp_path / "notes.mcap"
    other.write_text("my notes")
    with pytest.raises(OutputPathError, match="not an MCAP scene aion wrote"):
        check_scene_target(other)
    assert other.read_text() == "my notes"
    check_scene_target(write(tmp_path / "old.mcap", 1))  # a scene aion exported may be replaced
    check_scene_target(tmp_path / "new.mcap")
    from aion_cli.formats.writers import LogWriter

    log = tmp_path / "log.mcap"  # a robot log (as convert writes them): never replaced
    with LogWriter(log, "mcap") as writer:
        writer.write("/chatter", "std_msgs/msg/String", {"data": "hi"}, 1)
    with pytest.raises(OutputPathError, match="not an MCAP scene aion wrote"):
        check_scene_target(log)


def test_failure_leaves_the_previous_file_and_no_staging(tmp_path: Path) -> None:
    target = write(tmp_path / "scene.mcap", 2)
    before = target.read_bytes()

    def fail_midway() -> None:
        with SceneMcapWriter(target, {}) as writer:
            writer.write_step(T0, scene(), NODE_IDS, CELL_IDS)
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        fail_midway()
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.mcap"]
    write(target, 1)  # a successful write replaces it
    assert len(read(target)["/aion/scene"]) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.mcap"]


def test_bad_steps_are_typed_errors(tmp_path: Path) -> None:
    with SceneMcapWriter(tmp_path / "s.mcap", {}) as writer:
        with pytest.raises(SceneTimeError, match="1970"):
            writer.write_step(-1, scene(), NODE_IDS, CELL_IDS)
        with pytest.raises(SceneTimeError, match="2038-01-19 03:14:08 UTC"):
            writer.write_step(LAST_STEP_NS + 1, scene(), NODE_IDS, CELL_IDS)
        with pytest.raises(ExportError, match="one id"):
            writer.write_step(T0, scene(), NODE_IDS[:2], CELL_IDS)
        writer.write_step(T0, scene(), NODE_IDS, CELL_IDS)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    from aion_cli.formats.outputs import OutputPathError

    with pytest.raises(OutputPathError, match="is a file, not a folder"):  # before any write
        SceneMcapWriter(blocker / "s.mcap", {})


def test_a_heavy_tail_is_sized_by_its_high_quantile() -> None:
    """29 nodes with flow 1 and an entrance with 100: sized to the busiest, every other sphere
    would be near the smallest; sized to the 95th percentile (the shared rule of pictures and
    scenes, ``display_flow_scale``) they are full size, as is the entrance."""
    from aion_cli.formats.scene_colours import DISPLAY_QUANTILE, display_flow_scale, sphere_radii

    flow = np.r_[np.ones(29), 100.0]
    n = flow.size
    xyz = np.column_stack([np.arange(n, dtype=np.float64), np.zeros(n), np.zeros(n)])
    style = style_scene(xyz, flow, np.full(n, 0.5), np.zeros(n), cell_size=DELTA)
    high = float(np.quantile(flow, DISPLAY_QUANTILE))
    assert display_flow_scale(flow) == (high, 100.0)
    assert style.flow_scale == high
    np.testing.assert_array_equal(style.radii, sphere_radii(np.ones(n), 1.0, DELTA))
    few = style_scene(xyz[:4], np.r_[1.0, 1.0, 1.0, 100.0], np.full(4, 0.5), np.zeros(4),
                      cell_size=DELTA)
    assert few.flow_scale == 100.0  # four entries: no tail to judge, the busiest is full size
