"""Every built-in people type, written into a log of some container and built back: two people
walking known straight lines in the ``odom`` frame (a static ``map -> odom`` 10 m along x),
ids as integers, strings or UUIDs, empty messages and one NaN position among them. The build
reads every item written, drops only the NaN one (and says only that), takes its headings
from the source the type carries, and puts every detection on the lines in the map frame."""

from __future__ import annotations

import math
import uuid
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.cli.conftest import map_cells, run_json

S = 1_000_000_000
T0 = 1_767_600_000 * S
MESSAGES = 40  # at 2 Hz
EMPTY_EVERY = 10  # messages k = 3, 13, 23, 33 hold nobody
NAN_AT = 20  # one more item with x = NaN
ODOM_X = 10.0  # map -> odom


def _pt(x: float, y: float) -> dict[str, float]:
    return {"x": x, "y": y, "z": 0.0}


def _item(kind: str, pid: int, x: float, y: float, vx: float, vy: float, ros: int) -> Any:
    """One person of ``kind``'s array element, at (x, y) moving (vx, vy), id ``pid``."""
    pose = {"position": _pt(x, y), "orientation": {"w": 1.0}}
    if kind == "TrackedPersons":
        twist = {"twist": {"linear": _pt(vx, vy)}}
        return {"track_id": pid, "pose": {"pose": pose}, "twist": twist}
    if kind == "DetectedPersons":
        return {"detection_id": pid, "confidence": 0.9, "pose": {"pose": pose}}
    if kind == "People":
        return {"name": f"person_{pid}", "position": _pt(x, y), "velocity": _pt(vx, vy)}
    if kind == "PositionMeasurementArray":
        return {"name": "legs", "object_id": f"person {pid}", "pos": _pt(x, y)}
    if kind == "PersonArray":
        return {"pose": pose, "id": pid}
    if kind == "AgentStates":
        return {"id": pid, "pose": pose, "twist": {"linear": _pt(vx, vy)}}
    if kind == "ObstacleArray":
        uid = list(uuid.UUID(int=pid).bytes)
        return {"uuid": {"uuid": uid}, "position": _pt(x, y), "velocity": _pt(vx, vy)}
    if kind == "Detection3DArray":
        if ros == 1:  # noetic: an int64 class id, no track id
            return {"results": [{"id": 1, "score": 0.9}], "bbox": {"center": pose}}
        hypothesis = {"hypothesis": {"class_id": "person", "score": 0.9}}
        return {"results": [hypothesis], "bbox": {"center": pose}, "id": f"track-{pid}"}
    if kind == "ObjectsStamped":
        obj = {"label": "Person", "label_id": pid, "position": [x, y, 0.0],
               "velocity": [vx, vy, 0.0], "tracking_available": True}  # fmt: skip
        if ros == 1:
            obj["instance_id"] = pid
        return obj
    assert kind == "PoseArray", kind
    return pose


ARRAYS = {
    "TrackedPersons": "tracks", "DetectedPersons": "detections", "People": "people",
    "PositionMeasurementArray": "people", "PersonArray": "people", "AgentStates": "agent_states",
    "ObstacleArray": "obstacles", "Detection3DArray": "detections", "ObjectsStamped": "objects",
    "PoseArray": "poses",
}  # fmt: skip
#: items with a header of their own
ITEM_HEADERS = ("PositionMeasurementArray", "AgentStates")


def write_log(path: Path, msgtype: str, container: str, topics: int) -> int:
    """The log; returns the number of items written (the NaN one included)."""
    from aion_cli.formats.writers import LogWriter

    kind = msgtype.rsplit("/", 1)[1]
    ros = 1 if container in ("bag", "mcap-ros1") else 2
    written = 0
    with LogWriter(path, container) as w:
        transform = {"translation": _pt(ODOM_X, 0.0), "rotation": {"w": 1.0}}
        stamp0 = {"sec": T0 // S, "nanosec": 0}
        tf = {"header": {"stamp": stamp0, "frame_id": "map"}, "child_frame_id": "odom",
              "transform": transform}  # fmt: skip
        w.write("/tf_static", "tf2_msgs/msg/TFMessage", {"transforms": [tf]}, T0)
        for k in range(MESSAGES):
            t = T0 + k * S // 2
            header = {"stamp": {"sec": t // S, "nanosec": t % S}, "frame_id": "odom"}
            for n in range(topics):
                people = [(1 + 10 * n, 0.5 * k, 0.0, 1.0, 0.0),
                          (2 + 10 * n, 0.0, 5.0 + 0.4 * k, 0.0, 0.8)]  # fmt: skip
                if k % EMPTY_EVERY == 3:
                    people = []
                if k == NAN_AT:
                    people.append((99, math.nan, 1.0, 0.0, 0.0))
                items = [_item(kind, *p, ros=ros) for p in people]
                if kind in ITEM_HEADERS:
                    items = [{**item, "header": header} for item in items]
                written += len(items)
                topic = f"/people_tracker/out{n}"
                w.write(topic, msgtype, {"header": header, ARRAYS[kind]: items}, t)
    return written


#: (type, container, topics, heading source): every type in some container, every container
CASES = [
    ("spencer_tracking_msgs/msg/TrackedPersons", "bag", 1, "velocity"),
    ("spencer_tracking_msgs/msg/DetectedPersons", "mcap", 1, "linked"),
    ("people_msgs/msg/People", "rosbag2-sqlite3", 2, "velocity"),
    ("people_msgs/msg/PositionMeasurementArray", "mcap-ros1", 1, "track"),
    ("leg_tracker/msg/PersonArray", "rosbag2-mcap", 1, "track"),
    ("pedsim_msgs/msg/AgentStates", "mcap", 1, "velocity"),
    ("nav2_dynamic_msgs/msg/ObstacleArray", "rosbag2-sqlite3", 1, "velocity"),
    ("vision_msgs/msg/Detection3DArray", "mcap", 2, "track"),
    ("vision_msgs/msg/Detection3DArray", "bag", 1, "linked"),
    ("zed_interfaces/msg/ObjectsStamped", "bag", 1, "velocity"),
    ("zed_msgs/msg/ObjectsStamped", "rosbag2-mcap", 1, "velocity"),
    ("geometry_msgs/msg/PoseArray", "rosbag2-sqlite3", 1, "linked"),
]


@pytest.mark.parametrize(("msgtype", "container", "topics", "heading"), CASES)
def test_each_type_is_read_back_in_the_map_frame(
    msgtype: str, container: str, topics: int, heading: str, tmp_path: Path
) -> None:
    log = tmp_path / ("log.bag" if container == "bag" else
                      "log" if container.startswith("rosbag2") else "log.mcap")  # fmt: skip
    written = write_log(log, msgtype, container, topics)
    out = tmp_path / "m.aion"
    report = run_json("build", log, "-o", out, "--format", "json")
    used = written - topics  # the NaN item of each topic
    assert report["detections"] == {"read": written, "used": used, "dropped": {"nan": topics}}
    for n in range(topics):
        per_topic = report["detections_by_topic"][f"/people_tracker/out{n}"]
        assert per_topic == {"read": written // topics, "used": used // topics,
                             "dropped": {"nan": 1}}  # fmt: skip
    headings = report["headings"]
    assert sum(headings.values()) == used
    # a track's first row has no earlier one to difference: two people per topic
    expected = used - 2 * topics if heading == "track" else used
    assert headings[heading] == expected, headings
    assert report["mean_speed_m_s"] == pytest.approx(0.9, abs=0.02)  # 1.0 and 0.8 m/s walkers

    xy, counts, nodir = map_cells(out)
    assert counts.sum() + nodir.sum() == used
    # on person 1's line (y = 0, map x from 10) or person 2's (map x = 10, y from 5), 0.5 m cells
    on_first = (np.abs(xy[:, 1]) <= 0.5) & (xy[:, 0] >= ODOM_X - 0.5)
    on_second = (np.abs(xy[:, 0] - ODOM_X) <= 0.5) & (xy[:, 1] >= 4.5)
    assert (on_first | on_second).all(), xy[~(on_first | on_second)]
    assert xy[:, 0].max() == pytest.approx(ODOM_X + 0.5 * (MESSAGES - 1), abs=0.5)
    assert xy[:, 1].max() == pytest.approx(5.0 + 0.4 * (MESSAGES - 1), abs=0.5)
