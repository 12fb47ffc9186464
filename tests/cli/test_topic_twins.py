"""Two detection topics of one log that hold the same people (a second tracker of the same
sensor, as ``write_office_log(second_topic=...)`` writes) are all used, so each person counts
once per topic: ``aion build`` and ``aion info`` warn, naming both and how to build from one.
Topics of other people at the same times, or one topic named, do not warn."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tests.cli.conftest import run_json
from tests.cli.logdata import write_office_log

S = 1_000_000_000
T0 = 1_767_600_000 * S
TWINS = "hold the same people at the same times and places"


def _twin_warnings(report: dict[str, Any]) -> list[str]:
    return [w for w in report["warnings"] if TWINS in w]


def test_two_topics_of_the_same_people_warn_that_they_count_twice(tmp_path: Path) -> None:
    log = tmp_path / "two.mcap"
    expected = write_office_log(log, second_topic="/tracks_fused")
    report = run_json("build", log, "--format", "json")
    assert report["detections"]["used"] == 2 * expected.detections  # both used, as before
    (warning,) = _twin_warnings(report)
    assert warning.startswith(f"/tracks and /tracks_fused {TWINS} (100% of one's"), warning
    assert "counts twice; build from one of them with --detections-topic /tracks" in warning
    info = run_json("info", log, "--format", "json")
    assert _twin_warnings(info) == [warning]
    one = run_json("build", log, "--detections-topic", "/tracks", "-o", tmp_path / "one.aion",
                   "--format", "json")  # fmt: skip
    assert one["detections"]["used"] == expected.detections
    assert _twin_warnings(one) == []


def test_two_topics_of_other_people_at_the_same_times_do_not_warn(tmp_path: Path) -> None:
    from aion_cli.formats.writers import LogWriter

    log = tmp_path / "apart.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(40):
            t = T0 + k * S // 2
            header = {"stamp": {"sec": t // S, "nanosec": t % S}, "frame_id": "map"}
            for topic, y in (("/left/people", 0.0), ("/right/people", 6.0)):
                pose = {"position": {"x": 0.5 * k, "y": y}, "orientation": {"w": 1.0}}
                message = {"header": header, "poses": [pose]}
                w.write(topic, "geometry_msgs/msg/PoseArray", message, t)
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--format", "json")
    assert report["detection_topics"] == ["/left/people", "/right/people"]
    assert report["detections"]["used"] == 80
    assert _twin_warnings(report) == []


def test_topics_sharing_under_two_seconds_name_the_finer_tolerance(tmp_path: Path) -> None:
    """Two topics of one person walking at 3 m/s, the same poses 0.9 s long (ten messages
    0.1 s apart): a stretch shorter than four tolerances of 0.5 s is compared within a
    quarter of it, 0.225 s (``log_twins._shared_time_share``), and the warning names that
    tolerance, not the 0.5 s of longer stretches it had named."""
    from aion_cli.formats.writers import LogWriter

    log = tmp_path / "short.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(10):
            t = T0 + k * S // 10
            header = {"stamp": {"sec": t // S, "nanosec": t % S}, "frame_id": "map"}
            pose = {"position": {"x": 0.3 * k, "y": 1.0}, "orientation": {"w": 1.0}}
            for topic in ("/people", "/people_fused"):
                message = {"header": header, "poses": [pose]}
                w.write(topic, "geometry_msgs/msg/PoseArray", message, t)
    report = run_json("build", log, "-o", tmp_path / "m.aion", "--format", "json")
    (warning,) = _twin_warnings(report)
    assert "(100% of one's detections have one of the other's within 0.225 s and 0.5 m)" in (
        warning
    ), warning
