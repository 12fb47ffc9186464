"""``aion info`` on several logs whose detections are in frames without TF, one frame per log
(the leg_tracker bags: ``positive_1..4`` in 'right_laser', ``positive_6..7`` in 'rear_laser').

Info reads the frames of each log's first detection messages, not only those of the set's
first messages, so it names every frame the build will meet; and where the frames cannot be
joined (no TF between them) it says to build each frame's logs into a map of its own, as the
build's error then does, not ``--map-frame`` of one of them (which the build refuses)."""

from __future__ import annotations

import json
from pathlib import Path

from tests.robustness.conftest import T0, S, fails, person, run, write_log


def _frame_log(path: Path, frame: str, start_s: int, n: int = 30) -> Path:
    """``n`` person messages (more than info samples of one topic: 20) in ``frame``, one a
    second from ``T0 + start_s``."""
    people = [person(T0 + (start_s + k) * S, (1, 2, 0), frame=frame) for k in range(n)]
    return write_log(path, people)


def test_info_names_the_frames_of_every_log_and_says_to_build_them_apart(tmp_path: Path) -> None:
    right = _frame_log(tmp_path / "right.mcap", "right_laser", 0)
    rear = _frame_log(tmp_path / "rear.mcap", "rear_laser", 60)
    # built in one of the frames, the build meets the other and stops: what info must foresee
    both = tmp_path / "both.aion"
    fails(run("build", right, rear, "--map-frame", "right_laser", "-o", both), "two frames")
    doc = json.loads(run("info", right, rear, "--format", "json").stdout)
    assert doc["frames_without_tf"] == {"/tracks": ["rear_laser", "right_laser"]}
    table = " ".join(run("info", right, rear).stderr.split())
    named = "/tracks holds detections in frames 'rear_laser', 'right_laser', and the logs have"
    assert f"{named} no TF to 'map'" in table
    assert "build the logs of each frame into a map of its own" in table
    assert "(--map-frame rear_laser, --map-frame right_laser)" in table
    # the advice works: each frame's log builds with its --map-frame
    for log, frame in ((right, "right_laser"), (rear, "rear_laser")):
        built = run("build", log, "--map-frame", frame, "-o", tmp_path / f"{frame}.aion", "-q")
        assert built.exit_code == 0, built.stderr


def test_info_on_logs_of_one_frame_keeps_the_one_frame_advice(tmp_path: Path) -> None:
    first = _frame_log(tmp_path / "a.mcap", "right_laser", 0)
    second = _frame_log(tmp_path / "b.mcap", "right_laser", 60)
    doc = json.loads(run("info", first, second, "--format", "json").stdout)
    assert doc["frames_without_tf"] == {"/tracks": ["right_laser"]}
    table = " ".join(run("info", first, second).stderr.split())
    assert "and the logs have no TF to 'map': build with --map-frame right_laser (if it is a" \
        " fixed frame)" in table
    assert "of its own" not in table
    built = run("build", first, second, "--map-frame", "right_laser", "-o", tmp_path / "r.aion")
    assert built.exit_code == 0, built.stderr
