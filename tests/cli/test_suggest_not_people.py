"""``aion info LOG --suggest-mapping /tf`` wrote a mapping that read every TF transform (the
robot's own among them) as a person, exit 0. Types that clearly hold no detections of people
(TF, a Hydra scene graph, images, point clouds and other raw sensor data) are refused now,
one line and a hint that lists the topics of the log that look like detections."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.writers import LogWriter, stamp
from tests.cli.conftest import assert_one_line_error, run

T0 = 1_700_000_000_000_000_000


def _header(t: int) -> dict[str, object]:
    return {"stamp": stamp(t), "frame_id": "map"}


def _write(path: Path, people: bool = True) -> Path:
    """TF, a scene graph, an image and a point cloud; with ``people``, also a people topic, a
    generic PoseStamped on a name that does not suggest people, and odometry (a position a
    mapping can read)."""
    with LogWriter(path, "mcap") as w:
        for k in range(3):
            t = T0 + k * 10**9
            w.write("/tf", "tf2_msgs/TFMessage", {"transforms": [
                {"header": _header(t), "child_frame_id": "base_link"}]}, t)
            w.write("/hydra/backend/dsg", "hydra_msgs/DsgUpdate",
                    {"header": _header(t), "layer_contents": b"\x00"}, t)
            w.write("/camera/image", "sensor_msgs/Image",
                    {"header": _header(t), "height": 1, "width": 1, "encoding": "mono8",
                     "step": 1, "data": b"\x00"}, t)
            w.write("/points", "sensor_msgs/PointCloud2", {"header": _header(t)}, t)
            if people:
                w.write("/people", "people_msgs/People", {"header": _header(t), "people": [
                    {"name": "a", "position": {"x": 1.0, "y": 2.0}}]}, t)
                w.write("/goal", "geometry_msgs/PoseStamped", {"header": _header(t)}, t)
                w.write("/odom", "nav_msgs/Odometry", {"header": _header(t)}, t)
    return path


@pytest.mark.parametrize(
    ("topic", "what"),
    [
        ("/tf", "tf2_msgs/msg/TFMessage holds TF transforms"),
        ("/hydra/backend/dsg", "hydra_msgs/msg/DsgUpdate holds a scene graph"),
        ("/camera/image", "sensor_msgs/msg/Image holds raw sensor data"),
        ("/points", "sensor_msgs/msg/PointCloud2 holds raw sensor data"),
    ],
)
def test_no_mapping_for_a_type_that_holds_no_people(tmp_path: Path, topic: str, what: str) -> None:
    log = _write(tmp_path / "robot.mcap")
    result = run("info", log, "--suggest-mapping", topic)
    assert result.exit_code == 2, result.stdout
    assert result.stdout == ""  # no mapping printed
    assert_one_line_error(result.stderr, f"{topic}: {what}", "not detections of people")
    (hint,) = [line for line in result.stderr.splitlines() if line.startswith("hint: ")]
    # the people type first, then the generic one, then a type a mapping can read
    assert hint.startswith(
        "hint: topics that look like detections of people: /people (people_msgs/msg/People), "
        "/goal (geometry_msgs/msg/PoseStamped), /odom (nav_msgs/msg/Odometry)"
    ), hint
    for other in ("/tf ", "/hydra", "/camera", "/points"):
        assert other not in hint


def test_without_a_candidate_the_hint_says_so(tmp_path: Path) -> None:
    log = _write(tmp_path / "sensors.mcap", people=False)
    result = run("info", log, "--suggest-mapping", "/tf")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "not detections of people")
    assert "hint: no topic of the log looks like detections of people" in result.stderr


def test_a_topic_that_may_hold_people_still_gets_its_mapping(tmp_path: Path) -> None:
    log = _write(tmp_path / "robot.mcap")
    result = run("info", log, "--suggest-mapping", "/odom")
    assert result.exit_code == 0, result.stderr
    assert 'topic = "/odom"' in result.stdout
