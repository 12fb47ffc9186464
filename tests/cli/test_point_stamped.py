"""``geometry_msgs/PointStamped`` streams of one detected person (no id, no orientation): read
as a generic type from topics whose name suggests people, linked into tracks."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import map_cells, run_json

S = 1_000_000_000
T0 = 1_700_000_400 * S  # aligned to 600-s windows
POINT = "geometry_msgs/msg/PointStamped"


def test_point_stamped_of_a_person_is_read_and_linked(tmp_path: Path) -> None:
    """/person_position: a person walking -x at 1.2 m/s, 30 points at 2 Hz in frame map;
    /clicked_point (RViz) beside it. The person's topic was skipped ('PointStamped is not a
    type aion reads') and the build refused the log; now it is used, RViz's is not, and
    the 30 points give 30 linked headings, all -x (bin 0): the first takes the first step's."""
    from aion_cli.formats.writers import LogWriter, stamp

    log = tmp_path / "points.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(30):
            t = T0 + k * S // 2
            hdr = {"stamp": stamp(t), "frame_id": "map"}
            w.write("/person_position", POINT,
                    {"header": hdr, "point": {"x": 20.0 - 0.6 * k, "y": -3.0}}, t)  # fmt: skip
            w.write("/clicked_point", POINT, {"header": hdr, "point": {"x": 1.0}}, t)
    info = run_json("info", log, "--format", "json")
    why = {t["topic"]: (t["used"], t["why"]) for t in info["topics"]}
    assert why == {
        "/person_position": (True, "generic PointStamped, the name suggests people"),
        "/clicked_point": (False, "skipped: generic PointStamped on /clicked_point (name does "
                           "not suggest people; name it with --detections-topic)"),
    }  # fmt: skip
    out = tmp_path / "points.aion"
    report = run_json("build", log, "-o", out, "--format", "json")
    assert report["detection_topics"] == ["/person_position"]
    assert report["detections"] == {"read": 30, "used": 30, "dropped": {}}
    assert report["headings"] == {"velocity": 0, "track": 0, "linked": 30, "pose_yaw": 0,
                                  "none": 0}  # fmt: skip
    assert report["mean_speed_m_s"] == pytest.approx(1.2)
    _, counts, _ = map_cells(out)
    assert counts.sum(axis=0).tolist() == [30, 0, 0, 0, 0, 0, 0, 0]
