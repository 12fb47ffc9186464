"""Positions beyond the spatial hash's range (``engine.spatial_hash``: 2^20 cells from the
origin, 524,288 m at the default ``cell_size`` of 0.5 m) in a log: a detection there is dropped
and counted as ``out_of_range``, as a non-finite one is as ``nan``; a robot pose there is
dropped as a non-finite pose is (it says nothing of what was seen). Before stop 70 such a pose
was kept: its squared distances (``engine.sensor_reach``) overflowed to inf, numpy's
RuntimeWarning printed raw on the build's stderr."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats.mapfile import read_map
from tests.robustness.conftest import T0, S, build_json, person, robot_tf, run, write_log


def _far_tf(t_ns: int) -> tuple:
    topic, kind, msg, t = robot_tf(t_ns)
    msg = copy.deepcopy(msg)
    msg["transforms"][0]["transform"]["translation"]["x"] = 1e300
    return topic, kind, msg, t


@pytest.mark.filterwarnings("error::RuntimeWarning")  # the far pose's overflow, printed raw
def test_a_far_pose_and_a_far_detection_are_dropped_and_the_map_loads(tmp_path: Path) -> None:
    people = [person(T0 + k * 10 * S, (2.0 + k % 3, 1.0, 0.0)) for k in range(60)]
    people.append(person(T0 + 305 * S, (-1e300, 1.0, 0.0)))  # one far detection
    poses = [robot_tf(T0 + k * 5 * S) for k in range(121)]
    poses[40] = _far_tf(T0 + 200 * S)  # one far robot pose among 121
    log = write_log(tmp_path / "far.mcap", sorted(people + poses, key=lambda m: m[3]))
    out = tmp_path / "far.aion"
    report = build_json(log, "-o", out)
    detections = report["detections"]
    assert detections["dropped"]["out_of_range"] == 1, detections
    assert detections["used"] == 60, detections
    arrays, _ = read_map(out)
    poses_xy = np.asarray(arrays["obs_pose_xy"])
    assert len(poses_xy) > 0  # the robot's other poses are kept (the same pose: stored once)
    assert np.abs(poses_xy).max() < 10.0  # the far one is not
    result = run("predict", out, "--historical", "--format", "json")
    assert result.exit_code == 0, result.stderr
    assert json.loads(result.stdout)
