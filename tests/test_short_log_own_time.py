"""A short log (ten messages or fewer per topic) recorded days away from a bigger log is a
recording of its own, not a stray clock (docs/ROBUSTNESS.md, time sanity): one build of both
keeps its robot poses, scene graphs and detections, as a build of it alone does (its own
shard of a ``--workers`` build, or ``--map``), so both routes give one map.

The short log here is the office log (tests/cli/logdata.py) cut to 40 s two days after the
big one: 8 robot poses (every 5 s), 1 scene graph, 4 ``/tracks`` messages."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.mapquery import load_map
from tests.cli.logdata import ROBOT_XYZ, T0, Expected, S, write_office_log
from tests.time_shard_logs import build_logs, same_maps

DAY_S = 86_400
SHORT_S = 40  # 8 poses, 1 graph, 4 tracks messages: every topic within the stray rule's 10


def _short(path: Path, **kw: object) -> Expected:
    """The short log, two days after T0."""
    return write_office_log(path, shift_s=2 * DAY_S, duration_s=SHORT_S, **kw)  # type: ignore[arg-type]


def _both_routes(tmp_path: Path, logs: list[Path], **kw: object) -> tuple[object, object]:
    """The sequential and the 2-worker build of ``logs``: one map, two shards."""
    one = build_logs(logs, tmp_path / "one.aion", 1, **kw)
    two = build_logs(logs, tmp_path / "two.aion", 2, **kw)
    assert len(two.workers) == 2  # type: ignore[attr-defined]
    assert same_maps(tmp_path / "one.aion", tmp_path / "two.aion") == []
    return one, two


def test_a_short_robot_log_days_away_keeps_its_poses_in_one_pass(tmp_path: Path) -> None:
    """One pass dropped the short log's 8 poses as strays of the big log's trajectory (and
    read the log as a fixed sensor: its window observed everywhere), while its own shard
    kept them. Now both keep them: the map's open window holds exactly the 8 poses written,
    at the robot's place, and the robot observes the short log."""
    big, short = tmp_path / "big.mcap", tmp_path / "short.mcap"
    wrote = write_office_log(big, graph=False, duration_s=3600)
    few = _short(short, graph=False)
    assert few.tf_messages == 8
    assert few.track_messages == 4
    one, _ = _both_routes(tmp_path, [big, short])
    report = one.to_dict()  # type: ignore[attr-defined]
    assert report["observation"] == "tf map->base_link"
    assert not [w for w in report["warnings"] if "robot pose(s) ignored" in w]
    assert report["log_times_dropped"] == {}
    assert report["detections"]["used"] == wrote.detections + few.detections
    state = load_map(tmp_path / "one.aion").state
    start = T0 + 2 * DAY_S * S
    assert state.observation.pose_t.tolist() == [start + k * 5 * S for k in range(8)]
    assert np.array_equal(state.observation.pose_xy, np.tile(ROBOT_XYZ[:2], (8, 1)))


def test_a_stray_pose_stamped_in_a_log_without_tf_is_still_dropped(tmp_path: Path) -> None:
    """The exemption is for a log's own trajectory: a pose whose stamp lies two days away,
    inside a fixed sensor's short log (no ``/tf``), sent by a log whose other poses lie
    elsewhere, is still a stray for both routes, and the short log a fixed sensor."""
    from aion_cli.formats.writers import LogWriter

    big, odd, short = tmp_path / "big.mcap", tmp_path / "odd.mcap", tmp_path / "short.mcap"
    write_office_log(big, graph=False, duration_s=3600)
    with LogWriter(odd) as writer:  # the big log's robot: a last pose stamped two days on
        t = T0 + 3600 * S
        stamp = T0 + (2 * DAY_S + 10) * S
        writer.write("/tf", "tf2_msgs/msg/TFMessage", {"transforms": [{
            "header": {"stamp": {"sec": stamp // S, "nanosec": 0}, "frame_id": "map"},
            "child_frame_id": "base_link",
            "transform": {"translation": {"x": 9.0, "y": 0.0, "z": 0.0},
                          "rotation": {"w": 1.0}},
        }]}, t)
    _short(short, graph=False, tf=False)  # a fixed sensor recording at that stamp
    one, _ = _both_routes(tmp_path, [big, odd, short])
    report = one.to_dict()  # type: ignore[attr-defined]
    assert [w for w in report["warnings"] if w.startswith("1 robot pose(s) ignored")]
    assert report["observation"].startswith("tf map->base_link + fixed sensor over the 1 window")


def test_a_short_log_of_scene_graphs_days_away_is_kept_by_both_routes(tmp_path: Path) -> None:
    """The same for a robot seen by the scene graphs' agent layer (no TF): the short log's
    one graph message and its detections are kept by one pass as by its own shard."""
    big, short = tmp_path / "big.mcap", tmp_path / "short.mcap"
    wrote = write_office_log(big, tf=False, agents=True, duration_s=3600)
    few = _short(short, tf=False, agents=True)
    assert few.graph_messages == 1
    one, two = _both_routes(tmp_path, [big, short])
    for report in (one.to_dict(), two.to_dict()):  # type: ignore[attr-defined]
        assert report["observation"] == "scene-graph agent layer"
        assert report["log_times_dropped"] == {}
        assert report["graph"]["messages"] == wrote.graph_messages + few.graph_messages
        assert report["detections"]["used"] == wrote.detections + few.detections


def test_observed_spans_over_a_short_log_days_away_are_kept_by_both_routes(
    tmp_path: Path,
) -> None:
    """A fixed sensor's short log with ``--observed`` over its hour: its 4 messages are its own
    time, and the declared hour (six windows) is observed by one pass as by its shard."""
    big, short = tmp_path / "big.mcap", tmp_path / "short.mcap"
    wrote = write_office_log(big, tf=False, graph=False, duration_s=3600)
    few = _short(short, tf=False, graph=False)
    hour = T0 + 2 * DAY_S * S
    declared = ((T0, T0 + 3600 * S), (hour, hour + 3600 * S))
    one, two = _both_routes(tmp_path, [big, short], observed=declared)
    for report in (one.to_dict(), two.to_dict()):  # type: ignore[attr-defined]
        assert report["log_times_dropped"] == {}
        assert report["detections"]["used"] == wrote.detections + few.detections
        assert report["windows"] == 12  # the big log's hour and the declared one
