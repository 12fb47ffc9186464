"""Detections whose position is NaN, infinite or absurdly far (a tracker's lost tracks) beside
people walking a known straight line: they are dropped as before (NaN or infinite as ``nan``,
beyond the spatial hash's range as ``out_of_range``), and no longer reach the
track linker or the heading estimator (which printed numpy RuntimeWarnings and tallied a
heading source for rows the map never used)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.conftest import run_process

S = 1_000_000_000
T0 = 1_700_000_400 * S  # aligned to 600-s windows


def lost_tracks_log(path: Path, far: float) -> Path:
    """30 messages at 2 Hz on /people_poses (PoseArray) and /tracked (TrackedPersons), in
    frame map. Each holds one person walking +x at 1.2 m/s (0.6 m per message; in
    TrackedPersons track 1 with that velocity) and one row whose position is NaN, infinite
    or ``far`` in turn (track 2, its velocity likewise)."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path, "mcap") as w:
        for k in range(30):
            t = T0 + k * S // 2
            header = {"stamp": {"sec": t // S, "nanosec": t % S}, "frame_id": "map"}
            bad = (float("nan"), float("inf"), far)[k % 3]
            poses = [{"position": {"x": 0.6 * k, "y": 1.0}}, {"position": {"x": bad, "y": 1.0}}]
            w.write("/people_poses", "geometry_msgs/msg/PoseArray",
                    {"header": header, "poses": poses}, t)  # fmt: skip
            tracks = [
                {"track_id": 1, "pose": {"pose": {"position": {"x": 0.6 * k, "y": 5.0}}},
                 "twist": {"twist": {"linear": {"x": 1.2}}}},
                {"track_id": 2, "pose": {"pose": {"position": {"x": 5.0, "y": bad}}},
                 "twist": {"twist": {"linear": {"x": bad}}}},
            ]  # fmt: skip
            w.write("/tracked", "spencer_tracking_msgs/msg/TrackedPersons",
                    {"header": header, "tracks": tracks}, t)  # fmt: skip
    return path


@pytest.mark.parametrize("far", [float("nan"), 1e300])
def test_lost_tracks_reach_neither_the_linker_nor_the_headings(tmp_path: Path, far: float) -> None:
    log = lost_tracks_log(tmp_path / "lost.mcap", far)
    done = run_process("build", log, "-o", tmp_path / "lost.aion", "--format", "json")
    assert done.returncode == 0, done.stderr
    assert "RuntimeWarning" not in done.stderr
    report = json.loads(done.stdout)
    detections = report["detections"]
    assert detections["used"] == 60  # the two walkers, 30 rows each
    assert detections["read"] == 120
    if far != far:  # every bad row NaN or infinite: all dropped before headings
        assert detections["dropped"] == {"nan": 60}
    else:  # the rows 1e300 m away are the Mapper's out_of_range, and stop as early
        assert detections["dropped"] == {"nan": 40, "out_of_range": 20}
    # one heading source per used row: 30 velocities, 30 linked (the first takes the first
    # step's); a far row linked beside the walker had made "people move at 25,000.9 m/s"
    assert report["headings"] == {"velocity": 30, "track": 0, "linked": 30,
                                  "pose_yaw": 0, "none": 0}  # fmt: skip
    assert report["mean_speed_m_s"] == pytest.approx(1.2)
    assert not [w for w in report["warnings"] if "people move at" in w]
