"""Bad log streams, one fault per test: what ``aion build`` does with several inputs of mixed
ROS versions, out-of-order log times, duplicates, zero header stamps and a clock jump. Bad log
files (truncated, corrupt, empty): ``test_bad_log_files.py``.

Every log is generated in ``tmp_path`` with ``formats.writers.LogWriter`` (and spark_dsg for the
scene graphs), with the fault placed at a known message, so each test states exactly what aion
must keep, drop (and count), or refuse with a one-line error.
"""

from __future__ import annotations

import random
import tracemalloc
from pathlib import Path

import pytest

from tests.robustness.conftest import (
    T0,
    Message,
    S,
    assert_same_arrays,
    build_json,
    graph_payload,
    map_arrays,
    person,
    robot_tf,
    scene_graph,
    walk,
    write_log,
)

# -- several inputs, order, stamps -----------------------------------------------------------


def office_messages(seconds: int) -> list[Message]:
    """TF every 5 s, a scene graph every 60 s, a person near p1 every 2 s."""
    payload = graph_payload()
    out: list[Message] = []
    for k in range(seconds):
        t = T0 + k * S
        if k % 60 == 0:
            out.append(scene_graph(t, payload))
        if k % 5 == 0:
            out.append(robot_tf(t))
        if k % 2 == 1:
            out.append(person(t, (2.1 + 0.01 * (k % 7), 0.1, 0.0), track=1 + k % 3))
    return out


def test_mixed_ros1_and_ros2_inputs_equal_one_log(tmp_path: Path) -> None:
    """A ROS 1 bag, a ROS 2 MCAP and a ROS 1-profile MCAP in one build give the same map as
    the same messages in one ROS 2 MCAP."""
    msgs = office_messages(1800)
    third = len(msgs) // 3
    parts = [
        write_log(tmp_path / "a.bag", msgs[:third], "bag"),
        write_log(tmp_path / "b.mcap", msgs[third : 2 * third], "mcap"),
        write_log(tmp_path / "c.mcap", msgs[2 * third :], "mcap-ros1"),
    ]
    mixed = build_json(*parts, "-o", tmp_path / "mixed.aion")
    single = build_json(write_log(tmp_path / "all.mcap", msgs), "-o", tmp_path / "all.aion")
    assert mixed["detections"] == single["detections"]
    assert mixed["detections"]["read"] == 900
    assert mixed["graph"]["messages"] == single["graph"]["messages"] == 30
    assert_same_arrays(map_arrays(tmp_path / "mixed.aion"), map_arrays(tmp_path / "all.aion"))


def test_out_of_order_log_times_are_read_in_time_order(tmp_path: Path) -> None:
    msgs = office_messages(1200)
    shuffled = msgs[:]
    random.Random(7).shuffle(shuffled)
    build_json(write_log(tmp_path / "shuffled.mcap", shuffled), "-o", tmp_path / "s.aion")
    build_json(write_log(tmp_path / "sorted.mcap", msgs), "-o", tmp_path / "o.aion")
    assert_same_arrays(map_arrays(tmp_path / "s.aion"), map_arrays(tmp_path / "o.aion"))


def test_duplicate_messages_are_counted_as_detections(tmp_path: Path) -> None:
    """aion does not deduplicate: a message recorded twice is two detections (same window,
    same cell), and nothing breaks."""
    msgs = walk(100)
    twice = sorted([*msgs, *msgs[10:20]], key=lambda m: m[3])
    report = build_json(write_log(tmp_path / "dup.mcap", twice), "-o", tmp_path / "d.aion")
    assert report["detections"] == {"read": 110, "used": 110, "dropped": {}}


def test_zero_header_stamps_fall_back_to_log_time(tmp_path: Path) -> None:
    """Stamps of 0 (an unset header): the log time is used (and counted in a note), so the map
    equals the map of the same log with proper stamps."""
    stamped = [person(T0 + k * S, (2.1, 0.1, 0.0)) for k in range(1300)]
    zero = [person(T0 + k * S, (2.1, 0.1, 0.0), header_ns=0) for k in range(1300)]
    a = build_json(write_log(tmp_path / "zero.mcap", zero), "-o", tmp_path / "z.aion")
    b = build_json(write_log(tmp_path / "ok.mcap", stamped), "-o", tmp_path / "k.aion")
    assert a["detections"] == b["detections"] == {"read": 1300, "used": 1300, "dropped": {}}
    # two closed windows and 100 s of the open one: 2.17 windows of recording, rounded
    assert a["windows"] == b["windows"] == 2
    assert "1,300 detections had a zero header stamp" in " ".join(a["notes"])
    assert "zero header stamp" not in " ".join(b["notes"])
    assert_same_arrays(map_arrays(tmp_path / "z.aion"), map_arrays(tmp_path / "k.aion"))


@pytest.mark.parametrize("jump_s", [3 * 86400, (2**31 - 1) - T0 // S])  # 3 days; to 2038
def test_clock_jump_is_survived_with_bounded_memory(jump_s: int, tmp_path: Path) -> None:
    """One detection stamped days (or years) ahead of the log: the build finishes, every
    detection is used or counted, memory stays small (no dense allocation over the gap).

    Known weakness (docs/ROBUSTNESS.md): the bad stamp opens a far-future window, so later
    detections in other chunks are dropped as ``before_window`` (counted, not lost silently).
    """
    before = walk(300)
    jumped = person(T0 + 300 * S, (2.1, 0.1, 0.0), header_ns=T0 + jump_s * S)
    after = walk(300, start_s=301)
    log = write_log(tmp_path / "jump.mcap", [*before, jumped, *after])
    tracemalloc.start()
    try:
        report = build_json(log, "-o", tmp_path / "j.aion", "--batch-size", "50")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    det = report["detections"]
    assert det["read"] == 601
    assert det["used"] + sum(det["dropped"].values()) == 601
    assert det["used"] >= 301  # everything up to the jump, at least
    assert peak < 200 * 2**20, peak
    assert (tmp_path / "j.aion").stat().st_size < 2 * 2**20
    # the log's time span comes from log times, not from the bad stamp
    assert report["time_span"]["end_ns"] == T0 + 600 * S
