"""rosbag.js's real turtlesim bag read with a mapping of /turtle1/pose (as ``aion info LOG
--suggest-mapping`` writes it) in frame ``world``: TF moves turtle1 and turtle2 in world and
has no base_link. The build warned "TF moves 'turtle1', 'turtle2' in 'world' but has no
world->base_link chain: ... give the robot's frame, e.g. --base-frame turtle1" and noted the
same again, "TF has no world->base_link chain for the robot trajectory (frames: carrot,
turtle1, turtle2, world); see --map-frame / --base-frame", beside the fixed-sensor note. The
warning, which names the frame to give, now says it once; the note stays where no warning
names a frame (a TF tree that moves nothing in the map frame)."""

from __future__ import annotations

from pathlib import Path

from aion_cli.formats.writers import LogWriter
from tests.cli.conftest import run, run_json
from tests.cli.logdata import T0, write_office_log
from tests.shared_data import real

CHAIN_NOTE = "chain for the robot trajectory"


def test_a_robot_frame_the_warning_names_is_not_noted_again(tmp_path: Path) -> None:
    log = real("logs", "rosbagjs_fixtures", "example-bz2.bag")
    suggested = run("info", log, "--suggest-mapping", "/turtle1/pose")
    assert suggested.exit_code == 0, suggested.stderr
    mapping = tmp_path / "turtle.toml"
    mapping.write_text(suggested.stdout)
    report = run_json("build", log, "--detections-mapping", mapping, "--map-frame", "world",
                      "-o", tmp_path / "t.aion", "--workers", "1", "--format", "json")  # fmt: skip
    assert report["detections"]["used"] == 1344  # /turtle1/pose's messages, one turtle each
    warned = [w for w in report["warnings"] if w.startswith("TF moves 'turtle1', 'turtle2'")]
    assert len(warned) == 1, report["warnings"]
    assert warned[0].endswith("--base-frame turtle1")
    assert not [n for n in report["notes"] if CHAIN_NOTE in n], report["notes"]
    assert report["observation"].startswith("fixed sensor")  # what the warning says
    # with the frame it names, the robot's trajectory is read, and neither is said
    fixed = run_json("build", log, "--detections-mapping", mapping, "--map-frame", "world",
                     "--base-frame", "turtle1", "-o", tmp_path / "b.aion", "--workers", "1",
                     "--format", "json")  # fmt: skip
    assert fixed["observation"] == "tf world->turtle1"
    assert not [w for w in fixed["warnings"] if w.startswith("TF moves")]
    assert not [n for n in fixed["notes"] if CHAIN_NOTE in n]


def test_a_tree_without_moving_frames_keeps_the_note(tmp_path: Path) -> None:
    """People in map, TF only map -> laser on /tf_static and no base_link: nothing moves in
    map, so no warning names a frame, and the note says why there is no trajectory."""
    people, static = tmp_path / "office.mcap", tmp_path / "static.mcap"
    write_office_log(people, tf=False, graph=False)
    with LogWriter(static) as writer:
        writer.write(
            "/tf_static",
            "tf2_msgs/msg/TFMessage",
            {"transforms": [{
                "header": {"stamp": {"sec": T0 // 10**9, "nanosec": 0}, "frame_id": "map"},
                "child_frame_id": "laser",
                "transform": {"translation": {"x": 3.0}, "rotation": {"w": 1.0}},
            }]},
            T0,
        )  # fmt: skip
    report = run_json("build", people, static, "-o", tmp_path / "t.aion", "--workers", "1",
                      "--format", "json")  # fmt: skip
    assert not [w for w in report["warnings"] if w.startswith("TF moves")], report["warnings"]
    assert [n for n in report["notes"] if CHAIN_NOTE in n], report["notes"]
