"""Logs of a robot and of a fixed sensor in one build: a log without any robot trajectory is a
fixed sensor over the windows it recorded (README, ``aion build``), also when another log of
the build has a trajectory, so one build of all the logs equals continuing the robot's map with
the fixed sensor's log, and the ``--workers`` build, whose shards each observe by their own logs."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import write_office_log
from tests.time_shard_logs import build_logs, same_maps

HOUR_S = 3600
DAY_S = 24 * HOUR_S


def _logs(tmp_path: Path) -> list[Path]:
    """A robot's hour on Monday and Thursday, a fixed sensor's hour on Tuesday 08:00."""
    robot1, fixed, robot2 = tmp_path / "r1.mcap", tmp_path / "f.mcap", tmp_path / "r2.mcap"
    write_office_log(robot1, duration_s=HOUR_S)
    write_office_log(fixed, tf=False, shift_s=DAY_S, duration_s=HOUR_S)
    write_office_log(robot2, shift_s=3 * DAY_S, duration_s=HOUR_S)
    return [robot1, fixed, robot2]


def _continued(logs: list[Path], out: Path) -> Path:
    """A map built from the first log and continued with each next one (``--map``)."""
    for k, log in enumerate(logs):
        build_map(BuildOptions(
            logs=(log,), output=out, workers=1, continue_from=out if k else None,
        ))
    return out


def test_a_fixed_sensor_log_beside_robot_logs_observes_its_own_windows(tmp_path: Path) -> None:
    logs = _logs(tmp_path)
    one = build_logs(logs, tmp_path / "one.aion", 1)
    # the fixed sensor recorded Tuesday 08:00-09:00: six windows, all of them observed
    assert one.observation.startswith("tf map->base_link + fixed sensor over the 6 windows")
    assert [n for n in one.notes if "hold no robot pose" in n] == [
        "1 log(s) of other times than the robot's hold no robot pose (f.mcap): each is treated "
        "as a fixed sensor that saw everything in the windows in which it recorded any "
        "message, as a build of it alone would (a robot log whose localisation was not "
        "recorded is read so too)"
    ]
    continued = _continued(logs, tmp_path / "continued.aion")
    assert same_maps(tmp_path / "one.aion", continued) == []
    two = build_logs(logs, tmp_path / "two.aion", 2)
    assert len(two.workers) == 3
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []
    # and the parallel build says so as the sequential one does, with no warning that the
    # shards observed otherwise
    assert two.observation == one.observation
    assert not [w for w in two.warnings if "observation sources differ" in w]


def test_a_fixed_sensor_log_beside_a_robot_seen_by_the_graphs_agent_layer(tmp_path: Path) -> None:
    """The same with a robot whose poses come from the scene graphs' agent layer (no TF): the
    fixed sensor's log, whose graphs carry no agents, observes its own windows."""
    logs = [tmp_path / "a1.mcap", tmp_path / "f.mcap", tmp_path / "a2.mcap"]
    write_office_log(logs[0], tf=False, agents=True, duration_s=2 * HOUR_S)
    write_office_log(logs[1], tf=False, shift_s=DAY_S, duration_s=HOUR_S)
    write_office_log(logs[2], tf=False, agents=True, shift_s=3 * DAY_S, duration_s=2 * HOUR_S)
    one = build_logs(logs, tmp_path / "one.aion", 1)
    assert one.observation.startswith("scene-graph agent layer + fixed sensor over the 6 windows")
    continued = _continued(logs, tmp_path / "continued.aion")
    assert same_maps(tmp_path / "one.aion", continued) == []
    two = build_logs(logs, tmp_path / "two.aion", 2)
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []
    assert two.observation == one.observation


def test_robot_logs_that_overlap_a_log_without_tf_observe_by_the_robot(tmp_path: Path) -> None:
    """A recording split into files (the tracker's in one, TF in another) is one robot."""
    robot, tracker = tmp_path / "r.mcap", tmp_path / "t.mcap"
    write_office_log(robot, duration_s=HOUR_S)
    write_office_log(tracker, tf=False, graph=False, shift_s=600, duration_s=HOUR_S)
    one = build_logs([robot, tracker], tmp_path / "one.aion", 1)
    assert one.observation == "tf map->base_link"


def test_a_log_without_tf_touching_a_robot_log_is_grouped_as_the_parallel_build_groups(
    tmp_path: Path,
) -> None:
    """A log that starts 8 s after the robot's last message (in the next window) stays with it,
    as a parallel build keeps logs that touch in one shard: the robot's poses say what it
    observed, in one build as in two workers."""
    robot, tracker, later = tmp_path / "r.mcap", tmp_path / "t.mcap", tmp_path / "r2.mcap"
    write_office_log(robot, duration_s=HOUR_S)  # its last message at 08:59:55
    write_office_log(tracker, tf=False, shift_s=HOUR_S + 3, duration_s=HOUR_S)
    write_office_log(later, shift_s=2 * DAY_S, duration_s=HOUR_S)
    one = build_logs([robot, tracker, later], tmp_path / "one.aion", 1)
    assert one.observation == "tf map->base_link"
    two = build_logs([robot, tracker, later], tmp_path / "two.aion", 2)
    assert len(two.workers) == 2
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []


def test_observed_spans_beside_a_robot_give_the_sequential_map_with_workers(
    tmp_path: Path,
) -> None:
    """One pass ignores ``--observed`` beside a robot's trajectory (a warning says so), which a
    fixed sensor's shard alone applies: the parallel build learns such logs again in
    sequence, so both give one map."""
    from tests.cli.logdata import T0

    logs = _logs(tmp_path)
    declared = ((T0 - 3600 * 10**9, T0 + 4 * DAY_S * 10**9),)
    one = build_logs(logs, tmp_path / "one.aion", 1, observed=declared)
    assert [w for w in one.warnings if w.startswith("--observed ignored")]
    two = build_logs(logs, tmp_path / "two.aion", 2, observed=declared)
    assert [n for n in two.notes if n.startswith("--observed beside a robot's logs")]
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []


def test_a_parallel_build_names_the_fixed_sensor_logs_as_one_pass_does(tmp_path: Path) -> None:
    """Two fixed sensors' logs between a robot's: one pass names both in one note; the
    --workers build said "no robot trajectory ... the log is treated as a fixed sensor" once
    per shard and named none of them."""
    logs = [tmp_path / f"{name}.mcap" for name in ("r1", "f1", "f2", "r2")]
    write_office_log(logs[0], duration_s=HOUR_S)
    write_office_log(logs[1], tf=False, shift_s=DAY_S, duration_s=HOUR_S)
    write_office_log(logs[2], tf=False, shift_s=2 * DAY_S, duration_s=HOUR_S)
    write_office_log(logs[3], shift_s=3 * DAY_S, duration_s=HOUR_S)
    one = build_logs(logs, tmp_path / "one.aion", 1)
    two = build_logs(logs, tmp_path / "two.aion", 2)
    assert len(two.workers) == 4
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []
    named = [n for n in one.notes if "hold no robot pose" in n]
    assert [n.split(":")[0] for n in named] == [
        "2 log(s) of other times than the robot's hold no robot pose (f1.mcap, f2.mcap)"
    ]
    assert [n for n in two.notes if "hold no robot pose" in n] == named
    assert not [n for n in two.notes if n.startswith("no robot trajectory")]
    assert two.observation == one.observation


def test_a_robot_shard_with_its_own_fixed_sensor_logs_adds_their_windows_once() -> None:
    """A shard of a robot's log and a fixed sensor's (logs learnt together in sequence) says
    "tf ... + fixed sensor over ..." itself; joined with a fixed-sensor shard the build said
    both spans one after the other ("... + fixed sensor over the 15 windows (2.5 h of a
    2.5 h span) + fixed sensor over the 30 windows ...") where one pass gives one span."""
    from aion_cli.build_report import BuildReport
    from aion_cli.fixed_sensor import fixed_sensor_text
    from aion_cli.shard_reports import combine_reports

    delta = 600 * 10**9
    fixed = BuildReport(Path("f"), observation=fixed_sensor_text(30, 100, 300, delta))
    fixed.fixed_windows = (30, 100, 300, delta)
    fixed.recording_spans = [("/logs/d2.mcap", 250, 300), ("/logs/d1.mcap", 100, 120)]
    own = fixed_sensor_text(15, 900, 914, delta)
    robot = BuildReport(Path("r"), observation="tf map->base_link + " + own)
    robot.unposed = (["d8.mcap"], (15, 900, 914, delta))
    out = BuildReport(Path("out"))
    combine_reports(out, [fixed, robot])
    # one pass: 45 windows from the first fixed sensor's window to the last one's
    assert out.observation == "tf map->base_link + " + fixed_sensor_text(45, 100, 914, delta)
    assert out.observation.count("fixed sensor over") == 1
    named = [n for n in out.notes if "hold no robot pose" in n]
    assert [n.split(":")[0] for n in named] == [
        "3 log(s) of other times than the robot's hold no robot pose (d1.mcap, d2.mcap, d8.mcap)"
    ]



@pytest.mark.parametrize(
    ("shift_s", "later_s", "cut_after"),
    [
        # people from 09:00:03 to 09:59:53 and from 11:00:03: the cut after the last pose
        (HOUR_S - 2, 2 * HOUR_S, "2026-11-23 10:00"),
        # people from 06:00:05 to 06:59:55 and from 09:00:03: the cut before the first pose
        (-2 * HOUR_S, 3 * HOUR_S - 2, "2026-11-23 07:00"),
    ],
)
def test_a_time_shard_without_the_robots_poses_observes_as_one_pass(
    tmp_path: Path, shift_s: int, later_s: int, cut_after: str
) -> None:
    """A tracker's log touching a robot's (one group of logs: the robot's poses say what they
    observed) records another hour, apart from the robot's, so a parallel build cuts the group
    between the two into time shards, one of them without a robot pose. One pass judges the
    group by all its poses (its windows without a pose are unobserved); the part without a
    pose judged its own windows only and read the group as a fixed sensor over them. Before
    the first pose, one pass's map starts at that pose (every pose is added before the
    stream) and drops the hour's detections as before its first window: the part before it
    kept them."""
    robot, tracker = tmp_path / "r.mcap", tmp_path / "t.mcap"
    write_office_log(robot, graph=False, duration_s=HOUR_S)  # poses 08:00-08:59:55
    write_office_log(
        tracker, tf=False, graph=False, shift_s=shift_s, duration_s=HOUR_S,
        later_sessions_s=(later_s,),
    )
    one = build_logs([robot, tracker], tmp_path / "one.aion", 1)
    assert one.observation == "tf map->base_link"
    two = build_logs([robot, tracker], tmp_path / "two.aion", 2)
    assert len(two.workers) == 2
    assert two.workers[1]["from"] > cut_after  # one part holds no pose
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []
    assert two.observation == one.observation
    assert not [n for n in two.notes if "hold no robot pose" in n]


LATE_START = ((-2 * HOUR_S, -HOUR_S, False), (0, HOUR_S, True))


def _late_localisation(
    path: Path, shift_s: int = 0, segments: tuple[tuple[int, int, bool], ...] = LATE_START
) -> None:
    """One log of ``segments`` ``(start, stop, posed)``, seconds after Monday 08:00 plus
    ``shift_s``: a person every 10 s (at 5 s past), and where ``posed`` the robot's ``/tf``
    map -> base_link every 5 s. By default people from 06:00:05 to 06:59:55 with no robot
    pose, then from 08:00:05 to 08:59:55 with the robot's (its localisation started late)."""
    from aion_cli.formats.writers import LogWriter
    from tests.cli.logdata import ROBOT_XYZ, T0, S

    def stamp(t: int) -> dict[str, int]:
        return {"sec": t // S, "nanosec": t % S}

    person = {
        "track_id": 1, "is_matched": True,
        "pose": {"pose": {"position": {"x": 2.1, "y": 0.1, "z": 0.0}, "orientation": {"w": 1.0}}},
        "twist": {"twist": {"linear": {"x": 1.0, "y": 0.0, "z": 0.0}}},
    }
    x, y, z = ROBOT_XYZ
    with LogWriter(path) as writer:
        for start, stop, posed in segments:
            for s in range(start, stop, 5):
                t = T0 + (shift_s + s) * S
                if posed:
                    writer.write("/tf", "tf2_msgs/msg/TFMessage", {"transforms": [{
                        "header": {"stamp": stamp(t), "frame_id": "map"},
                        "child_frame_id": "base_link",
                        "transform": {"translation": {"x": x, "y": y, "z": z},
                                      "rotation": {"w": 1.0}},
                    }]}, t)
                if s % 10 == 5:
                    writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons", {
                        "header": {"stamp": stamp(t), "frame_id": "map"}, "tracks": [person],
                    }, t)


def test_a_time_shard_before_the_robots_localisation_starts_drops_as_one_pass(
    tmp_path: Path,
) -> None:
    """A robot's log whose tracker ran an hour before its localisation, cut into two time
    shards between the two: one pass adds every pose before the stream, so its map starts at
    the first pose and the hour before it is dropped (360 detections ``before_window``); the
    first part, holding no pose, started at its own first detection and kept them."""
    log = tmp_path / "late.mcap"
    _late_localisation(log)
    one = build_logs([log], tmp_path / "one.aion", 1)
    assert one.observation == "tf map->base_link"
    assert one.to_dict()["detections"]["dropped"] == {"before_window": 360}
    two = build_logs([log], tmp_path / "two.aion", 2)
    assert len(two.workers) == 2
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []
    assert two.to_dict()["detections"] == one.to_dict()["detections"]


def test_a_later_shard_whose_localisation_starts_late_keeps_what_one_pass_keeps(
    tmp_path: Path,
) -> None:
    """The same log two days after a robot's hour, a shard of its own: one pass's map began
    with the first log, so the hour before the second log's first pose is streamed into it
    and kept; the shard started its map at that first pose (every pose is added before the
    stream) and dropped the 360 detections before it as ``before_window``."""
    first, late = tmp_path / "a.mcap", tmp_path / "late.mcap"
    write_office_log(first, graph=False, duration_s=HOUR_S)
    _late_localisation(late, shift_s=2 * DAY_S)
    one = build_logs([first, late], tmp_path / "one.aion", 1)
    assert one.to_dict()["detections"]["dropped"] == {}
    two = build_logs([first, late], tmp_path / "two.aion", 2)
    assert len(two.workers) == 2
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []
    assert two.to_dict()["detections"] == one.to_dict()["detections"]


def test_a_time_shard_whose_poses_resume_late_keeps_what_one_pass_keeps(tmp_path: Path) -> None:
    """One robot log: an hour with poses, a silent hour, then an hour of people without a
    pose and an hour with them again; cut in the silence. One pass's map began in the first
    hour and keeps the people of the hour before the poses resume; the second part, its own
    first pose added before its stream, started its map there and dropped 360 of them."""
    log = tmp_path / "gap.mcap"
    _late_localisation(log, segments=(
        (0, HOUR_S, True), (2 * HOUR_S, 3 * HOUR_S, False), (3 * HOUR_S, 4 * HOUR_S, True),
    ))
    one = build_logs([log], tmp_path / "one.aion", 1)
    assert one.to_dict()["detections"]["dropped"] == {}
    two = build_logs([log], tmp_path / "two.aion", 2)
    assert len(two.workers) == 2
    assert two.workers[1]["from"] < "2026-11-23 10:05"  # the part starts before 11:00's pose
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []
    assert two.to_dict()["detections"] == one.to_dict()["detections"]
