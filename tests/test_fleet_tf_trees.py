"""Robots recording at the same time, built into one map (``aion build robot1.mcap
robot2.mcap``): both publish ``map -> base_link`` on ``/tf`` and detect people in
``base_link``. Each log holding ``/tf`` of its own resolves its detections with its own TF
tree (:mod:`aion_cli.tf_trees`); one buffer of both robots' poses moved each robot's
detections with the other's poses (interpolated between the two robots at interleaved stamps,
one of them at equal stamps), so people appeared where nobody stood and the map depended on
the order the logs were given. A recording split by topic (the detections in one log, ``/tf``
in another) still resolves with the shared tree.

The answers are known independently: each robot drives a straight line at constant speed
(so TF's linear interpolation is exact) and sees one standing person, whose map position the
test chose; every detection must land in that person's map cell."""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import T0

S = 1_000_000_000
DURATION_S = 1200  # two 10-minute windows
POSE_PERIOD_S = 1
DETECTION_PERIOD_S = 5


@dataclass(frozen=True)
class Robot:
    """A robot driving from ``start`` to ``end`` (map frame) over the log, heading ``yaw``,
    seeing the person standing at ``person`` (track ``track``)."""

    start: tuple[float, float]
    end: tuple[float, float]
    yaw: float
    person: tuple[float, float]
    track: int

    def pose(self, s: float) -> tuple[float, float]:
        f = s / DURATION_S
        return (
            self.start[0] + f * (self.end[0] - self.start[0]),
            self.start[1] + f * (self.end[1] - self.start[1]),
        )

    def seen(self, s: float) -> tuple[float, float]:
        """The person in ``base_link`` at ``s`` seconds: R(yaw)^T (person - robot)."""
        x, y = self.pose(s)
        dx, dy = self.person[0] - x, self.person[1] - y
        c, n = math.cos(self.yaw), math.sin(self.yaw)
        return c * dx + n * dy, -n * dx + c * dy


ROBOT1 = Robot(start=(2.0, 0.0), end=(6.0, 0.0), yaw=0.0, person=(4.25, 2.75), track=1)
ROBOT2 = Robot(start=(16.0, 10.0), end=(16.0, 6.0), yaw=-math.pi / 2, person=(17.75, 7.25), track=2)


def _tf(t: int, robot: Robot, s: float) -> dict[str, object]:
    x, y = robot.pose(s)
    return {
        "transforms": [
            {
                "header": {"stamp": _stamp(t), "frame_id": "map"},
                "child_frame_id": "base_link",
                "transform": {
                    "translation": {"x": x, "y": y, "z": 0.0},
                    "rotation": {"z": math.sin(robot.yaw / 2), "w": math.cos(robot.yaw / 2)},
                },
            }
        ]
    }


LASER_X = 0.5  # the laser 0.5 m ahead of base_link (/tf_static base_link -> laser)


def _people(t: int, robot: Robot, s: float, frame: str) -> dict[str, object]:
    x, y = robot.seen(s)
    x -= LASER_X if frame == "laser" else 0.0
    return {
        "header": {"stamp": _stamp(t), "frame_id": frame},
        "tracks": [
            {
                "track_id": robot.track,
                "is_matched": True,
                "pose": {"pose": {"position": {"x": x, "y": y}, "orientation": {"w": 1.0}}},
            }
        ],
    }


def _stamp(t: int) -> dict[str, int]:
    return {"sec": t // S, "nanosec": t % S}


def write_robot(
    paths: list[Path],
    robot: Robot,
    offset_ns: int = 0,
    tf: bool = True,
    people: bool = True,
    container: str = "mcap",
    frame: str = "base_link",
    sessions_s: tuple[int, ...] = (0,),
) -> int:
    """The robot's log, its time cut evenly over ``paths`` (one file each: a bag split by
    duration), every stamp ``offset_ns`` after the other robot's; ``tf``/``people``: whether
    it holds the ``/tf`` poses, the detections (a recording split by topic holds one of
    them). Returns the detection messages written."""
    from aion_cli.formats.writers import LogWriter

    n = 0
    part = DURATION_S // len(paths)
    for k, path in enumerate(paths):
        with LogWriter(path, container) as writer:  # type: ignore[arg-type]
            for session in sessions_s:  # (the log again, that many seconds later)
                for s in range(k * part, (k + 1) * part):
                    t = T0 + s * S + offset_ns + session * S
                    if tf and s % POSE_PERIOD_S == 0:
                        writer.write("/tf", "tf2_msgs/msg/TFMessage", _tf(t, robot, s), t)
                    if people and s % DETECTION_PERIOD_S == 4 and s + 1 < DURATION_S:
                        kind = "spencer_tracking_msgs/msg/TrackedPersons"
                        half = t + S // 2  # between two poses
                        writer.write("/tracks", kind, _people(half, robot, s + 0.5, frame), half)
                        n += 1
    return n


def where_people_are(
    logs: list[Path], out: Path, workers: int = 1
) -> dict[tuple[float, float], float]:
    """Build ``logs`` and return the detections of each map cell that holds any, by its
    centre (x, y)."""
    report = build_map(BuildOptions(logs=tuple(logs), output=out, workers=workers))
    assert report.observation.startswith("tf map->base_link"), report.observation
    entries = load_map(out).state.entries
    rows = entries.live_rows()
    counts = entries.counts[rows].sum(axis=1) + entries.nodir[rows]
    held = counts > 0
    centres = entries.xyz[rows][held, :2]
    return {(float(x), float(y)): float(c) for (x, y), c in zip(centres, counts[held], strict=True)}


def _at(cells: dict[tuple[float, float], float], person: tuple[float, float]) -> float:
    """The detections of the cells within half a metre of ``person``."""
    return sum(c for xy, c in cells.items() if math.dist(xy, person) <= 0.5)


def _assert_both_people(cells: dict[tuple[float, float], float], per_robot: int) -> None:
    assert _at(cells, ROBOT1.person) == per_robot, cells
    assert _at(cells, ROBOT2.person) == per_robot, cells
    assert sum(cells.values()) == 2 * per_robot, cells  # nobody anywhere else


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(offset_ms=st.integers(0, 999), swapped=st.booleans())
def test_two_robots_at_once_put_each_person_where_they_stood(offset_ms: int, swapped: bool) -> None:
    with tempfile.TemporaryDirectory() as folder:
        one, two = Path(folder, "robot1.mcap"), Path(folder, "robot2.mcap")
        per_robot = write_robot([one], ROBOT1)
        assert write_robot([two], ROBOT2, offset_ms * 1_000_000) == per_robot
        logs = [two, one] if swapped else [one, two]
        cells = where_people_are(logs, Path(folder, "fleet.aion"))
    _assert_both_people(cells, per_robot)


def test_two_robots_decoded_message_by_message(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """TF that the numpy decoder does not read (another layout, a rejected chunk) goes
    through the generic decoder, message by message: each robot's into its own tree too."""
    import aion_cli.formats.tf_fast as tf_fast

    monkeypatch.setattr(tf_fast, "layout_matches", lambda *args, **kw: False)
    one, two = tmp_path / "robot1.bag", tmp_path / "robot2.mcap"
    per_robot = write_robot([one], ROBOT1, container="bag")
    write_robot([two], ROBOT2, 300_000_000)
    _assert_both_people(where_people_are([one, two], tmp_path / "fleet.aion"), per_robot)


def test_static_transforms_in_a_log_of_their_own_serve_every_robot(tmp_path: Path) -> None:
    """Both robots detect in ``laser``, which ``/tf_static`` (``base_link -> laser``, recorded
    once in a log of its own) joins to ``base_link``: every log's static transforms are in
    each robot's own tree."""
    from aion_cli.formats.writers import LogWriter

    static = tmp_path / "static.mcap"
    with LogWriter(static, "mcap") as writer:
        mount = {
            "header": {"stamp": _stamp(T0), "frame_id": "base_link"},
            "child_frame_id": "laser",
            "transform": {"translation": {"x": LASER_X}, "rotation": {"w": 1.0}},
        }
        writer.write("/tf_static", "tf2_msgs/msg/TFMessage", {"transforms": [mount]}, T0)
    one, two = tmp_path / "robot1.mcap", tmp_path / "robot2.mcap"
    per_robot = write_robot([one], ROBOT1, frame="laser")
    write_robot([two], ROBOT2, 700_000_000, frame="laser")
    _assert_both_people(where_people_are([static, one, two], tmp_path / "fleet.aion"), per_robot)


def test_the_map_of_two_robots_is_the_same_in_either_order(tmp_path: Path) -> None:
    from aion_cli.engine.compare import differences

    one, two = tmp_path / "robot1.mcap", tmp_path / "robot2.mcap"
    write_robot([one], ROBOT1)
    write_robot([two], ROBOT2)  # the same stamps: one buffer kept one robot's poses
    given_, swapped = tmp_path / "given.aion", tmp_path / "swapped.aion"
    where_people_are([one, two], given_)
    where_people_are([two, one], swapped)
    a, b = load_map(given_).state, load_map(swapped).state
    assert differences(a, b) == []


def test_a_robot_recorded_as_a_split_bag_has_one_tree(tmp_path: Path) -> None:
    """Robot 1's bag split by duration into two storage files (a rosbag2 folder without
    metadata.yaml): one recording, one tree over both files, beside robot 2's log."""
    bag = tmp_path / "robot1"
    bag.mkdir()
    per_robot = write_robot([bag / "robot1_0.mcap", bag / "robot1_1.mcap"], ROBOT1)
    two = tmp_path / "robot2.mcap"
    write_robot([two], ROBOT2, 250_000_000)
    _assert_both_people(where_people_are([bag, two], tmp_path / "fleet.aion"), per_robot)


def test_one_robots_files_one_after_the_other_keep_one_tree(tmp_path: Path) -> None:
    """Robot 1's log cut in two files given as two paths (``rosbag record --split``): their
    ``/tf`` overlaps no other's, so the shared tree serves both and interpolates across the
    seam (the detection half a second after the first file's last pose, between it and the
    second file's first pose, is placed as in the uncut log); a tree per file would drop it."""
    first, second = tmp_path / "robot1_0.mcap", tmp_path / "robot1_1.mcap"
    per_robot = write_robot([first, second], ROBOT1)
    cells = where_people_are([first, second], tmp_path / "split.aion")
    assert _at(cells, ROBOT1.person) == per_robot == sum(cells.values()), cells


def test_a_recording_split_by_topic_resolves_with_the_other_logs_tf(tmp_path: Path) -> None:
    """Robot 1's detections in one log and its ``/tf`` in another, over the same time (no
    log of its own holds both): the shared tree moves the detections, as before."""
    people, poses = tmp_path / "robot1-people.mcap", tmp_path / "robot1-tf.mcap"
    per_robot = write_robot([people], ROBOT1, tf=False)
    write_robot([poses], ROBOT1, people=False)
    cells = where_people_are([people, poses], tmp_path / "split.aion")
    assert _at(cells, ROBOT1.person) == per_robot == sum(cells.values()), cells


def test_two_robots_in_parallel_shards_equal_one_pass(tmp_path: Path) -> None:
    """The two robots of one time and robot 1 again the next day (another shard): the
    parallel build equals one pass."""
    from aion_cli.engine.compare import differences

    one, two, later = (tmp_path / f"{n}.mcap" for n in ("robot1", "robot2", "robot1-next"))
    per_robot = write_robot([one], ROBOT1)
    write_robot([two], ROBOT2, 400_000_000)
    write_robot([later], ROBOT1, 86_400 * S)
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    cells = where_people_are([one, two, later], seq)
    assert (_at(cells, ROBOT1.person), _at(cells, ROBOT2.person)) == (2 * per_robot, per_robot)
    where_people_are([one, two, later], par, workers=2)
    assert differences(load_map(seq).state, load_map(par).state) == []


def test_two_robots_cut_in_time_shards_equal_one_pass(tmp_path: Path) -> None:
    """Both robots record a morning and an afternoon session in one log each: the two logs
    overlap (one group), which a parallel build cuts at the quiet midday into time shards,
    each reading both logs' whole TF into the same trees."""
    from aion_cli.engine.compare import differences

    one, two = tmp_path / "robot1.mcap", tmp_path / "robot2.mcap"
    per_session = write_robot([one], ROBOT1, sessions_s=(0, 6 * 3600))
    write_robot([two], ROBOT2, 600_000_000, sessions_s=(0, 6 * 3600))
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _assert_both_people(where_people_are([one, two], seq), per_session)
    report = build_map(BuildOptions(logs=(one, two), output=par, workers=2))
    assert len(report.to_dict()["workers"]) == 2, report.to_dict()["workers"]  # time shards
    assert differences(load_map(seq).state, load_map(par).state) == []


def test_which_recordings_overlap() -> None:
    from aion_cli.tf_trees import overlapping

    assert overlapping({0: (0, 10), 1: (10, 20), 2: (30, 40)}) == []  # touching: one after another
    assert overlapping({0: (0, 10), 1: (5, 20), 2: (30, 40)}) == [0, 1]
    assert overlapping({2: (30, 40), 0: (0, 100), 1: (5, 20)}) == [0, 1, 2]  # inside a long one
    assert overlapping({0: (0, 10), 1: (0, 10)}) == [0, 1]
    assert overlapping({0: (0, 10)}) == []
