"""ROS 1 ``time`` counts unsigned 32-bit seconds, valid to 2106: a ROS 1 log recorded after
2038-01-19 03:14:07 UTC reads as the same log recorded earlier. Before, the TF and scene-graph
stamps of such a log were read as signed seconds (as rosbags reads ROS 2's
``builtin_interfaces/Time``), 2^32 s early: a 2040 bag's TF lay in 1903, so every detection in
``base_link`` was dropped (``no_transform``) and the build refused the log, saying that TF and
the detections were stamped on different clocks."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.robustness.conftest import (
    T0,
    S,
    build_json,
    graph_payload,
    person,
    robot_tf,
    scene_graph,
    write_log,
)

T2040 = 2_208_988_800 * S + 9 * 3600 * S
"""2040-01-01 09:00 UTC (a Sunday, as is T0's day): 2^31 s lie between it and 1970."""


def _log(path: Path, container: str, t0: int) -> Path:
    """People in ``base_link`` for 40 s, the robot's TF every 5 s and a scene graph, from
    ``t0`` (log times and header stamps alike)."""
    msgs = [
        *[person(t0 + k * S, (2.1, 0.1, 0.0), frame="base_link") for k in range(40)],
        *[robot_tf(t0 + 5 * k * S) for k in range(9)],
        scene_graph(t0 + 1, graph_payload()),
    ]
    return write_log(path, sorted(msgs, key=lambda m: m[3]), container)


@pytest.mark.parametrize("container", ["bag", "mcap-ros1"])
def test_a_ros1_log_after_2038_builds_as_the_same_log_before(
    tmp_path: Path, container: str
) -> None:
    suffix = ".bag" if container == "bag" else ".mcap"
    assert T0 // S < 2**31 <= T2040 // S < 2**32
    early = build_json(_log(tmp_path / f"early{suffix}", container, T0), "-o", tmp_path / "e.aion")
    late = build_json(_log(tmp_path / f"late{suffix}", container, T2040), "-o", tmp_path / "l.aion")
    assert late["detections"] == early["detections"]
    assert late["detections"]["used"] == 40
    assert late["graph"]["decoded"] == early["graph"]["decoded"] == 1
    assert late["nodes"] == early["nodes"]
    assert late["time_span"]["start_ns"] - early["time_span"]["start_ns"] == T2040 - T0
    assert late["time_span"]["seconds"] == early["time_span"]["seconds"]
