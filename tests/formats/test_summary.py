"""summarize: roles of every kind of topic, counts, time range, JSON form."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from aion_cli.formats.logs import open_logs
from aion_cli.formats.summary import ROLES, detection_types, role_of, summarize
from aion_cli.formats.writers import LogWriter, stamp

T0 = 1_700_000_000_000_000_000  # 2023-11-14T22:13:20Z


def _write(path: Path, container: str) -> Path:
    with LogWriter(path, container) as w:
        tf = {"transforms": [{"header": {"frame_id": "map"}, "child_frame_id": "odom"}]}
        w.write("/tf_static", "tf2_msgs/TFMessage", tf, T0)
        for k in range(5):
            t = T0 + k * 500_000_000
            w.write("/tf", "tf2_msgs/TFMessage", tf, t)
            w.write("/people", "people_msgs/People", {"header": {"stamp": stamp(t)}}, t)
            w.write("/poses", "geometry_msgs/PoseArray", {"header": {"stamp": stamp(t)}}, t)
        for k in range(2):
            dsg = {"header": {"stamp": stamp(T0)}, "layer_contents": b"\x01"}
            w.write("/hydra/backend/dsg", "hydra_msgs/DsgUpdate", dsg, T0 + k * 2_000_000_000)
        w.write("/chatter", "std_msgs/String", {"data": "hi"}, T0 + 1)
    return path


@pytest.mark.parametrize(("container", "name"), [("mcap", "a.mcap"), ("bag", "a.bag")])
def test_summary_roles_counts_and_times(container: str, name: str, tmp_path: Path) -> None:
    path = _write(tmp_path / name, container)
    with open_logs([path]) as logs:
        s = summarize(logs)
    assert s.formats == ["mcap-ros2" if container == "mcap" else "bag"]
    roles = {t.topic: t.role for t in s.topics}
    assert roles == {
        "/chatter": "unsupported",
        "/hydra/backend/dsg": "scene_graph",
        "/people": "detections",
        "/poses": "detections",
        "/tf": "tf",
        "/tf_static": "tf_static",
    }
    counts = {t.topic: t.count for t in s.topics}
    assert counts == {
        "/chatter": 1,
        "/hydra/backend/dsg": 2,
        "/people": 5,
        "/poses": 5,
        "/tf": 5,
        "/tf_static": 1,
    }
    assert s.message_count == 19
    assert s.start_ns == T0
    assert s.end_ns == T0 + 2_000_000_000
    assert s.duration_s == 2.0
    rates = {t.topic: t.rate_hz for t in s.topics}
    assert rates["/people"] == 2.5
    assert rates["/chatter"] is None  # one message has no rate (it was 1 / the log's span)
    assert rates["/tf_static"] is None
    assert [t.topic for t in s.by_role("scene_graph")] == ["/hydra/backend/dsg"]
    assert s.size_bytes == path.stat().st_size
    assert s.files[0].message_count == 19


def test_to_dict_is_json_ready(tmp_path: Path) -> None:
    path = _write(tmp_path / "a.mcap", "mcap")
    with open_logs([path]) as logs:
        s = summarize(logs)
    s.dsg_versions["/hydra/backend/dsg"] = ["1.1.3"]
    d = json.loads(json.dumps(s.to_dict()))
    assert d["formats"] == ["mcap-ros2"]
    assert d["start"] == "2023-11-14T22:13:20.000000Z"
    assert d["end"] == "2023-11-14T22:13:22.000000Z"
    assert d["duration_s"] == 2.0
    assert d["messages"] == 19
    assert d["files"][0]["path"] == str(path)
    assert d["files"][0]["size_bytes"] == path.stat().st_size
    assert d["roles"]["detections"] == ["/people", "/poses"]
    assert d["roles"]["tf_static"] == ["/tf_static"]
    assert set(d["roles"]) == set(ROLES)
    assert d["dsg_versions"] == {"/hydra/backend/dsg": ["1.1.3"]}
    people = next(t for t in d["topics"] if t["topic"] == "/people")
    assert people == {
        "topic": "/people",
        "type": "people_msgs/msg/People",
        "count": 5,
        "role": "detections",
        "encoding": "cdr",
        "rate_hz": 2.5,
        "readable": True,
    }


def test_role_of_spellings_and_extra_detection_types() -> None:
    assert role_of("/any/topic", "hydra_msgs/DsgUpdate") == "scene_graph"
    assert role_of("/robot1/tf_static", "tf2_msgs/TFMessage") == "tf_static"
    assert role_of("/tf", "tf/tfMessage") == "tf"
    assert role_of("/x", "spencer_tracking_msgs/TrackedPersons") == "detections"
    assert role_of("/x", "my_msgs/Humans") == "unsupported"
    assert role_of("/x", "my_msgs/Humans", detections=["my_msgs/msg/Humans"]) == "detections"
    assert "zed_msgs/msg/ObjectsStamped" in detection_types()


def test_summarize_merges_files_and_keeps_warnings(tmp_path: Path) -> None:
    a = _write(tmp_path / "a.mcap", "mcap")
    b = tmp_path / "b.bag"
    with LogWriter(b, "bag"):
        pass
    with open_logs([a, b]) as logs:
        s = summarize(logs, detections=["std_msgs/String"])
    assert s.formats == ["mcap-ros2", "bag"]
    assert s.warnings == [f"{b}: no messages"]
    assert {t.topic: t.role for t in s.topics}["/chatter"] == "detections"
