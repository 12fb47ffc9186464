"""Time shards: ``aion build LOG --workers N`` cuts one long log at quiet moments and gives the
map of the sequential build.

The cut rule (:func:`aion_cli.time_shards.cut_times`) is checked on times worked out by hand;
the builds compare the two maps as saved with :func:`aion_cli.engine.compare.differences`
(ints exact, floats 1e-12), on office logs of known contents (``tests/cli/logdata.py``) that
hold several two-hour sessions in one file, in every container and with every observation
source (robot TF, fixed sensor, scene-graph agents).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.engine.compare import differences
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from aion_cli.time_shards import QUIET_NS, GroupTimes, cut_times, parts_of
from tests.cli.logdata import T0, S, write_office_log

HOUR_S = 3600
W = 600 * S  # the default window
# Monday 08:00 (the log's first session), Monday 18:00, Wednesday 08:00, Thursday 10:00
LATER_S = (10 * HOUR_S, 48 * HOUR_S, 74 * HOUR_S)


def _times(
    detections: list[int], others: tuple[int, ...] = (), recorded: tuple[int, ...] = ()
) -> GroupTimes:
    det = np.sort(np.asarray(detections, np.int64))
    span = np.sort(np.concatenate([det, np.asarray(others, np.int64)]))
    windows = np.union1d(span // W, np.asarray(recorded, np.int64))
    return GroupTimes(det, span, windows)


def _every_10_s(start_s: int, stop_s: int) -> list[int]:
    return [t * S for t in range(start_s, stop_s, 10)]


# -- the cut rule -----------------------------------------------------------------------------
def test_a_cut_is_the_window_start_after_a_burst_when_the_10_s_before_it_are_quiet() -> None:
    # a burst until 995 s (window 1: 600..1200 s), the next one from 5,000 s
    times = _times(_every_10_s(5, 1000) + _every_10_s(5005, 6000))
    assert cut_times(times, W, 2) == [1200 * S]


def test_a_burst_ending_within_10_s_of_a_window_start_is_cut_one_window_later() -> None:
    # the last message at 1,195 s lies within 10 s of 1,200 s: the cut moves to 1,800 s,
    # since window 2 (1,200..1,800 s) holds nothing at all
    times = _times(_every_10_s(5, 1200) + _every_10_s(5005, 6000))
    assert cut_times(times, W, 2) == [1800 * S]
    # ... and cannot move when window 2 recorded something (e.g. a topic aion does not use):
    # one pass observes that window, and neither part would close it
    assert cut_times(_times(times.detections.tolist(), recorded=(2,)), W, 2) == []


def test_a_stream_without_a_quiet_window_start_is_not_cut() -> None:
    # people every 10 s at 5, 15, ... s: each window start has a message 5 s before it
    assert cut_times(_times(_every_10_s(5, 20_000)), W, 4) == []
    # a quiet moment only before the first detection: nothing on one side, no cut
    quiet_first = _times(_every_10_s(1805, 4000), others=(0, 300 * S))
    assert cut_times(quiet_first, W, 2) == []


def test_cuts_split_the_detection_messages_evenly() -> None:
    # three bursts of 100, 100 and 200 messages, hours apart: two parts are cut before the
    # third (at the window start after b's last message, 10,995 s), four parts at both gaps
    # (a burst is never cut inside)
    a = _every_10_s(5, 1005)
    b = _every_10_s(10_005, 11_005)
    c = _every_10_s(20_005, 22_005)
    times = _times(a + b + c)
    assert cut_times(times, W, 2) == [11_400 * S]  # 200 before, 200 after
    assert cut_times(times, W, 4) == [1200 * S, 11_400 * S]
    assert cut_times(times, W, 1) == []


def test_span_messages_other_than_detections_decide_where_a_part_ends() -> None:
    # people until 1,195 s (too close to 1,200 s), then a TF message at 1,500 s in window 2:
    # the cut cannot skip window 2 (it holds a message one pass observes with), so the part
    # before the cut ends with it, and the cut is 1,800 s
    times = _times(_every_10_s(5, 1200) + _every_10_s(5005, 6000), others=(1500 * S,))
    assert cut_times(times, W, 2) == [1800 * S]
    # with people until 995 s, 1,200 s is quiet and comes first (the TF message then opens
    # the part after it)
    times = _times(_every_10_s(5, 1000) + _every_10_s(5005, 6000), others=(1500 * S,))
    assert cut_times(times, W, 2) == [1200 * S]
    assert QUIET_NS == 10 * S


def test_parts_cover_all_log_time() -> None:
    parts = parts_of([1200 * S, 1800 * S])
    assert [p[1] for p in parts[:-1]] == [p[0] for p in parts[1:]]
    assert parts[1] == (1200 * S, 1800 * S)
    assert parts[0][0] < 0 < 2**62 < parts[-1][1]


# -- builds -----------------------------------------------------------------------------------
def _build(logs: list[Path], out: Path, workers: int, **kw: object):  # type: ignore[no-untyped-def]
    out.unlink(missing_ok=True)
    return build_map(BuildOptions(logs=tuple(logs), output=out, workers=workers, **kw))  # type: ignore[arg-type]


def _same_maps(a: Path, b: Path) -> list[str]:
    return differences(load_map(a, writable=True).state, load_map(b, writable=True).state)


def _same_reports(one: object, two: object) -> None:
    a, b = one.to_dict(), two.to_dict()  # type: ignore[attr-defined]
    for key in ("detections", "detections_by_topic", "headings", "observation", "time_span"):
        assert a[key] == b[key], key
    assert a["graph"]["messages"] == b["graph"]["messages"]


@pytest.mark.parametrize(
    ("container", "source"),
    [
        ("mcap", "tf"),
        ("mcap", "fixed"),
        ("mcap", "agents"),
        ("bag", "tf"),
        ("rosbag2-sqlite3", "fixed"),
        ("rosbag2-mcap", "tf"),
    ],
)
def test_one_log_is_cut_into_time_shards_and_gives_the_sequential_map(
    tmp_path: Path, container: str, source: str
) -> None:
    names = {"bag": "log.bag", "rosbag2-sqlite3": "log", "rosbag2-mcap": "log"}  # folders
    log = tmp_path / names.get(container, "log.mcap")
    write_office_log(
        log,
        container,
        tf=source == "tf",
        agents=source == "agents",
        duration_s=2 * HOUR_S,
        later_sessions_s=LATER_S,
    )
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = _build([log], seq, 1)
    two = _build([log], par, 2)
    assert _same_maps(seq, par) == []
    _same_reports(one, two)
    rows = two.workers
    assert [(r["from"], r["to"]) for r in rows] == [
        ("start", "2026-11-23 20:10:00 UTC"),  # the sessions' detections split 2 + 2
        ("2026-11-23 20:10:00 UTC", "end"),
    ]
    assert sum(r["detections_used"] for r in rows) == one.detections_used
    assert any("cut into 2 time shards" in n for n in two.notes)
    assert not any("in sequence" in n for n in two.notes)
    assert load_map(par).state.temporal.flow_scored.sum() > 0  # held days scored at the join


def test_time_shards_continue_a_map_like_the_sequential_build(tmp_path: Path) -> None:
    first, rest = tmp_path / "first.mcap", tmp_path / "rest.mcap"
    write_office_log(first, duration_s=2 * HOUR_S)
    write_office_log(rest, shift_s=LATER_S[0], duration_s=2 * HOUR_S,
                     later_sessions_s=tuple(s - LATER_S[0] for s in LATER_S[1:]))
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build([first], seq, 1)
    _build([first], par, 1)
    build_map(BuildOptions(logs=(rest,), output=seq, continue_from=seq, workers=1))
    report = build_map(BuildOptions(logs=(rest,), output=par, continue_from=par, workers=2))
    assert len(report.workers) == 2  # both parts held their days for the joins
    assert _same_maps(seq, par) == []


def _joined(out: Path, logs: list[Path]) -> Path:
    """One log holding every message of ``logs`` (in log-time order)."""
    from aion_cli.formats.logs import open_logs
    from aion_cli.formats.writers import LogWriter

    with open_logs(logs) as logset, LogWriter(out) as writer:
        for msg in logset.messages():
            writer.write_raw(msg.topic, msg.msgtype, msg.data, msg.log_time_ns)
    return out


def test_a_part_that_cannot_be_joined_is_learnt_in_sequence_onto_the_map(tmp_path: Path) -> None:
    # the graph is published in the first two sessions only: the second part has none of its
    # own while the map before it has one, so one pass's map needs it learnt in sequence
    with_graph, without = tmp_path / "a.mcap", tmp_path / "b.mcap"
    write_office_log(with_graph, duration_s=2 * HOUR_S, later_sessions_s=LATER_S[:1])
    write_office_log(without, graph=False, shift_s=LATER_S[1], duration_s=2 * HOUR_S,
                     later_sessions_s=(LATER_S[2] - LATER_S[1],))
    log = _joined(tmp_path / "log.mcap", [with_graph, without])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build([log], seq, 1)
    report = _build([log], par, 2)
    notes = [n for n in report.notes if "in sequence" in n]
    assert len(notes) == 1
    assert "no scene graph" in notes[0]
    assert _same_maps(seq, par) == []


def test_a_stray_message_is_dropped_and_counted_once(tmp_path: Path) -> None:
    # one people message ten days after the log: the time rules drop it in every part, and
    # the report counts it once, as the sequential build does
    log, stray = tmp_path / "a.mcap", tmp_path / "stray.mcap"
    write_office_log(log, duration_s=2 * HOUR_S, later_sessions_s=LATER_S)
    from aion_cli.formats.writers import LogWriter

    with LogWriter(stray) as writer:
        from tests.cli.logdata import _tracked_persons

        t = T0 + 10 * 86_400 * S
        writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons",
                     _tracked_persons(t, t, "map"), t)
    joined = _joined(tmp_path / "log.mcap", [log, stray])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = _build([joined], seq, 1)
    two = _build([joined], par, 2)
    assert one.time_dropped == {"/tracks": {"out_of_range": 0, "stray": 1}}
    assert two.time_dropped == one.time_dropped
    assert len(two.workers) == 2
    assert _same_maps(seq, par) == []


def test_a_dask_cluster_builds_time_shards(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed")
    log = tmp_path / "log.mcap"
    write_office_log(log, duration_s=2 * HOUR_S, later_sessions_s=LATER_S)
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build([log], seq, 1)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
        host="127.0.0.1",
    ) as cluster:
        report = _build([log], par, 1, scheduler=cluster.scheduler_address)
    assert len(report.workers) == 2
    assert _same_maps(seq, par) == []


def _second_part_in_sequence(tmp_path: Path, log: Path, why: str) -> tuple[Any, Any]:
    """The sequential and the 2-worker build of ``log``: two time shards, the second learnt
    in sequence onto the first for ``why`` (a note says so), the map of one pass."""
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = _build([log], seq, 1)
    two = _build([log], par, 2)
    assert len(two.workers) == 2
    notes = [n for n in two.notes if "in sequence" in n]
    assert len(notes) == 1
    assert why in notes[0]
    assert _same_maps(seq, par) == []
    return one, two


def _standing(path: Path, sessions: list[tuple[int, list[float]]]) -> Path:
    """People standing still (no velocity) whose poses carry a yaw: per session (start
    seconds after T0, one yaw per person), a message every 10 s for 20 minutes."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path) as writer:
        for start_s, yaws in sessions:
            for k in range(120):
                t = T0 + (start_s + 5 + 10 * k) * S
                tracks = [
                    {
                        "track_id": i + 1,
                        "is_matched": True,
                        "pose": {"pose": {
                            "position": {"x": 2.0 + 2 * i, "y": 0.5, "z": 0.0},
                            "orientation": {"z": np.sin(yaw / 2), "w": np.cos(yaw / 2)},
                        }},
                        "twist": {"twist": {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}}},
                    }
                    for i, yaw in enumerate(yaws)
                ]
                stamp = {"sec": t // S, "nanosec": t % S}
                writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons",
                             {"header": {"stamp": stamp, "frame_id": "map"}, "tracks": tracks}, t)
    return path


def test_orientations_judged_alike_at_a_part_start_join_once_the_plan_saw_them_vary(
    tmp_path: Path,
) -> None:
    # aion sets aside pose orientations that have never varied (a tracker leaving them at
    # identity). The morning's two people face apart, so one pass keeps every yaw after it;
    # the evening's one person, alone, faces one way: a part starting there, judged from
    # scratch, would set the yaw aside. The plan reads the first messages, sees the
    # orientations vary in the morning, and starts the evening's part as one pass reaches
    # it: the parts join in parallel into the map of one pass.
    log = _standing(tmp_path / "log.mcap", [(0, [0.0, 1.5]), (10 * HOUR_S, [0.7])])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = _build([log], seq, 1)
    two = _build([log], par, 2)
    assert len(two.workers) == 2
    assert not [n for n in two.notes if "in sequence" in n]
    assert _same_maps(seq, par) == []
    assert one.headings == two.headings
    assert one.headings.get("pose_yaw", 0) == 120 * 3  # every yaw kept, the evening's too


def test_a_later_log_starts_with_the_orientations_of_the_logs_before(tmp_path: Path) -> None:
    # The same across two logs a day apart (two shards of logs, not of time): the second
    # log's one person would lose the yaw judged alone; the plan starts it as one pass does.
    first = _standing(tmp_path / "a.mcap", [(0, [0.0, 1.5])])
    second = _standing(tmp_path / "b.mcap", [(30 * HOUR_S, [0.7])])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = _build([first, second], seq, 1)
    two = _build([first, second], par, 2)
    assert len(two.workers) == 2
    assert not [n for n in two.notes if "in sequence" in n]
    assert _same_maps(seq, par) == []
    assert one.headings.get("pose_yaw", 0) == two.headings.get("pose_yaw", 0) == 120 * 3


def test_logs_that_start_in_a_continued_maps_open_window_are_learnt_in_sequence(
    tmp_path: Path,
) -> None:
    # The map's last message and the new logs' first fall in one window: one pass continues
    # that window with the new messages, which a join cannot (before: an internal error).
    # The first group is learnt in sequence onto the map, the later one joins.
    first = _standing(tmp_path / "a.mcap", [(0, [0.0, 1.5])])  # messages 5 .. 1195 s
    second = _standing(tmp_path / "b.mcap", [(1192, [0.3, 1.0])])  # from 1197 s
    third = _standing(tmp_path / "c.mcap", [(30 * HOUR_S, [0.7, 2.0])])
    base = tmp_path / "base.aion"
    _build([first], base, 1)
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build([second, third], seq, 1, continue_from=base)
    two = _build([second, third], par, 2, continue_from=base)
    assert len(two.workers) == 2
    notes = [n for n in two.notes if "in sequence" in n]
    assert len(notes) == 1
    assert "b.mcap was learnt" in notes[0]
    assert "a time window the map before them had already recorded" in notes[0]
    assert _same_maps(seq, par) == []


def test_orientations_the_plan_did_not_read_are_learnt_in_sequence(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The same log with the plan's scan switched off: the evening's part is judged from
    # scratch, the join sees that it set a yaw aside that one pass keeps, and learns the part
    # in sequence, continuing the rule's state: the map of one pass.
    import aion_cli.shard_yaws

    monkeypatch.setattr(aion_cli.shard_yaws, "SCAN_MESSAGES", 0)
    log = _standing(tmp_path / "log.mcap", [(0, [0.0, 1.5]), (10 * HOUR_S, [0.7])])
    one, two = _second_part_in_sequence(tmp_path, log, "orientations on /tracks")
    assert one.headings == two.headings
    assert one.headings.get("pose_yaw", 0) == 120 * 3


def test_a_wrong_orientation_assumption_is_caught_at_the_join(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # One person facing one way all day: one pass sets every yaw aside. A plan that wrongly
    # claims the orientations varied at the start would make the evening's part keep its
    # yaws; the join checks the claim against the state the morning's part left, and learns
    # the part in sequence instead: the map of one pass, no yaw kept.
    import aion_cli.shard_yaws

    wrong = {"/tracks": T0}
    monkeypatch.setattr(aion_cli.shard_yaws, "varied_by", lambda logset, plan, opts: wrong)
    log = _standing(tmp_path / "log.mcap", [(0, [0.7]), (10 * HOUR_S, [0.7])])
    one, two = _second_part_in_sequence(tmp_path, log, "started as if the pose orientations")
    assert one.headings == two.headings
    assert one.headings.get("pose_yaw", 0) == 0


def test_orientations_that_vary_in_every_part_join_in_parallel(tmp_path: Path) -> None:
    log = _standing(tmp_path / "log.mcap", [(0, [0.0, 1.5]), (10 * HOUR_S, [0.7, -1.0])])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build([log], seq, 1)
    two = _build([log], par, 2)
    assert len(two.workers) == 2
    assert not [n for n in two.notes if "in sequence" in n]
    assert _same_maps(seq, par) == []


def _hydra_sessions(path: Path, graphs: list[object]) -> Path:
    """Sessions a day apart (20 minutes each, from Monday 08:00): people every 10 s (the
    office log's), a robot pose every 5 s, and a Hydra graph (``graphs``, one per session, or
    a list of them: the first for the session's first ten minutes, the second after) every
    60 s."""
    from aion_cli.formats.writers import LogWriter
    from tests.cli.logdata import _tracked_persons

    with LogWriter(path) as writer:
        for day, graph in enumerate(graphs):
            halves = graph if isinstance(graph, list) else [graph, graph]
            payloads = [
                np.frombuffer(g.to_binary(False), dtype=np.uint8)  # type: ignore[attr-defined]
                for g in halves
            ]
            start = T0 + day * 86_400 * S
            for k in range(1200):
                t = start + k * S
                payload = payloads[k >= 600]
                if k % 60 == 0:
                    stamp = {"sec": t // S, "nanosec": t % S}
                    writer.write("/hydra/backend/dsg", "hydra_msgs/msg/DsgUpdate",
                                 {"header": {"stamp": stamp, "frame_id": "map"},
                                  "layer_contents": payload, "full_update": True}, t)
                if k % 10 == 5:
                    writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons",
                                 _tracked_persons(t, start, "map"), t)
                if k % 5 == 0:  # the robot (so the first graph is not read for agents)
                    stamp = {"sec": t // S, "nanosec": t % S}
                    writer.write("/tf", "tf2_msgs/msg/TFMessage", {"transforms": [{
                        "header": {"stamp": stamp, "frame_id": "map"},
                        "child_frame_id": "base_link",
                        "transform": {"translation": {"x": 3.0}, "rotation": {"w": 1.0}},
                    }]}, t)
    return path


def test_a_part_whose_graphs_would_pin_another_layer_is_learnt_in_sequence(
    tmp_path: Path,
) -> None:
    # Monday's Hydra graphs hold 3D places only: one pass pins that layer for the rest of the
    # log, so Tuesday's graphs (3D and 2D places) are read by their 3D places too. A part
    # starting on Tuesday, alone, would choose the 2D places: the join sees the other layer,
    # and the part is learnt in sequence with the pinned one.
    from tests.formats.dsg_builders import hydra_graph

    log = _hydra_sessions(tmp_path / "log.mcap", [hydra_graph(False), hydra_graph(True)])
    one, two = _second_part_in_sequence(tmp_path, log, "navigational layer")
    assert one.graph_layer == two.graph_layer == "PLACES (3)"


def _grown(graph: Any, place: int = 99) -> Any:
    """``graph`` with one more 3D place (as Hydra adds places while the robot explores)."""
    import spark_dsg as dsg

    attrs = dsg.PlaceNodeAttributes()
    attrs.position = np.array([2.0, -2.0, 1.0])
    attrs.distance = 0.5
    attrs.real_place = True
    graph.add_node(dsg.DsgLayers.PLACES, dsg.NodeSymbol("p", place), attrs)
    return graph


def test_a_log_whose_graph_changes_in_a_later_part_is_not_cut(tmp_path: Path) -> None:
    # Tuesday's Hydra graph gains a place halfway through the session: a part starting on
    # Tuesday, built apart, would bind cells as that graph changes after its first day,
    # which its join cannot replay (it would be learnt twice). The planner compares the
    # part's first and last graph, leaves the log whole and says why; the map is one pass's.
    from tests.formats.dsg_builders import hydra_graph

    tuesday = [hydra_graph(False), _grown(hydra_graph(False))]
    log = _hydra_sessions(tmp_path / "log.mcap", [hydra_graph(False), tuesday])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build([log], seq, 1)
    two = _build([log], par, 2)
    assert two.workers == []
    assert [n for n in two.notes if "not cut into time shards: its scene graph changes after" in n]
    assert not [n for n in two.notes if "no quiet moment" in n]
    assert _same_maps(seq, par) == []


def test_a_log_whose_graph_stays_in_each_later_part_is_still_cut(tmp_path: Path) -> None:
    # The same log with Tuesday's graph the same all session (another than Monday's): the
    # later part's first and last graph agree, so the log is cut and the parts join.
    from tests.formats.dsg_builders import hydra_graph

    log = _hydra_sessions(tmp_path / "log.mcap", [hydra_graph(False), _grown(hydra_graph(False))])
    two = _build([log], tmp_path / "par.aion", 2)
    assert len(two.workers) == 2
    assert not [n for n in two.notes if "not cut" in n]


def test_places_changed_compares_ids_and_moves_beyond_the_tolerance() -> None:
    from aion_cli.engine.types import GraphSnapshot, Layer
    from aion_cli.shard_graphs import places_changed

    def snap(ids: list[int], xyz: list[tuple[float, float, float]]) -> GraphSnapshot:
        layer = Layer(np.array(ids, np.uint64), np.array(xyz, float), np.zeros(len(ids), np.uint64))
        return GraphSnapshot(0, layer, np.zeros((0, 2), np.int64))

    a = snap([1, 2, 3], [(0, 0, 0), (1, 0, 0), (2, 0, 0)])
    shuffled = snap([3, 1, 2], [(2, 0, 0), (0, 0, 0), (1, 0, 0)])
    drifted = snap([1, 2, 3], [(0, 0.2, 0), (1, 0, 0), (2, 0, 0)])
    moved = snap([1, 2, 3], [(0, 0.3, 0), (1, 0, 0), (2, 0, 0)])
    grown = snap([1, 2, 3, 4], [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)])
    assert not places_changed(a, shuffled, 0.25)
    assert not places_changed(a, drifted, 0.25)
    assert places_changed(a, moved, 0.25)
    assert places_changed(a, grown, 0.25)
    assert places_changed(grown, a, 0.25)


def test_places_lost_counts_places_gone_or_moved_not_added() -> None:
    """Between two logs, a graph that grew keeps the join (its places are all still there);
    one that lacks a place, or moved one beyond the tolerance, does not."""
    from aion_cli.engine.types import GraphSnapshot, Layer
    from aion_cli.shard_graphs import places_lost

    def snap(ids: list[int], xyz: list[tuple[float, float, float]]) -> GraphSnapshot:
        where = np.array(xyz, float).reshape(-1, 3)
        layer = Layer(np.array(ids, np.uint64), where, np.zeros(len(ids), np.uint64))
        return GraphSnapshot(0, layer, np.zeros((0, 2), np.int64))

    a = snap([1, 2, 3], [(0, 0, 0), (1, 0, 0), (2, 0, 0)])
    grown = snap([4, 3, 1, 2], [(3, 0, 0), (2, 0, 0), (0, 0.2, 0), (1, 0, 0)])
    lacking = snap([1, 3], [(0, 0, 0), (2, 0, 0)])
    moved = snap([1, 2, 3], [(0, 0, 0), (1, 0.3, 0), (2, 0, 0)])
    other = snap([7, 8, 9], [(0, 0, 0), (1, 0, 0), (2, 0, 0)])
    empty = snap([], [])
    assert not places_lost(a, grown, 0.25)
    assert places_lost(grown, a, 0.25)
    assert places_lost(a, lacking, 0.25)
    assert places_lost(a, moved, 0.25)
    assert places_lost(a, other, 0.25)
    assert places_lost(a, empty, 0.25)
    assert not places_lost(empty, a, 0.25)


def _fixed_rate(path: Path, container: str = "mcap") -> Path:
    """A tracker publishing every 5 s from Monday 08:00 to 10:20, empty messages included:
    the office's people from 08:00 to 08:20 and from 10:00 to 10:20, nobody in between."""
    from aion_cli.formats.writers import LogWriter
    from tests.cli.logdata import _tracked_persons

    sessions = (T0, T0 + 2 * HOUR_S * S)
    with LogWriter(path, container) as writer:
        for k in range((2 * HOUR_S + 1200) // 5):
            t = T0 + 5 * k * S
            start = max(s for s in sessions if s <= t)
            message = (
                _tracked_persons(t, start, "map")
                if t - start < 1200 * S
                else {"header": {"stamp": {"sec": t // S, "nanosec": 0}, "frame_id": "map"},
                      "tracks": []}
            )
            writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons", message, t)
    return path


@pytest.mark.parametrize(
    ("container", "name"),
    [("mcap", "log.mcap"), ("bag", "log.bag"), ("rosbag2-sqlite3", "log"), ("rosbag2-mcap", "log")],
)
def test_a_tracker_publishing_empty_messages_is_cut_where_decoding_finds_nobody(
    tmp_path: Path, container: str, name: str
) -> None:
    # its messages never pause, so the index shows no quiet moment; decoding the 10 s before
    # the window starts nearest the even split finds them empty (an indexed MCAP reads just
    # those seconds' chunks, a ROS 1 bag finds them in its index, rosbag2's storage files
    # select them themselves)
    log = _fixed_rate(tmp_path / name, container)
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = _build([log], seq, 1)
    two = _build([log], par, 2)
    assert [(r["from"], r["to"]) for r in two.workers] == [
        ("start", "2026-11-23 09:10:00 UTC"),  # half of the messages on either side
        ("2026-11-23 09:10:00 UTC", "end"),
    ]
    assert _same_maps(seq, par) == []
    _same_reports(one, two)


def test_quiet_moments_only_decoding_finds_are_not_searched_where_reading_is_slow(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a log read from its start for every moment probed (an MCAP without a chunk index, say)
    # is not probed: built in one process, and the build says why
    from aion_cli.formats.logs import LogSet

    monkeypatch.setattr(LogSet, "skips_by_time", lambda self: False)
    log = _fixed_rate(tmp_path / "log.mcap")
    report = _build([log], tmp_path / "par.aion", 2)
    assert report.workers == []
    assert any("no quiet moment" in n for n in report.notes)


def test_a_probe_that_finds_people_everywhere_gives_no_cut() -> None:
    # messages every 5 s for an hour: the index sees no quiet moment, and a probe that always
    # decodes someone rules out every window start (each probed once, at most 48 per cut)
    times = _times([t * S for t in range(0, 3600, 5)])
    asked: list[int] = []

    def busy(at: int) -> bool:
        asked.append(at)
        return False

    assert cut_times(times, W, 2, busy) == []
    assert len(asked) == len(set(asked)) == 5  # the window starts with messages on both sides
    assert cut_times(times, W, 2, lambda at: at == 1800 * S) == [1800 * S]


class _Damaged:
    """A graph whose payload no spark_dsg version decodes."""

    def to_binary(self, _: bool) -> bytes:
        return b"\x07not a scene graph" * 8


def test_damaged_graphs_in_one_part_are_skipped_as_in_one_pass(tmp_path: Path) -> None:
    # Tuesday's graphs are all damaged: one pass skips them (a note) and keeps Monday's graph;
    # the part that holds them alone must not stop the build for having decoded none, and
    # the counts are the whole log's
    from tests.formats.dsg_builders import hydra_graph

    log = _hydra_sessions(tmp_path / "log.mcap", [hydra_graph(False), _Damaged()])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = _build([log], seq, 1)
    two = _build([log], par, 2)
    assert len(two.workers) == 2
    assert (two.graph_messages, two.graph_skipped) == (one.graph_messages, one.graph_skipped)
    assert one.graph_skipped == 20
    counts = [n for n in two.notes if n.startswith("scene graphs: ")]
    assert counts == [n for n in one.notes if n.startswith("scene graphs: ")]
    assert counts[0].startswith("scene graphs: 20 of 40 applied")
    assert _same_maps(seq, par) == []


def test_a_log_whose_graphs_all_fail_stops_with_workers_too(tmp_path: Path) -> None:
    from aion_cli.errors import MessageDecodeError

    log = _hydra_sessions(tmp_path / "log.mcap", [_Damaged(), _Damaged()])
    for workers in (1, 2):
        with pytest.raises(MessageDecodeError):
            _build([log], tmp_path / "m.aion", workers)
        assert not (tmp_path / "m.aion").exists()


def test_a_time_check_limited_to_a_part_keeps_its_messages_and_clips_its_runs() -> None:
    from aion_cli.formats.raw import RawMessage
    from aion_cli.log_times import TopicTimes

    # /a: a run from 0 to 3,000 s (messages every 500 s) and one stray 5 days later among 30
    # messages; /b: the same run's windows at 100 s past each window
    times = TopicTimes({"/a", "/b"})
    for t in range(0, 3001, 500):
        times.add("/a", t * S)
    for _ in range(30):
        times.add("/a", 1000 * S)
    times.add("/a", 5 * 86_400 * S)
    times.add("/b", 700 * S)
    whole = times.check({"/a", "/b"})
    assert whole.strays["/a"].tolist() == [5 * 86_400 * S]
    part = whole.limited(1200 * S, 2400 * S)
    assert (part.start_ns, part.end_ns) == (1500 * S, 2000 * S)  # its own messages
    assert part.run_first.min() >= 1200 * S
    assert part.run_last.max() == 2400 * S - 1
    # a fixed sensor observes the part's windows the whole log's runs cover: 1,200..2,400 s
    np.testing.assert_array_equal(part.windows(W), (np.array([2]), np.array([3])))
    assert part.within_runs(np.arange(6), W).tolist() == [False, False, True, True, False, False]
    stream = [RawMessage("/a", "t", t * S, b"", "cdr") for t in (1000, 1200, 2399, 2400)]
    stream.append(RawMessage("/a", "t", 5 * 86_400 * S, b"", "cdr"))
    assert [m.log_time_ns for m in part.filter(iter(stream))] == [1200 * S, 2399 * S]
    kept = [m.log_time_ns for m in whole.filter(iter(stream))]
    assert kept == [t * S for t in (1000, 1200, 2399, 2400)]
    inside = part.inside_limits(np.arange(6) * W)  # the windows starting inside the part
    assert inside.tolist() == [False, False, True, True, False, False]


def test_graph_breaks_between_logs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Between two logs (each one Hydra session): a later log whose first graph lacks a
    place of the earlier log's last is a break; one that grew, or repeats it, is not (a
    repeated payload is not even decoded); one whose graphs do not decode cannot tell (no
    break: the join decides)."""
    import aion_cli.shard_graphs as shard_graphs
    from aion_cli.build_options import BuildOptions
    from aion_cli.shard_graphs import graph_breaks
    from tests.formats.dsg_builders import hydra_graph

    def log(name: str, graph: object) -> Path:
        return _hydra_sessions(tmp_path / f"{name}.mcap", [graph])

    plain = log("plain", hydra_graph(False))
    again = log("again", hydra_graph(False))
    grown = log("grown", _grown(hydra_graph(False)))
    damaged = log("damaged", _Damaged())
    opts = BuildOptions(logs=(plain,), output=tmp_path / "x.aion")

    def breaks(*logs: Path) -> list[bool]:
        return graph_breaks([(p,) for p in logs], opts, 0.25)

    decoded: list[object] = []
    real = shard_graphs._decoded

    def counting(*args: Any) -> Any:
        decoded.append(args)
        return real(*args)

    monkeypatch.setattr(shard_graphs, "_decoded", counting)
    assert breaks(plain, again) == [False]
    assert decoded == []  # the same payload bytes: no decoding
    assert breaks(plain, again, grown) == [False, False]
    assert len(decoded) == 2  # the grown graph's payload differs: both ends decoded
    assert breaks(grown, plain) == [True]  # the grown graph's extra place is gone
    assert breaks(plain, damaged, plain) == [False, False]
    assert breaks(plain) == []


def test_groups_kept_together_are_not_cut_nor_their_times_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A group the planner kept together across sessions stays one shard: its times are not
    read (nothing to cut); the other groups are planned as before."""
    import aion_cli.time_shards as time_shards

    read: list[object] = []

    def times(group: Any, *_: Any) -> None:
        read.append(group)

    monkeypatch.setattr(time_shards, "group_times", times)
    a, b = (Path("a.mcap"),), (Path("b.mcap"),)
    opts = BuildOptions(logs=(a[0],), output=tmp_path / "x.aion")
    shards, notes = time_shards.split_groups([a], opts, 600 * S, 2, 0.25, frozenset({0}))
    assert (shards, notes, read) == ([(a, None, True)], [], [])
    shards, notes = time_shards.split_groups([a, b], opts, 600 * S, 4, 0.25, frozenset({1}))
    assert read == [a]  # only the other group's times (none found here: not cut)
    assert shards == [(a, None, True), (b, None, True)]
