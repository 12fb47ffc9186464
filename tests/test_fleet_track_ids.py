"""Robots recording at the same time on one detection topic, each tracker numbering its tracks
alike (``aion build robot1.mcap robot2.mcap``): track 1 of one robot and track 1 of the other
are two people (:mod:`aion_cli.track_owners`). Differenced as one track, each row's heading
came from a step between the two people (20 m apart), and id-less rows of both robots at
one time were linked as one sensor's frame.

The answers are known independently: each robot stands still (``map -> base_link`` constant
on its own ``/tf``) and tracks one person walking a straight line at constant speed, person
A at ``HEADING_A`` near robot 1 and person B the opposite way near robot 2; every detection
with a heading must be in its person's direction bin, and every detection written must be
in the map once. A robot's log cut in two files one after the other keeps its track across
the seam, as one file does."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.compare import differences
from aion_cli.engine.entries import direction_bins
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import T0

S = 1_000_000_000
DURATION_S = 120
SPEED = 0.3  # m/s
HEADING_A = 1.2  # rad, mid-bin for 8 bins (as is HEADING_B)
HEADING_B = HEADING_A - math.pi


@dataclass(frozen=True)
class Robot:
    """A robot standing at ``at`` (map frame, yaw 0) tracking one person (track ``track``)
    who walks from ``start`` at ``heading``."""

    at: tuple[float, float]
    start: tuple[float, float]
    heading: float
    track: int = 1

    def person(self, s: float) -> tuple[float, float]:
        d = SPEED * s
        return self.start[0] + d * math.cos(self.heading), self.start[1] + d * math.sin(
            self.heading
        )


# person A keeps to x < 5 m, person B to x > 27 m
ROBOT1 = Robot(at=(0.0, 0.0), start=(-8.0, -15.0), heading=HEADING_A)
ROBOT2 = Robot(at=(30.0, 0.0), start=(40.0, 15.0), heading=HEADING_B)


def _stamp(t: int) -> dict[str, int]:
    return {"sec": t // S, "nanosec": t % S}


def write_robot(
    path: Path, robot: Robot, seconds: range, offset_ns: int = 0, ids: bool = True
) -> int:
    """The robot's log over ``seconds`` (poses each second, a detection each second half a
    second later but the last, ``offset_ns`` later than the other robot's); ``ids``: the
    tracker's track ids, else bare positions (a leg detector's). Returns the detections
    written."""
    from aion_cli.formats.writers import LogWriter

    n = 0
    with LogWriter(path, "mcap") as writer:
        for s in seconds:
            t = T0 + s * S + offset_ns
            tf = {
                "transforms": [{
                    "header": {"stamp": _stamp(t), "frame_id": "map"},
                    "child_frame_id": "base_link",
                    "transform": {
                        "translation": {"x": robot.at[0], "y": robot.at[1], "z": 0.0},
                        "rotation": {"w": 1.0},
                    },
                }]
            }
            writer.write("/tf", "tf2_msgs/msg/TFMessage", tf, t)
            if s % 86_400 + 1 >= DURATION_S:
                continue  # (a detection after the last pose has no transform)
            half = t + S // 2
            x, y = robot.person(s + 0.5)
            x, y = x - robot.at[0], y - robot.at[1]
            if ids:
                people = {
                    "header": {"stamp": _stamp(half), "frame_id": "base_link"},
                    "tracks": [{
                        "track_id": robot.track,
                        "is_matched": True,
                        "pose": {"pose": {"position": {"x": x, "y": y},
                                          "orientation": {"w": 1.0}}},
                    }],
                }
                writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons", people, half)
            else:
                poses = {
                    "header": {"stamp": _stamp(half), "frame_id": "base_link"},
                    "poses": [{"position": {"x": x, "y": y, "z": 0.0},
                               "orientation": {"w": 1.0}}],
                }
                writer.write("/tracks", "geometry_msgs/msg/PoseArray", poses, half)
            n += 1
    return n


def _build(logs: list[Path], out: Path, workers: int = 1) -> None:
    build_map(BuildOptions(logs=tuple(logs), output=out, workers=workers))


def _by_person(out: Path) -> dict[str, np.ndarray]:
    """Per person (the entries nearer robot 1's or robot 2's path): the detections per
    direction bin, summed, with those without a heading last."""
    entries = load_map(out).state.entries
    rows = entries.live_rows()
    xy = entries.xyz[rows, :2]
    per_bin = np.column_stack([entries.counts[rows], entries.nodir[rows]])
    robot1 = xy[:, 0] < 16.0
    return {"A": per_bin[robot1].sum(axis=0), "B": per_bin[~robot1].sum(axis=0)}


def _assert_headings(got: dict[str, np.ndarray], per_robot: int) -> None:
    bins = len(got["A"]) - 1
    for person, heading in (("A", HEADING_A), ("B", HEADING_B)):
        want = int(direction_bins(np.array([heading]), bins)[0])
        counts = got[person]
        assert counts.sum() == per_robot, got  # each detection once: nothing lost or doubled
        # all but a track's first row (its first displacement comes with the second row)
        assert counts[want] >= per_robot - 2, (person, want, got)
        assert counts[:bins].sum() == counts[want], (person, want, got)  # no other bin


@pytest.mark.parametrize("offset_ms", [0, 300])
def test_two_robots_with_the_same_track_ids_keep_each_persons_heading(
    tmp_path: Path, offset_ms: int
) -> None:
    one, two = tmp_path / "robot1.mcap", tmp_path / "robot2.mcap"
    per_robot = write_robot(one, ROBOT1, range(DURATION_S))
    assert write_robot(two, ROBOT2, range(DURATION_S), offset_ms * 1_000_000) == per_robot
    _build([one, two], tmp_path / "fleet.aion")
    _assert_headings(_by_person(tmp_path / "fleet.aion"), per_robot)


def test_two_robots_without_track_ids_are_linked_apart(tmp_path: Path) -> None:
    """Bare positions at the same instants: each robot's rows are linked by a linker of
    their own (one linker took both robots' rows of one time for one frame)."""
    one, two = tmp_path / "robot1.mcap", tmp_path / "robot2.mcap"
    per_robot = write_robot(one, ROBOT1, range(DURATION_S), ids=False)
    write_robot(two, ROBOT2, range(DURATION_S), ids=False)
    _build([one, two], tmp_path / "fleet.aion")
    _assert_headings(_by_person(tmp_path / "fleet.aion"), per_robot)


def test_a_fleet_builds_the_same_with_two_workers(tmp_path: Path) -> None:
    """Robot 1 and robot 2 at once, robot 1 again a day later (its own shard): ``--workers 2``
    gives the map of one pass."""
    one, two, later = (tmp_path / f"{n}.mcap" for n in ("robot1", "robot2", "robot1-next"))
    write_robot(one, ROBOT1, range(DURATION_S))
    write_robot(two, ROBOT2, range(DURATION_S), 300_000_000)
    write_robot(later, ROBOT1, range(86_400, 86_400 + DURATION_S))
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build([one, two, later], seq)
    _build([one, two, later], par, workers=2)
    a, b = load_map(seq, writable=True).state, load_map(par, writable=True).state
    assert differences(a, b) == []


def test_one_robots_track_goes_on_across_two_files(tmp_path: Path) -> None:
    """One robot's log cut in two files one after the other (``rosbag record --split``):
    they overlap no other recording, so the track goes on across the seam with one estimator
    and the map is the one of the log in one file."""
    whole, first, second = tmp_path / "whole.mcap", tmp_path / "a.mcap", tmp_path / "b.mcap"
    write_robot(whole, ROBOT1, range(DURATION_S))
    write_robot(first, ROBOT1, range(DURATION_S // 2))
    write_robot(second, ROBOT1, range(DURATION_S // 2, DURATION_S))
    _build([whole], tmp_path / "whole.aion")
    _build([first, second], tmp_path / "split.aion")
    a = load_map(tmp_path / "whole.aion", writable=True).state
    b = load_map(tmp_path / "split.aion", writable=True).state
    assert differences(a, b) == []
