"""Scene graphs that wait behind the heading hold keep one mesh, not one each.

Id-less detections (``geometry_msgs/PoseArray``) are linked into tracks and a track's first
rows wait for its first displacement, up to 5 s for a person standing still; a scene graph
that comes meanwhile waits behind them, decoded (``aion_cli.build_stream``). With
``--graph-period 0`` a 10 Hz Hydra stream then had ~50 decoded graphs waiting, each with its
own mesh (a 30,000-vertex mesh: 121 MB). Only the map's last graph's mesh is kept, so a graph
waiting behind a later one drops its mesh: the map is the same as from a log whose graphs
carry no mesh but the last one.

The log: one person standing at (5, 5) and one walking along y = 1 (10 Hz, frame ``map``,
for 8 s), the office graph 10 times a second with place p0 drifting 1 mm per graph (every
payload differs, so every graph is decoded) and a mesh of :data:`VERTICES` vertices, one of
which moves 1 mm per graph too (a graph whose mesh did not change shares its predecessor's,
``formats.dsg_delta``).
"""

from __future__ import annotations

import weakref
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.mapper import Mapper
from aion_cli.engine.types import Mesh
from aion_cli.formats.mapfile import read_map
from aion_cli.graph_feed import GraphFeed
from tests.cli.logdata import T0, S, build_graph
from tests.graph_stream_logs import assert_same_map, build_log

SECONDS = 8
VERTICES = 300


def _mesh_arrays() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    vertices = np.vstack([rng.uniform(0, 20, (3, VERTICES)), rng.uniform(0, 1, (3, VERTICES))])
    return vertices, rng.integers(0, VERTICES, (3, 2 * VERTICES)).astype(np.int32)


def write_log(path: Path, mesh_on_last_only: bool = False) -> Path:
    import spark_dsg

    from aion_cli.formats.writers import LogWriter

    graph = build_graph()
    vertices, faces = _mesh_arrays()
    n = SECONDS * 10
    with LogWriter(path, "mcap") as writer:
        for k in range(n):
            t = T0 + k * S // 10
            stamp = {"sec": t // S, "nanosec": t % S}
            graph.get_node(spark_dsg.NodeSymbol("p", 0)).attributes.position = np.array(
                [0.001 * k, 0.0, 0.0]
            )
            with_mesh = not mesh_on_last_only or k == n - 1
            if with_mesh:
                vertices[2, 0] = 0.001 * k  # the mesh changes too (a Hydra mesh grows)
                mesh = spark_dsg.Mesh()
                mesh.set_vertices(vertices)
                mesh.set_faces(faces)
                graph.mesh = mesh
            payload = graph.to_binary(with_mesh)
            writer.write(
                "/hydra/backend/dsg",
                "hydra_msgs/msg/DsgUpdate",
                {
                    "header": {"stamp": stamp, "frame_id": "map"},
                    "layer_contents": np.frombuffer(payload, np.uint8),
                    "full_update": True,
                },
                t,
            )
            t += S // 20
            poses = [(5.0, 5.0), (1.0 + 1.0 * k / 10, 1.0)]
            writer.write(
                "/people_tracker/pose_array",
                "geometry_msgs/msg/PoseArray",
                {
                    "header": {"stamp": {"sec": t // S, "nanosec": t % S}, "frame_id": "map"},
                    "poses": [
                        {"position": {"x": x, "y": y, "z": 0.0}, "orientation": {"w": 1.0}}
                        for x, y in poses
                    ],
                },
                t,
            )
    return path


def test_graphs_waiting_behind_the_hold_keep_one_mesh(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    live: list[weakref.ref[Mesh]] = []  # every decoded mesh (a Mesh hashes no arrays)
    most = [0]
    decode, add_graph = GraphFeed.decode, Mapper.add_graph

    def spied_decode(self: GraphFeed, *args: object) -> object:
        snapshot = decode(self, *args)
        if snapshot.mesh is not None:
            live.append(weakref.ref(snapshot.mesh))
        return snapshot

    def spied_add_graph(self: Mapper, snapshot: object) -> None:
        alive = {id(m) for ref in live if (m := ref()) is not None}
        most[0] = max(most[0], len(alive))
        add_graph(self, snapshot)  # type: ignore[arg-type]

    monkeypatch.setattr(GraphFeed, "decode", spied_decode)
    monkeypatch.setattr(Mapper, "add_graph", spied_add_graph)
    log = write_log(tmp_path / "every.mcap")
    report = build_log(log, tmp_path / "every.aion", graph_period_ns=0)
    assert report.graph_messages == report.graph_decoded == SECONDS * 10
    # the newest graph waiting (also the feed's last decode) and the map's graph: without the
    # bound, every graph waiting behind the standing person's rows kept its mesh (~50)
    assert most[0] <= 2
    monkeypatch.undo()
    reference = write_log(tmp_path / "last.mcap", mesh_on_last_only=True)
    build_log(reference, tmp_path / "last.aion", graph_period_ns=0)
    assert_same_map(tmp_path / "every.aion", tmp_path / "last.aion")
    arrays, _ = read_map(tmp_path / "every.aion")
    vertices, faces = _mesh_arrays()
    vertices[2, 0] = 0.001 * (SECONDS * 10 - 1)  # the last graph's
    np.testing.assert_allclose(arrays["graph_mesh_vertices"], vertices[:3].T, rtol=1e-6)
    np.testing.assert_array_equal(arrays["graph_mesh_faces"], faces.T)
