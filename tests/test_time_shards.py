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

import numpy as np
import pytest

from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from aion_cli.time_shards import QUIET_NS, GroupTimes, cut_times, parts_of
from tests.cli.logdata import T0, S, write_office_log
from tests.time_shard_logs import (
    HOUR_S,
    LATER_S,
    W,
    build_logs,
    build_on_local_cluster,
    same_maps,
    same_reports,
)


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



# -- builds -----------------------------------------------------------------------------------
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
    one = build_logs([log], seq, 1)
    two = build_logs([log], par, 2)
    assert same_maps(seq, par) == []
    same_reports(one, two)
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
    build_logs([first], seq, 1)
    build_logs([first], par, 1)
    build_map(BuildOptions(logs=(rest,), output=seq, continue_from=seq, workers=1))
    report = build_map(BuildOptions(logs=(rest,), output=par, continue_from=par, workers=2))
    assert len(report.workers) == 2  # both parts held their days for the joins
    assert same_maps(seq, par) == []


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
    build_logs([log], seq, 1)
    report = build_logs([log], par, 2)
    notes = [n for n in report.notes if "in sequence" in n]
    assert len(notes) == 1
    assert "no scene graph" in notes[0]
    assert same_maps(seq, par) == []


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
    one = build_logs([joined], seq, 1)
    two = build_logs([joined], par, 2)
    assert one.time_dropped == {"/tracks": {"out_of_range": 0, "stray": 1}}
    assert two.time_dropped == one.time_dropped
    assert len(two.workers) == 2
    assert same_maps(seq, par) == []


def test_a_dask_cluster_builds_time_shards(tmp_path: Path) -> None:
    log = tmp_path / "log.mcap"
    write_office_log(log, duration_s=2 * HOUR_S, later_sessions_s=LATER_S)
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    build_logs([log], seq, 1)
    report = build_on_local_cluster([log], par)
    assert len(report.workers) == 2
    assert same_maps(seq, par) == []


