"""The real leg_tracker bags from the command line: id-less PoseArrays in a laser frame with zero
quaternions, built with linked headings (and two bags of unconnected laser frames, said so)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, map_cells, run, run_json
from tests.shared_data import real

# --- the real leg_tracker bags ----------------------------------------------------------------

# Poses in /leg_cluster_positions per bag (counted with rosbags), and the laser frame.
LEG_BAGS = {
    "positive_1_extracted.bag": (324, "right_laser"),
    "positive_2_extracted.bag": (116, "right_laser"),
    "positive_3_extracted.bag": (309, "right_laser"),
    "positive_4_extracted.bag": (415, "right_laser"),
    "positive_6_extracted.bag": (303, "rear_laser"),
    "positive_7_extracted.bag": (385, "rear_laser"),
}


@pytest.mark.parametrize("name", sorted(LEG_BAGS))
def test_leg_tracker_bags_build_with_linked_headings(name: str, tmp_path: Path) -> None:
    """Real laser leg clusters: PoseArray in the laser frame, no ids, zero quaternions, and an
    RViz MarkerArray beside them (skipped: its name does not suggest people). With the laser
    as the map frame every pose is used, and headings come from linking. People walk
    towards and away from the laser: the clusters span ~4.5 m in x and ~1 m in y, so most
    headings lie within 45° of the x axis."""
    poses, frame = LEG_BAGS[name]
    log = real("logs", "leg_tracker", name)
    refused = run("build", log, "-o", tmp_path / "m.aion")
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, f"frame {frame!r}")
    assert f"--map-frame {frame}" in refused.stderr
    out = tmp_path / "legs.aion"
    report = run_json("build", log, "-o", out, "--map-frame", frame, "--format", "json")
    assert report["detection_topics"] == ["/leg_cluster_positions"]
    assert report["detection_decoding"]["/leg_cluster_positions"]["decoder"] == "fast"
    assert report["detections"] == {"read": poses, "used": poses, "dropped": {}}
    h = report["headings"]
    assert h["pose_yaw"] == 0
    assert h["velocity"] == 0
    assert h["track"] == 0
    assert h["linked"] + h["none"] == poses
    assert h["linked"] >= 0.5 * poses
    _, counts, nodir = map_cells(out)
    assert counts.sum() == h["linked"]
    assert nodir.sum() == h["none"]
    bins = counts.sum(axis=0)
    along_x = bins[[0, 3, 4, 7]].sum()  # bins touching θ = ±π and θ = 0
    assert along_x >= 0.8 * bins.sum()


def test_leg_bags_of_two_unconnected_laser_frames_are_said_so(tmp_path: Path) -> None:
    """positive_1 (right_laser) and positive_6 (rear_laser) without TF: whichever frame is the
    map's, the error names both frames (its hint named the other one, whose build then
    named the first: round and round)."""
    logs = [real("logs", "leg_tracker", n) for n in ("positive_1_extracted.bag",
                                                      "positive_6_extracted.bag")]
    for frame, other in (("right_laser", "rear_laser"), ("rear_laser", "right_laser")):
        result = run("build", *logs, "--map-frame", frame, "--workers", "1",
                     "-o", tmp_path / "x.aion")
        assert result.exit_code == 2
        assert_one_line_error(
            result.stderr,
            f"the detections are in two frames, {frame!r} and {other!r}, and the logs have no "
            "TF between them",
        )
        assert "--map-frame names the frame" in result.stderr
