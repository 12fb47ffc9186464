"""``aion build``'s frames: ``--map-frame`` for logs without TF (and the map remembering it for
the logs after), empty frame names refused, TF trees that cannot carry a frame. Frame names on
the command line are spelt as the logs' frame ids are compared: ROS 1 tools write ``/map``
where ROS 2 writes ``map``, and both name one frame."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.mapfile import read_manifest
from aion_cli.formats.writers import LogWriter
from tests.cli.conftest import Office, assert_one_line_error, run, run_json
from tests.cli.logdata import T0, write_office_log


def test_a_leading_slash_on_map_frame_names_the_logs_frame(tmp_path: Path) -> None:
    """Detections in 'map' and no TF: ``--map-frame /map`` stopped the build with "detections
    are in frame 'map' but the log has no TF to '/map'" (and the map recorded '/map', so
    continuing it with 'map' warned of two frames). All 300 detections are used either way."""
    log = tmp_path / "office.mcap"
    write_office_log(log, tf=False, graph=False)
    first = tmp_path / "first.aion"
    report = run_json("build", log, "--map-frame", "/map", "-o", first, "--format", "json")
    assert report["detections"]["used"] == 300
    assert read_manifest(first)["map_frame"] == "map"
    later = tmp_path / "later.mcap"
    write_office_log(later, tf=False, graph=False, shift_s=3 * 86_400)
    report = run_json("build", later, "--map", first, "--map-frame", "map", "-o",
                      tmp_path / "both.aion", "--format", "json")
    assert report["detections"]["used"] == 300
    assert not [w for w in report["warnings"] if "holds positions in frame" in w]


def _tf_log(
    path: Path,
    topic: str,
    child: str,
    quats: list[tuple[float, ...]],
    parent: str | None = None,
    period_s: int = 30,
    stamped: bool = True,
) -> None:
    """TF ``parent -> child`` (default ``base_link`` on ``/tf_static``, else ``map``) with the
    rotations ``quats``, one message every ``period_s`` from the office log's start (header
    stamps 0 unless ``stamped``)."""
    parent = parent or ("base_link" if topic == "/tf_static" else "map")
    with LogWriter(path) as writer:
        for k, (x, y, z, w) in enumerate(quats):
            t = T0 + period_s * k * 10**9
            writer.write(
                topic,
                "tf2_msgs/msg/TFMessage",
                {
                    "transforms": [
                        {
                            "header": {
                                "stamp": {"sec": t // 10**9 if stamped else 0, "nanosec": 0},
                                "frame_id": parent,
                            },
                            "child_frame_id": child,
                            "transform": {
                                "translation": {"x": 3.0},
                                "rotation": {"x": x, "y": y, "z": z, "w": w},
                            },
                        }
                    ]
                },
                t,
            )


def test_a_frame_whose_only_transform_is_unusable_is_said_so(tmp_path: Path) -> None:
    """base_link -> laser with an all-zero quaternion (tf2 ignores it, and so does aion): the
    build said "unknown frame 'laser'" with the hint to check that the log has /tf, which it
    has. Now the error names the transform and why it cannot be used, and info warns."""
    people, static = tmp_path / "laser.mcap", tmp_path / "static.mcap"
    write_office_log(people, frame="laser", graph=False)
    _tf_log(static, "/tf_static", "laser", [(0.0, 0.0, 0.0, 0.0)])
    result = run("build", people, static, "--workers", "1", "-o", tmp_path / "m.aion")
    assert result.exit_code == 2
    assert_one_line_error(
        result.stderr,
        "frame 'laser' is only in TF transforms that cannot be used: "
        "1 of base_link->laser (a NaN or zero quaternion",
    )
    info = run_json("info", people, static, "--format", "json")
    assert [w for w in info["warnings"] if "1 of base_link->laser" in w]


def test_unusable_robot_poses_are_a_warning_with_their_count(tmp_path: Path) -> None:
    """Three map -> base_link poses with a NaN rotation beside the good ones: dropped without a
    word before; now a warning counts them (the 300 detections are still used)."""
    people, broken = tmp_path / "office.mcap", tmp_path / "broken.mcap"
    write_office_log(people, graph=False)
    _tf_log(
        broken, "/tf", "base_link", [(0.0, 0.0, 0.0, 1.0)] + [(float("nan"), 0.0, 0.0, 1.0)] * 3
    )
    report = run_json(
        "build", people, broken, "--workers", "1", "-o", tmp_path / "m.aion", "--format", "json"
    )
    assert report["detections"]["used"] == 300
    assert [
        w for w in report["warnings"] if w.startswith("TF transforms ignored: 3 of map->base_link")
    ]


def test_a_frame_with_two_parents_is_a_warning(tmp_path: Path) -> None:
    """base_link under map (the office log) and under world (a second localiser): not a tree,
    and nothing said before; the build now warns and names both parents."""
    people, other = tmp_path / "office.mcap", tmp_path / "world.mcap"
    write_office_log(people, graph=False)
    _tf_log(other, "/tf", "base_link", [(0.0, 0.0, 0.0, 1.0)] * 2, parent="world")
    report = run_json("build", people, other, "--workers", "1", "-o", tmp_path / "m.aion",
                      "--format", "json")
    assert report["detections"]["used"] == 300
    warned = [w for w in report["warnings"] if "more than one parent" in w]
    assert len(warned) == 1, report["warnings"]
    assert "'base_link' (map, world)" in warned[0]


def test_without_map_to_odom_the_top_of_the_sensors_tree_is_suggested(tmp_path: Path) -> None:
    """odom -> base_link -> laser and no map -> odom (no localisation running): the build said
    "unknown frame 'map'" with a hint to check --map-frame, and info suggested --map-frame
    laser, the moving sensor's own frame. Both now name odom, the top of the laser's tree,
    and a build in odom uses every detection."""
    people, odom, static = tmp_path / "laser.mcap", tmp_path / "odom.mcap", tmp_path / "s.mcap"
    write_office_log(people, frame="laser", tf=False, graph=False)
    _tf_log(odom, "/tf", "base_link", [(0.0, 0.0, 0.0, 1.0)] * 241, parent="odom", period_s=5)
    _tf_log(static, "/tf_static", "laser", [(0.0, 0.0, 0.0, 1.0)])
    logs = (people, odom, static)
    result = run("build", *logs, "--workers", "1", "-o", tmp_path / "m.aion")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "unknown frame 'map': TF joins 'laser' only to "
                          "base_link, odom")
    assert "--map-frame odom builds the map in that frame" in result.stderr
    info = run("info", *logs)
    assert "build with --map-frame odom (the top of the TF tree 'laser' is in)" in info.stderr
    assert run_json("info", *logs, "--format", "json")["tf_roots"] == {"laser": "odom"}
    report = run_json("build", *logs, "--workers", "1", "--map-frame", "odom", "-o",
                      tmp_path / "odom.aion", "--format", "json")
    assert report["detections"]["used"] == 300


def test_a_robot_without_base_link_is_told_its_base_frame(tmp_path: Path) -> None:
    """TF moves base_footprint in map and has no base_link: the robot's log was read as a fixed
    sensor that saw every place in every window, with only a note. Now a warning names the
    frame TF moves (--base-frame base_footprint), which gives the robot's trajectory."""
    people, robot = tmp_path / "office.mcap", tmp_path / "robot.mcap"
    write_office_log(people, tf=False, graph=False)
    _tf_log(robot, "/tf", "base_footprint", [(0.0, 0.0, 0.0, 1.0)] * 241, period_s=5)
    report = run_json("build", people, robot, "--workers", "1", "-o", tmp_path / "a.aion",
                      "--format", "json")
    assert report["observation"].startswith("fixed sensor")
    warned = [w for w in report["warnings"] if w.startswith("TF moves 'base_footprint' in 'map'")]
    assert len(warned) == 1, report["warnings"]
    assert warned[0].endswith("--base-frame base_footprint")
    info = run_json("info", people, robot, "--format", "json")  # says so before the build
    assert warned[0] in info["warnings"]
    report = run_json("build", people, robot, "--workers", "1", "-o", tmp_path / "b.aion",
                      "--base-frame", "base_footprint", "--format", "json")
    assert report["observation"] == "tf map->base_footprint"
    assert not [w for w in report["warnings"] if w.startswith("TF moves")]


def test_transforms_stamped_zero_take_their_log_time(tmp_path: Path) -> None:
    """map -> laser on /tf with header stamps left at 0 by its publisher: looked up at the
    detections' stamps (2026) a transform of 1970 was never found, and the build stopped with
    "none of the 300 people detections read could be used (dropped: no_transform 300)". They
    now take their log time, as detections do: the map is that of the people in 'map'."""
    people, robot = tmp_path / "laser.mcap", tmp_path / "robot.mcap"
    write_office_log(people, frame="laser", tf=False)
    _tf_log(robot, "/tf", "laser", [(0.0, 0.0, 0.0, 1.0)] * 240, period_s=5, stamped=False)
    report = run_json("build", people, robot, "--workers", "1", "-o", tmp_path / "a.aion",
                      "--format", "json")
    assert report["detections"]["used"] == 300
    assert "240 transform(s) on /tf were stamped 0 (unset by their publisher): their log time " \
        "was taken, as for detections" in report["notes"]
    reference = tmp_path / "map.mcap"
    write_office_log(reference, frame="map", tf=False)
    built = run_json("build", reference, "-o", tmp_path / "b.aion", "--format", "json")
    flows = [
        {e["id"]: (e["flow"], e["direction_bin"]) for e in run_json(
            "predict", tmp_path / f"{m}.aion", "--historical", "--format", "json")["entries"]}
        for m in ("a", "b")
    ]
    assert built["detections"]["used"] == 300
    assert flows[0] == flows[1]


def test_the_api_reads_map_frame_with_a_slash_as_the_cli_does(tmp_path: Path) -> None:
    """``Map.holdout(logs, map_frame="/map")`` on a map of 'map': the note "the map holds
    positions in frame 'map' and --map-frame read the test logs into '/map'" said the two
    frames differ; they are one frame, as for aion evaluate holdout --map-frame /map."""
    from aion_cli.api import Map

    first, later = tmp_path / "first.mcap", tmp_path / "later.mcap"
    write_office_log(first, tf=False)
    write_office_log(later, tf=False, shift_s=3 * 86_400)
    assert run("build", first, "-o", tmp_path / "m.aion", "-q").exit_code == 0
    result = Map.load(tmp_path / "m.aion").holdout(later, map_frame="/map")
    assert result.test["detections"] == 300
    assert not [n for n in result.notes if "holds positions in frame" in n]


def test_a_rotation_tf2_refuses_as_not_normalised_is_a_warning(tmp_path: Path) -> None:
    """base_link -> laser on /tf_static with |q| = 2 (tf2: "Quaternion not properly
    normalized"; |q|² − 1 = 3 > 0.01): aion normalised it without a word. The build still
    uses it (the rotation is unambiguous), and build and info now warn with the edge, the
    topic, |q| and the message count; a quaternion within tf2's tolerance says nothing."""
    people, static = tmp_path / "laser.mcap", tmp_path / "static.mcap"
    write_office_log(people, frame="laser", graph=False)
    _tf_log(static, "/tf_static", "laser", [(0.0, 0.0, 2.0, 0.0)] * 2, period_s=1)
    report = run_json("build", people, static, "--workers", "1", "-o", tmp_path / "m.aion",
                      "--format", "json")
    assert report["detections"]["used"] == 300
    warned = [w for w in report["warnings"] if "not unit quaternions" in w]
    assert len(warned) == 1, report["warnings"]
    assert "base_link->laser on /tf_static in 2 messages (|q| 2)" in warned[0]
    info = run_json("info", people, static, "--format", "json")
    assert [w for w in info["warnings"] if "base_link->laser on /tf_static in 2" in w]
    within = tmp_path / "within.mcap"
    _tf_log(within, "/tf_static", "laser", [(0.0, 0.0, 1.004, 0.0)])  # |q|² − 1 = 0.008
    report = run_json("build", people, within, "--workers", "1", "-o", tmp_path / "w.aion",
                      "--format", "json")
    assert report["detections"]["used"] == 300
    assert not [w for w in report["warnings"] if "not unit quaternions" in w]


def test_detections_that_name_no_frame_are_said_to_be_taken_as_the_map_frame(
    tmp_path: Path,
) -> None:
    """A tracker that leaves frame_id empty had its positions taken as map positions without
    a word; a robot's odom-frame tracker would so have been mapped where it never was. The
    build now says so once for the topic (in --workers 2 too), and says nothing when the
    detections name the map frame."""
    empty = tmp_path / "empty.mcap"
    write_office_log(empty, tf=False, graph=False, frame="")
    note = "detections on /tracks name no frame (an empty frame_id): their positions are " \
        "taken as in the map frame 'map'"
    for workers in ("1", "2"):
        report = run_json("build", empty, "-o", tmp_path / f"e{workers}.aion", "--workers",
                          workers, "--format", "json")
        assert report["detections"]["used"] == 300
        assert report["notes"].count(note) == 1, report["notes"]
    named = tmp_path / "named.mcap"
    write_office_log(named, tf=False, graph=False)
    report = run_json("build", named, "-o", tmp_path / "n.aion", "--format", "json")
    assert not [n for n in report["notes"] if "name no frame" in n]


def test_frames_without_tf_and_map_frame_option(tmp_path: Path) -> None:
    log = tmp_path / "odom.mcap"
    write_office_log(log, tf=False, frame="odom")
    result = run("build", log)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "'odom'")
    assert "--map-frame odom" in result.stderr
    assert not (tmp_path / "odom.aion").exists()
    report = run_json("build", log, "--map-frame", "odom", "--format", "json")
    assert report["detections"]["used"] == 300


def test_a_map_remembers_its_frame_for_the_logs_after(tmp_path: Path) -> None:
    """A map built with --map-frame records it: continuing it (aion build --map) and judging
    it on later logs (aion evaluate holdout) read those logs into the same frame without the
    option again; a map without the record (older maps) still defaults to 'map'."""
    first, later = tmp_path / "first.mcap", tmp_path / "later.mcap"
    write_office_log(first, tf=False, frame="odom")
    write_office_log(later, tf=False, frame="odom", shift_s=3 * 86_400)
    site = tmp_path / "site.aion"
    assert run("build", first, "--map-frame", "odom", "-o", site, "-q").exit_code == 0
    assert read_manifest(site)["map_frame"] == "odom"
    doc = run_json("evaluate", "holdout", site, later, "--format", "json")
    assert doc["test"]["detections"] == 300
    report = run_json("build", later, "--map", site, "--format", "json")
    assert report["detections"]["used"] == 300
    assert read_manifest(site)["map_frame"] == "odom"
    third = tmp_path / "third.mcap"
    write_office_log(third, tf=False, frame="odom", shift_s=6 * 86_400)
    other = tmp_path / "other.aion"  # an explicit frame still wins
    result = run("build", third, "--map", site, "--map-frame", "map", "-o", other)
    assert result.exit_code == 2
    assert "'odom'" in result.stderr


def test_continuing_a_map_in_another_frame_is_a_warning(tmp_path: Path) -> None:
    """``--map-frame`` on a continued map of another frame (the hint of the missing-TF error
    suggests it: leg_tracker bags in 'rear_laser' onto a map of 'right_laser') joined the
    positions of two frames in one map without a word, the manifest then recording only the
    new one."""
    first, later = tmp_path / "first.mcap", tmp_path / "later.mcap"
    write_office_log(first, tf=False, frame="right_laser")
    write_office_log(later, tf=False, frame="rear_laser", shift_s=3 * 86_400)
    site = tmp_path / "site.aion"
    assert run("build", first, "--map-frame", "right_laser", "-o", site, "-q").exit_code == 0
    report = run_json("build", later, "--map", site, "--map-frame", "rear_laser", "-o",
                      tmp_path / "both.aion", "--format", "json")
    assert report["detections"]["used"] == 300
    warned = [w for w in report["warnings"] if "holds positions in frame 'right_laser'" in w]
    assert len(warned) == 1, report["warnings"]
    assert "--map-frame reads these logs into 'rear_laser'" in warned[0]
    assert read_manifest(tmp_path / "both.aion")["map_frame"] == "rear_laser"
    # the map's own frame, given or not, is no news
    again = tmp_path / "again.mcap"
    write_office_log(again, tf=False, frame="right_laser", shift_s=3 * 86_400)
    for given in ((), ("--map-frame", "right_laser")):
        report = run_json("build", again, "--map", site, *given, "-o",
                          tmp_path / f"same{len(given)}.aion", "--format", "json")
        assert not [w for w in report["warnings"] if "holds positions in frame" in w]


@pytest.mark.parametrize(
    ("option", "value", "example"),
    [("--base-frame", "", "base_link"), ("--base-frame", " ", "base_link"),
     ("--map-frame", "", "map"), ("--map-frame", "/", "map"), ("--base-frame", "//", "base_link")],
)
def test_an_empty_frame_is_refused(
    office: Office, tmp_path: Path, option: str, value: str, example: str
) -> None:
    """An empty --base-frame made the robot's log a fixed sensor with only a note."""
    out = tmp_path / "m.aion"
    result = run("build", office.log, "-o", out, option, value)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, option, f"e.g. {example}")
    assert not out.exists()
