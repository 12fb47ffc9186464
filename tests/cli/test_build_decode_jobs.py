"""A build decodes its detections in jobs of many scene-graph pieces (issue 15). The map is
the same, array for array and byte for byte, as when every piece is decoded on its own (the
path before: one decode per graph interval), on a log with a scene graph every few seconds
(graphs that move and grow, so a detection mapped with the wrong graph shows),
people with track ids but no velocity (headings by differencing, across graph boundaries),
id-less detections on a second topic (linked), stamps that run back across graphs, and
several decode jobs (``batch_size`` smaller than the log)."""

from __future__ import annotations

import math
import zipfile
from pathlib import Path

import numpy as np
import pytest

from aion_cli.detection_feed import TopicFeeders
from aion_cli.formats.writers import LogWriter, stamp
from aion_cli.pipeline import BuildOptions, build_map

S = 1_000_000_000
T0 = 1_700_006_400 * S  # window- and day-aligned
TRACKED = "spencer_tracking_msgs/msg/TrackedPersons"
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
DSG_UPDATE = "hydra_msgs/msg/DsgUpdate"


def _graph_bytes(k: int) -> bytes:
    """The k-th scene graph: a chain of places that moves and grows from one graph to the
    next, so that which graph a detection is mapped with changes the map."""
    spark_dsg = pytest.importorskip("spark_dsg")
    g = spark_dsg.DynamicSceneGraph()
    n = 8 + k % 5
    for i in range(n):
        a = spark_dsg.PlaceNodeAttributes()
        a.position = np.array([2.0 * (i % 4) + 0.7 * (k % 3), 2.0 * (i // 4), 0.0])
        a.distance = 1.0
        a.real_place = True
        a.last_update_time_ns = T0
        g.add_node(spark_dsg.DsgLayers.PLACES, (ord("p") << 56) + i, a)
    for i in range(n - 1):
        info = spark_dsg.EdgeAttributes()
        info.weight = 1.0
        g.insert_edge((ord("p") << 56) + i, (ord("p") << 56) + i + 1, info)
    return bytes(g.to_binary(False))


def _write_log(path: Path, seed: int) -> None:
    rng = np.random.default_rng(seed)
    graphs = [_graph_bytes(k) for k in range(15)]
    per = 4
    start = rng.uniform(0, 6, (per, 2))
    heading = rng.uniform(-math.pi, math.pi, per)
    speed = np.array([1.0, 0.3, 0.02, 0.0])
    with LogWriter(path, "mcap") as w:
        for i in range(3000):  # 5 minutes at 10 Hz
            t = T0 + 60 * S + i * S // 10
            if i % 37 == 0:
                w.write("/dsg", DSG_UPDATE, {
                    "header": {"stamp": stamp(t), "frame_id": "map"},
                    "layer_contents": graphs[i // 37 % 15], "full_update": True,
                    "sequence_number": i,
                }, t)
            d = speed * (i / 10) % 6.0
            xy = start + np.stack([d * np.cos(heading), d * np.sin(heading)], 1)
            xy += rng.normal(0, 0.01, xy.shape)
            st = t - (int(rng.integers(1, 6)) * S // 10 if rng.random() < 0.2 else 0)
            tracks = [{
                "track_id": k + 100 * (i // 400),
                "pose": {"pose": {"position": {"x": x, "y": y, "z": 0.0},
                                  "orientation": {"w": 1.0}},
                         "covariance": [0.0] * 35 + [1e6]},
                "twist": {"covariance": [1e6] * 36},
            } for k, (x, y) in enumerate(xy.tolist()) if rng.random() < 0.9]
            w.write("/tracks", TRACKED, {"header": {"stamp": stamp(st), "frame_id": "map"},
                                         "tracks": tracks}, t)
            if i % 2:
                poses = [{"position": {"x": x + 0.5, "y": y}} for x, y in xy[:2].tolist()]
                w.write("/legs", POSE_ARRAY, {"header": {"stamp": stamp(st), "frame_id": "map"},
                                              "poses": poses}, t + 1)


def _members(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n) for n in z.namelist() if n.endswith(".npy")}


@pytest.mark.parametrize("batch_size", [4000, 700])
def test_decoding_in_jobs_gives_the_map_of_decoding_piece_by_piece(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, batch_size: int
) -> None:
    log = tmp_path / "graphs.mcap"
    _write_log(log, 3)

    def build(name: str) -> tuple[dict[str, bytes], object]:
        out = tmp_path / name
        opts = BuildOptions(logs=(log,), output=out, batch_size=batch_size, graph_period_ns=0)
        report = build_map(opts)
        return _members(out), report

    jobs, r_jobs = build("jobs.aion")
    with monkeypatch.context() as m:
        m.delattr(TopicFeeders, "decode_segments")  # decoded_chunks: one decode per piece
        pieces, r_pieces = build("pieces.aion")
    assert jobs.keys() == pieces.keys()
    differ = [name for name in jobs if jobs[name] != pieces[name]]
    assert differ == []
    for key in ("detections_read", "detections_used", "dropped", "headings", "graph_messages"):
        assert getattr(r_jobs, key) == getattr(r_pieces, key), key
    headings = r_jobs.headings  # type: ignore[attr-defined]
    assert headings["track"] > 1000  # differenced across graph boundaries
    assert headings["linked"] > 100  # the id-less topic linked
    assert r_jobs.graph_messages > 50  # type: ignore[attr-defined]
