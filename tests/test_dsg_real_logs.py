"""The real Hydra graphs put into logs as ``hydra_msgs/DsgUpdate`` messages, as Hydra publishes
them (the whole graph, mesh included, ``full_update`` true), with aion's own log writer: a
build of the log must take the graph the file holds. Each map's graph is checked against the
file's JSON (:mod:`tests.dsg_real_files`, read with :mod:`json` alone) and against a build of
the same detections with ``--graph FILE``: every ``graph_*`` member equal. All four files in
ROS 2 MCAP; the apartment also in a ROS 1 bag, a ROS 1 MCAP and a rosbag2 (SQLite) folder."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.engine.state import MapState
from aion_cli.formats import dsg as fdsg
from aion_cli.formats.mapfile import read_map
from aion_cli.formats.writers import LogWriter
from aion_cli.pipeline import BuildOptions, build_map
from tests.dsg_real_files import FILES, assert_reads_the_file, from_json
from tests.shared_data import real

S = 10**9
T0 = 1_767_607_200 * S  # 2026-01-05 10:00 UTC


def _write_log(
    path: Path, payload: bytes | None, people: np.ndarray, container: str = "mcap"
) -> Path:
    """40 s: people standing at ``people`` every second (map frame), the robot at the origin
    in TF every 5 s, and the graph (when ``payload``) every 10 s on Hydra's backend topic."""
    with LogWriter(path, container) as writer:
        for s in range(40):
            t = T0 + s * S
            if payload is not None and s % 10 == 0:
                writer.write(
                    "/hydra/backend/dsg",
                    "hydra_msgs/msg/DsgUpdate",
                    {
                        "header": {"stamp": {"sec": t // S}, "frame_id": "map"},
                        "layer_contents": np.frombuffer(payload, np.uint8),
                        "full_update": True,
                    },
                    t,
                )
            if s % 5 == 0:
                tf = {
                    "header": {"stamp": {"sec": t // S}, "frame_id": "map"},
                    "child_frame_id": "base_link",
                    "transform": {"translation": {"x": 0.0}, "rotation": {"w": 1.0}},
                }
                writer.write("/tf", "tf2_msgs/msg/TFMessage", {"transforms": [tf]}, t)
            tracks = [
                {
                    "track_id": k + 1,
                    "is_matched": True,
                    "pose": {
                        "pose": {
                            "position": {"x": float(x), "y": float(y), "z": float(z)},
                            "orientation": {"w": 1.0},
                        }
                    },
                }
                for k, (x, y, z) in enumerate(people)
            ]
            stamp = {"sec": (t + S // 2) // S, "nanosec": S // 2}
            writer.write(
                "/tracks",
                "spencer_tracking_msgs/msg/TrackedPersons",
                {"header": {"stamp": stamp, "frame_id": "map"}, "tracks": tracks},
                t + S // 2,
            )
    return path


def _graph_members(path: Path) -> tuple[dict[str, np.ndarray], Any]:
    arrays, manifest = read_map(path)
    graph = MapState.from_arrays(arrays, manifest["state"]).graph
    return {k: v for k, v in arrays.items() if k.startswith("graph_")}, graph


def _check_round_trip(path: Path, tmp_path: Path, container: str = "mcap") -> None:
    """The graph of ``path`` in a DsgUpdate log builds as the file (and its JSON) does."""
    want = from_json(path)
    payload = bytes(fdsg.read_dsg_file(path).graph.to_binary(True))
    people = np.array(sorted(want.places.values())[:3])  # three people at three places
    suffix = {"mcap": ".mcap", "mcap-ros1": ".mcap", "bag": ".bag"}.get(container, "")
    streamed = _write_log(tmp_path / f"stream{suffix}", payload, people, container)
    plain = _write_log(tmp_path / "plain.mcap", None, people)

    every_graph = BuildOptions(logs=(streamed,), output=tmp_path / "a.aion", graph_period_ns=0)
    report = build_map(every_graph)
    assert report.graph_source == "log"
    assert report.graph_messages == 4  # all four graphs applied, none skipped
    assert report.graph_skipped == 0
    build_map(BuildOptions(logs=(plain,), output=tmp_path / "b.aion", graph_file=path))

    members_a, graph_a = _graph_members(tmp_path / "a.aion")
    members_b, _ = _graph_members(tmp_path / "b.aion")
    assert sorted(members_a) == sorted(members_b)
    for key, value in members_a.items():
        assert value.dtype == members_b[key].dtype, key
        np.testing.assert_array_equal(value, members_b[key], err_msg=key)
    assert_reads_the_file(graph_a, want)


@pytest.mark.parametrize("name", FILES)
def test_graph_in_a_dsg_update_log_builds_as_the_file(name: str, tmp_path: Path) -> None:
    _check_round_trip(real("dsg", name), tmp_path)


@pytest.mark.parametrize("container", ["bag", "mcap-ros1", "rosbag2-sqlite3"])
def test_graph_in_ros1_and_rosbag2_logs(container: str, tmp_path: Path) -> None:
    """ROS 1 (bag, ROS 1 MCAP: a header with ``seq``) and rosbag2 logs read back alike."""
    _check_round_trip(real("dsg", "apartment_dsg.json"), tmp_path, container)
