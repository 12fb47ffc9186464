"""Simulated logs read back with the project's reader and with rosbags: types, topics, frames,
counts, and a TF chain that really maps robot-frame detections onto map-frame ones."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats.logs import open_logs
from aion_cli.formats.tf import TfBuffer
from aion_cli.sim.scenario import SceneResult, simulate
from tests.sim.conftest import PATROL
from tests.sim.logged_detections import DET, logged_detections


def test_mcap_topics_types_and_counts(patrol_scene: SceneResult) -> None:
    meta = patrol_scene.meta
    with open_logs([patrol_scene.log]) as logs:
        topics = {t.topic: (t.msgtype, t.count, t.encoding) for t in logs.topics}
    assert topics == {
        "/hydra/backend/dsg": ("hydra_msgs/msg/DsgUpdate", meta["messages"]["scene_graph"], "cdr"),
        DET: ("spencer_tracking_msgs/msg/TrackedPersons", meta["messages"]["detections"], "cdr"),
        "/tf": ("tf2_msgs/msg/TFMessage", meta["messages"]["tf"], "cdr"),
    }
    assert meta["messages"]["detections"] > 20
    assert meta["messages"]["scene_graph"] > 20


def test_frames_and_rows(patrol_scene: SceneResult) -> None:
    t, _, _, frames = logged_detections(patrol_scene)
    assert set(frames) == {"base_link"}
    assert len(t) == patrol_scene.meta["detections"]
    assert np.all(np.diff(t) >= 0)
    with open_logs([patrol_scene.log]) as logs:
        chains = set()
        for raw in logs.messages({"/tf"}):
            msg = logs.decode(raw)
            chains.add(tuple((x.header.frame_id, x.child_frame_id) for x in msg.transforms))
        dsg_frames = {logs.decode(r).header.frame_id for r in logs.messages({"/hydra/backend/dsg"})}
    assert chains == {(("map", "odom"), ("odom", "base_link"))}
    assert dsg_frames == {"map"}


def _tf_buffer(result: SceneResult) -> TfBuffer:
    with open_logs([result.log]) as logs:
        msgs = [(logs.decode(r), False) for r in logs.messages({"/tf"})]
    return TfBuffer.from_messages(msgs, tolerance_s=0.0)


def test_base_link_detections_through_tf_equal_map_frame_ones(
    patrol_scene: SceneResult, patrol_map_scene: SceneResult
) -> None:
    """Same seed, two frames: base_link rows transformed by the logged TF are the map rows."""
    t_b, xyz_b, vel_b, _ = logged_detections(patrol_scene)
    t_m, xyz_m, vel_m, frames = logged_detections(patrol_map_scene)
    assert set(frames) == {"map"}
    np.testing.assert_array_equal(t_b, t_m)
    tf = _tf_buffer(patrol_scene)
    mapped, ok = tf.transform_points("map", "base_link", t_b, xyz_b)
    assert ok.all()
    np.testing.assert_allclose(mapped, xyz_m, atol=1e-6)
    rotated, _ = tf.transform_vectors("map", "base_link", t_b, vel_b)
    np.testing.assert_allclose(rotated, vel_m, atol=1e-6)
    # and they are close to (but, with drift, not exactly) the true positions
    truth = np.load(patrol_scene.truth_npz)
    seen = truth["agent_seen"]
    err = np.linalg.norm(mapped[:, :2] - truth["agent_xyz"][seen][:, :2], axis=1)
    assert err.max() < 1.5
    assert np.median(err) < 0.5


def test_map_odom_jumps_at_loop_closures(patrol_scene: SceneResult) -> None:
    """map→odom is constant between loop closures and changes exactly at them."""
    truth = np.load(patrol_scene.truth_npz)
    closures = truth["loop_closure_t_ns"]
    assert len(closures) >= 3
    with open_logs([patrol_scene.log]) as logs:
        rows = []
        for raw in logs.messages({"/tf"}):
            tr = logs.decode(raw).transforms[0].transform
            rows.append((raw.log_time_ns, tr.translation.x, tr.translation.y, tr.rotation.z))
    arr = np.array(rows)
    change = np.flatnonzero(np.any(np.abs(np.diff(arr[:, 1:], axis=0)) > 1e-12, axis=1)) + 1
    np.testing.assert_array_equal(arr[change, 0].astype(np.int64), closures[: len(change)])
    assert len(change) == len(closures)


@pytest.mark.parametrize(
    ("fmt", "dsg_topic", "suffix"),
    [("bag", "/hydra_ros_node/backend/dsg", ".bag"), ("rosbag2", "/hydra/backend/dsg", "")],
)
def test_bag_and_rosbag2_read_with_rosbags(
    tmp_path: Path, fmt: str, dsg_topic: str, suffix: str
) -> None:
    from rosbags.highlevel import AnyReader

    config = replace(
        PATROL, days=0.75 / 24, format=fmt, detection_type="people", start="2026-01-05T12:00"
    )
    result = simulate(config, tmp_path / "scene")[0]
    assert result.log == tmp_path / f"scene{suffix}"
    counts: dict[tuple[str, str], int] = {}
    names: set[str] = set()
    with AnyReader([result.log]) as reader:
        for conn, _, raw in reader.messages():
            key = (conn.topic, conn.msgtype)
            counts[key] = counts.get(key, 0) + 1
            if conn.topic == "/people":
                msg = reader.deserialize(raw, conn.msgtype)
                assert msg.header.frame_id == "base_link"
                names |= {p.name for p in msg.people}
    m = result.meta["messages"]
    zone = {("/aion/timezone", "std_msgs/msg/String"): 1} if fmt == "bag" else {}  # UTC
    assert counts == {
        (dsg_topic, "hydra_msgs/msg/DsgUpdate"): m["scene_graph"],
        ("/people", "people_msgs/msg/People"): m["detections"],
        ("/tf", "tf2_msgs/msg/TFMessage"): m["tf"],
        **zone,
    }
    assert m["detections"] > 0
    assert all(n.isdigit() for n in names)


def test_detection_topic_exists_even_when_nobody_walks(tmp_path: Path) -> None:
    """Like a live tracker, the simulator publishes empty messages while nobody is seen."""
    config = replace(PATROL, agents=0, days=0.25 / 24, start="2026-01-05T03:00")
    result = simulate(config, tmp_path / "night.mcap")[0]
    with open_logs([result.log]) as logs:
        topics = {t.topic: t.count for t in logs.topics}
        sizes = {len(logs.decode(r).tracks) for r in logs.messages({DET})}
    assert topics[DET] == result.meta["messages"]["detections"] >= 15 * 60 // 10
    assert sizes == {0}


def test_a_scene_ends_before_the_next_one_starts(tmp_path: Path) -> None:
    """A scene of d days covers [start, start + d): the scene that starts where it ends shares
    no instant with it, so the two build into parts that merge (a last tick at the end had put
    both days' scenes at midnight)."""
    config = replace(PATROL, agents=0, days=0.25 / 24, start="2026-01-05T03:00")
    first = simulate(config, tmp_path / "a.mcap")[0]
    second = simulate(replace(config, start="2026-01-05T03:15"), tmp_path / "b.mcap")[0]
    spans = []
    for result in (first, second):
        with open_logs([result.log]) as logs:
            times = np.array([r.log_time_ns for r in logs.messages(None)], dtype=np.int64)
        spans.append((int(times.min()), int(times.max())))
    start = np.datetime64("2026-01-05T03:00", "ns").astype(np.int64)
    quarter = 15 * 60 * 10**9
    assert spans[0][0] == start
    assert spans[1][0] == start + quarter
    assert start + quarter - 10**9 <= spans[0][1] < start + quarter  # ends within its last second


def test_a_day_the_clocks_go_forward_is_23_hours_of_ticks(tmp_path: Path) -> None:
    """Berlin, Sunday 2026-03-29 (02:00 -> 03:00): one day from local midnight ends before
    Monday's local midnight (23 hours of ticks), so Monday's scene follows it without sharing
    an hour (a day of 24 elapsed hours ran to 01:00 on Monday)."""
    from tests.sim.conftest import FIXED

    config = replace(FIXED, agents=0, days=1.0, start="2026-03-29", timezone="Europe/Berlin")
    result = simulate(config, tmp_path / "sunday.mcap")[0]
    with open_logs([result.log]) as logs:
        times = np.array([r.log_time_ns for r in logs.messages(None)], dtype=np.int64)
    sunday = np.datetime64("2026-03-28T23:00", "ns").astype(np.int64)  # 00:00 CET
    monday = np.datetime64("2026-03-29T22:00", "ns").astype(np.int64)  # 00:00 CEST
    assert int(times.min()) == sunday
    assert monday - 60 * 10**9 <= int(times.max()) < monday  # 23 hours of ticks, none after
