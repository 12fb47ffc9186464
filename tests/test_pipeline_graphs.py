"""Scene-graph streams in ``aion build`` (issue 15): identical payloads are not decoded again,
``--graph-period`` thins the stream, and both leave ownership exact on the graphs used.

The stream log: the office of ``tests/cli/logdata.py`` (people at p1, p4, p3; TF at the robot)
with a ``DsgUpdate`` every second for 60 s, starting 30 s before a window boundary. Place p1
moves by 0.5 m (more than ``stable_move_tolerance``, so its stability timer restarts) in the
graphs from index 3 on and again from index 12 on; every other graph repeats the payload before
it. Expected answers are worked out by hand from the rules in the docstrings:

* ``--graph-period 0``: all 60 graphs applied; 3 payloads differ (indices 0, 3, 12), so 3
  decodes and 57 reuses; p1 stable since graph 12.
* ``--graph-period 5s``: graphs 0, 5, ..., 25 (the period boundaries), 29 (the last one logged
  in the first window), 30, 35, ..., 55 and 59 (the last of the log): 14 applied, 46 left out;
  p1 seen moved first at graph 5 and again at 15, so stable since graph 15.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.cli.graph_options import GRAPH_PERIOD_DEFAULT_TEXT
from aion_cli.errors import InputError
from aion_cli.formats.mapfile import read_map
from aion_cli.graph_schedule import DEFAULT_GRAPH_PERIOD_NS, graph_schedule, parse_period_ns
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import S, _tracked_persons, sym
from tests.graph_stream_logs import (
    N_GRAPHS,
    START,
    assert_same_map,
    build_log,
    office_graph_payload,
    write_stream_log,
)

PERIOD_5S_USED = [0, 5, 10, 15, 20, 25, 29, 30, 35, 40, 45, 50, 55, 59]


def _stable_since(path: Path, node: int) -> int:
    arrays, _ = read_map(path)
    ids = arrays["node_ids"].tolist()
    return int(arrays["node_stable_since_ns"][ids.index(node)])


@pytest.fixture(scope="module")
def stream_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_stream_log(tmp_path_factory.mktemp("graphs") / "stream.mcap")


# -- the schedule ---------------------------------------------------------------------------------
def test_schedule_on_a_steady_stream() -> None:
    t = np.arange(20, dtype=np.int64) * S
    assert np.flatnonzero(graph_schedule(t, 5 * S)).tolist() == [0, 5, 10, 15, 19]
    assert graph_schedule(t, 0).all()
    assert graph_schedule(t, -1).all()
    assert np.flatnonzero(graph_schedule(t, 100 * S)).tolist() == [0, 19]


def test_schedule_takes_the_newest_graph_of_each_period() -> None:
    # 0 used; boundary 5: the newest graph at or before it is at 3; boundary 10: 8; at 15
    # nothing came after 8, so the next graph (30) is used when it comes
    t = np.array([0, 1, 2, 3, 7, 8, 30], np.int64) * S
    assert np.flatnonzero(graph_schedule(t, 5 * S)).tolist() == [0, 3, 5, 6]
    # a graph exactly on the boundary is used
    t = np.array([0, 2, 5, 6], np.int64) * S
    assert np.flatnonzero(graph_schedule(t, 5 * S)).tolist() == [0, 2, 3]


def test_schedule_uses_the_last_graph_of_each_window() -> None:
    t = np.arange(10, dtype=np.int64) * S
    used = graph_schedule(t, 100 * S, window_ns=4 * S)  # windows [0, 4), [4, 8), [8, 12)
    assert np.flatnonzero(used).tolist() == [0, 3, 7, 9]
    assert graph_schedule(np.zeros(0, np.int64), 5 * S).size == 0
    assert graph_schedule(np.array([7], np.int64), 5 * S).tolist() == [True]
    # log times out of order (several files) still give a valid schedule, first and last used
    used = graph_schedule(np.array([0, 9, 3, 12], np.int64) * S, 5 * S)
    assert used[0]
    assert used[-1]


def test_schedule_near_the_end_of_time_does_not_overflow() -> None:
    top = np.iinfo(np.int64).max
    t = np.array([top - 3 * S, top - 2 * S, top - S], np.int64)
    assert np.flatnonzero(graph_schedule(t, 10 * S)).tolist() == [0, 2]


# -- the option -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("text", "ns"),
    [
        ("0", 0),
        ("5", 5 * S),
        ("2.5", 2_500_000_000),
        ("5s", 5 * S),
        ("1m", 60 * S),
        ("1m30s", 90 * S),
        ("1 m 30 s", 90 * S),
        ("500ms", 500_000_000),
        ("0.001s", 1_000_000),
        ("1h", 3600 * S),
        ("2d", 2 * 86_400 * S),
    ],
)
def test_period_parses_like_the_other_durations(text: str, ns: int) -> None:
    assert parse_period_ns(text) == ns


@pytest.mark.parametrize("text", ["-1s", "abc", "5x", "5s5", "", "400d", "1e3"])
def test_bad_periods_are_input_errors(text: str) -> None:
    with pytest.raises(InputError):
        parse_period_ns(text)


def test_the_help_shows_the_builds_default() -> None:
    assert parse_period_ns(GRAPH_PERIOD_DEFAULT_TEXT) == DEFAULT_GRAPH_PERIOD_NS
    assert BuildOptions(logs=()).graph_period_ns == DEFAULT_GRAPH_PERIOD_NS


# -- identical payloads ---------------------------------------------------------------------------
def test_identical_payloads_are_not_decoded_and_the_map_is_the_same(
    stream_log: Path, tmp_path: Path
) -> None:
    fast = build_log(stream_log, tmp_path / "fast.aion", graph_period_ns=0)
    slow = build_log(
        stream_log, tmp_path / "slow.aion", graph_period_ns=0, skip_identical_graphs=False
    )
    assert fast.graph_messages == slow.graph_messages == N_GRAPHS
    assert fast.graph_decoded == 3  # graphs 0, 3 and 12 differ from the one before
    assert fast.graphs_skipped_identical == N_GRAPHS - 3
    assert slow.graph_decoded == N_GRAPHS
    assert slow.graphs_skipped_identical == 0
    assert fast.graphs_skipped_period == slow.graphs_skipped_period == 0
    assert_same_map(tmp_path / "fast.aion", tmp_path / "slow.aion")
    # p1's timer restarted at graph 12, where it moved the second time
    assert _stable_since(tmp_path / "fast.aion", sym("p", 1)) == START + 12 * S
    graph = fast.to_dict()["graph"]
    assert graph["decoded"] == 3
    assert graph["skipped_identical"] == N_GRAPHS - 3
    assert graph["period_s"] == 0


def test_a_payload_that_comes_back_is_decoded_again(tmp_path: Path) -> None:
    """Only the *last* decoded payload is reused: A A B A decodes A, B and A."""
    from aion_cli.formats.writers import LogWriter

    log = tmp_path / "aba.mcap"
    order = [0, 0, 1, 0]
    with LogWriter(log, "mcap") as writer:
        for s in range(40):
            t = START + s * S
            if s % 10 == 0:
                writer.write(
                    "/hydra/backend/dsg",
                    "hydra_msgs/msg/DsgUpdate",
                    {
                        "header": {"stamp": {"sec": t // S, "nanosec": 0}, "frame_id": "map"},
                        "layer_contents": np.frombuffer(
                            office_graph_payload(order[s // 10]), np.uint8
                        ),
                    },
                    t,
                )
            writer.write(
                "/tracks",
                "spencer_tracking_msgs/msg/TrackedPersons",
                _tracked_persons(t + S // 2, START, "map"),
                t + S // 2,
            )
    fast = build_log(log, tmp_path / "fast.aion", graph_period_ns=0)
    slow = build_log(log, tmp_path / "slow.aion", graph_period_ns=0, skip_identical_graphs=False)
    assert (fast.graph_decoded, fast.graphs_skipped_identical) == (3, 1)
    assert slow.graph_decoded == 4
    assert_same_map(tmp_path / "fast.aion", tmp_path / "slow.aion")


def test_the_first_graph_is_decoded_once_when_it_gives_the_observation(
    tmp_path: Path,
) -> None:
    """Without TF the first graph's agent layer decides the observation; the stream then
    reuses that decode instead of decoding the graph a second time."""
    from tests.cli.logdata import write_office_log

    log = tmp_path / "agents.mcap"
    expected = write_office_log(log, tf=False, agents=True)
    slow = build_log(log, tmp_path / "slow.aion", skip_identical_graphs=False)
    assert slow.observation == "scene-graph agent layer"
    assert slow.graph_messages == expected.graph_messages
    assert slow.graph_decoded == expected.graph_messages  # not one more
    fast = build_log(log, tmp_path / "fast.aion")
    assert fast.graph_decoded == 1  # the office repeats one payload
    assert_same_map(tmp_path / "fast.aion", tmp_path / "slow.aion")


def test_a_damaged_first_graph_without_tf_is_skipped_as_in_the_stream(tmp_path: Path) -> None:
    """Without TF the first graph's agent layer decides the observation. A damaged first
    DsgUpdate (logged with the log's first graph) stopped the build with the decode error,
    though the stream skips a damaged graph (and a log with TF built); now the next graph
    answers, the damaged one is skipped and noted, and the map is the map of the same log
    without it."""
    from tests.cli.logdata import write_office_log

    clean = tmp_path / "clean.mcap"
    expected = write_office_log(clean, tf=False, agents=True)
    damaged = tmp_path / "damaged.mcap"
    write_office_log(damaged, tf=False, agents=True, early_graph=(0, b"\x00damaged" * 8))
    reference = build_log(clean, tmp_path / "clean.aion")
    report = build_log(damaged, tmp_path / "damaged.aion")
    assert report.observation == reference.observation == "scene-graph agent layer"
    assert report.graph_skipped == 1
    assert report.graph_messages == expected.graph_messages
    assert any("1 damaged scene-graph message(s) skipped" in n for n in report.notes)
    assert_same_map(tmp_path / "damaged.aion", tmp_path / "clean.aion")


# -- --graph-period --------------------------------------------------------------------------------
def test_period_build_equals_a_log_of_only_the_graphs_used(
    stream_log: Path, tmp_path: Path
) -> None:
    thinned = build_log(stream_log, tmp_path / "thinned.aion", graph_period_ns=5 * S)
    assert thinned.graph_messages == len(PERIOD_5S_USED)
    assert thinned.graphs_skipped_period == N_GRAPHS - len(PERIOD_5S_USED)
    # decoded: 0 (p1 unmoved), 5 (moved once), 15 (moved twice); 10, 20, ... repeat them
    assert thinned.graph_decoded == 3
    only = write_stream_log(tmp_path / "only.mcap", PERIOD_5S_USED)
    reference = build_log(only, tmp_path / "reference.aion", graph_period_ns=0)
    assert reference.graph_messages == len(PERIOD_5S_USED)
    assert_same_map(tmp_path / "thinned.aion", tmp_path / "reference.aion")
    assert _stable_since(tmp_path / "thinned.aion", sym("p", 1)) == START + 15 * S
    # the thinning is visible: every graph gives p1 another stability time
    every = build_log(stream_log, tmp_path / "every.aion", graph_period_ns=0)
    assert every.graphs_skipped_period == 0
    assert _stable_since(tmp_path / "every.aion", sym("p", 1)) == START + 12 * S
    assert any("left out by --graph-period 5s" in n for n in thinned.notes)
    assert thinned.to_dict()["graph"]["skipped_period"] == N_GRAPHS - len(PERIOD_5S_USED)


def test_period_schedule_skips_the_graphs_the_time_check_drops(tmp_path: Path) -> None:
    """A stray graph (two days before the others) is dropped from the stream; the schedule is
    decided on the same messages, so the map equals the one of the log without it."""
    stray = write_stream_log(tmp_path / "stray.mcap", stray_graph=True)
    with_stray = build_log(stray, tmp_path / "stray.aion", graph_period_ns=5 * S)
    assert with_stray.time_dropped["/hydra/backend/dsg"]["stray"] == 1
    assert with_stray.graph_messages == len(PERIOD_5S_USED)
    clean = write_stream_log(tmp_path / "clean.mcap")
    build_log(clean, tmp_path / "clean.aion", graph_period_ns=5 * S)
    assert_same_map(tmp_path / "stray.aion", tmp_path / "clean.aion")


def test_cli_graph_period_option(stream_log: Path, tmp_path: Path) -> None:
    from tests.cli.conftest import run, run_json

    report = run_json(
        "build", stream_log, "-o", tmp_path / "a.aion", "--graph-period", "5s", "--format", "json"
    )
    assert report["graph"]["messages"] == len(PERIOD_5S_USED)
    assert report["graph"]["period_s"] == 5.0
    report = run_json("build", stream_log, "-o", tmp_path / "b.aion", "--format", "json")
    assert report["graph"]["period_s"] == DEFAULT_GRAPH_PERIOD_NS / 1e9
    bad = run("build", stream_log, "-o", tmp_path / "c.aion", "--graph-period", "soon")
    assert bad.exit_code == 2
    assert "--graph-period" in bad.stderr or "period" in bad.stderr


def test_graphs_left_out_are_not_decompressed_and_the_map_is_the_same(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A live-Hydra stream whose every chunk ends with its scene graph (300 moving places at
    1 Hz, 16 KB chunks; the benchmarks' generator): with the default ``--graph-period`` the
    chunks of the graphs left out are decompressed only up to their graph (read_head), or not
    at all where the graph is all the chunk holds (unread_chunk), and the map and report
    equal those of a build that reads every chunk whole (and copies every payload)."""
    from aion_cli.formats import mcap_partial
    from aion_cli.graph_feed import GraphFeed
    from benchmarks.build_logs import SITE, MovingPayload, places_graph, steady_times, write_log

    xyz, edges = places_graph(*SITE, 300)
    log = tmp_path / "live.mcap"
    write_log(log, steady_times(60.0), 2, (SITE[0], SITE[1]), MovingPayload(xyz, edges), 1.0,
              chunk_size=16_384)
    real, real_alone = mcap_partial.read_head, mcap_partial.unread_chunk
    partial = []  # chunks read in part or not at all

    def counting(*args: Any) -> Any:
        return record(real(*args))

    def record(got: Any) -> Any:
        if got is not None:
            partial.append(True)
        return got

    monkeypatch.setattr(mcap_partial, "read_head", counting)
    monkeypatch.setattr(mcap_partial, "unread_chunk", lambda *a: record(real_alone(*a)))
    in_part = build_map(BuildOptions(logs=(log,), output=tmp_path / "part.aion"))
    assert in_part.graphs_skipped_period >= 40
    assert sum(partial) >= in_part.graphs_skipped_period - 2  # a left-out graph ends each
    monkeypatch.setattr(GraphFeed, "unread_hint", lambda self, topics: None)
    partial.clear()
    whole = build_map(BuildOptions(logs=(log,), output=tmp_path / "whole.aion"))
    assert not any(partial)
    assert_same_map(tmp_path / "part.aion", tmp_path / "whole.aion")
    ra, rb = in_part.to_dict(), whole.to_dict()
    for report in (ra, rb):
        report.pop("map")
        report.pop("map_bytes")
    assert ra == rb


def test_the_api_takes_the_period_version_and_batch_size_as_the_cli_does(
    stream_log: Path, tmp_path: Path
) -> None:
    """aion.build had no keyword for --graph-period, --dsg-version or --batch-size (docs/API.md:
    "everything the aion command does can be done from Python"): a script could not use every
    scene graph of a live Hydra stream, nor pin a payload version. Now graph_period takes the
    period as text, seconds or a timedelta, and builds the map the command builds."""
    from datetime import timedelta

    import aion_cli as aion
    from tests.cli.conftest import run_json

    every = aion.build(stream_log, tmp_path / "every.aion", graph_period=0)
    assert every.report.graphs_skipped_period == 0
    assert every.report.graph_messages == N_GRAPHS
    run_json("build", stream_log, "-o", tmp_path / "cli.aion", "--graph-period", "0", "--format",
             "json")
    assert_same_map(tmp_path / "every.aion", tmp_path / "cli.aion")
    import numpy as np

    # numpy's timedelta64 is an integer to numbers: np.timedelta64(5000, "ms") was 5000 s
    for period in ("5s", 5, 5.0, timedelta(seconds=5), np.timedelta64(5000, "ms")):
        thinned = aion.build(stream_log, tmp_path / "thinned.aion", graph_period=period)
        assert thinned.report.graph_messages == len(PERIOD_5S_USED), period
        assert thinned.report.graphs_skipped_period == N_GRAPHS - len(PERIOD_5S_USED)
    # the decoding chunk changes no map; a pinned version is the one reported
    assert every.report.dsg_version is not None
    small = aion.build(stream_log, tmp_path / "small.aion", graph_period=0, batch_size=3,
                       dsg_version=every.report.dsg_version)
    assert small.report.dsg_version == every.report.dsg_version
    assert_same_map(tmp_path / "small.aion", tmp_path / "every.aion")
    with pytest.raises(InputError, match="cannot read the period 'soon'"):
        aion.build(stream_log, tmp_path / "x.aion", graph_period="soon")
    with pytest.raises(InputError, match="graph_period must be 0 or more seconds"):
        aion.build(stream_log, tmp_path / "x.aion", graph_period=-1)
    with pytest.raises(InputError, match="batch_size must be at least 1"):
        aion.build(stream_log, tmp_path / "x.aion", batch_size=0)


@pytest.mark.parametrize("reader", ["fast", "generic"])
def test_a_used_graphs_header_is_read_once(
    reader: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With --graph-period the stream reads a used graph's header to tell a partial update
    (whose period the next whole graph of its window takes) from a whole graph; its decoding
    read the header again, and a stand-in's was read three times: with the generic decoder
    (a log's own DsgUpdate layout) each read deserialises the whole message. Now what the
    first read found goes on with the message. The office log with partial updates at 45-s
    periods (tests/cli/test_build_graphs.py): 19 graphs applied and 14 partial updates
    skipped, each of these 33 messages read once; the topic's first message once more, to
    learn whether its writer sets full_update (GraphFeed._uses_flag)."""
    from collections import Counter

    from aion_cli.formats import dsg_update_fast
    from aion_cli.formats.logs import LogSet
    from tests.cli.logdata import PLACES, T0, write_office_log

    log = tmp_path / "partial.mcap"
    write_office_log(log, "mcap", partial_places={k: PLACES[k] for k in (0, 1)})
    reads: Counter[int] = Counter()  # header reads per graph, by its time (s after T0)
    fast, generic = dsg_update_fast.read_dsg_update, LogSet.decode

    def fast_counted(data: bytes, encoding: str) -> Any:
        got = fast(data, encoding)
        assert got is not None  # the office log's layout: every header read here
        reads[(got.sec * S + got.nanosec - T0) // S] += 1
        return got

    def generic_counted(self: LogSet, msg: Any) -> Any:
        if msg.msgtype == dsg_update_fast.DSG_UPDATE:
            reads[(msg.log_time_ns - T0) // S] += 1
        return generic(self, msg)

    if reader == "fast":
        monkeypatch.setattr(dsg_update_fast, "read_dsg_update", fast_counted)
    else:  # as for a log whose own DsgUpdate definition has another layout
        monkeypatch.setattr(dsg_update_fast, "read_dsg_update", lambda data, encoding: None)
        monkeypatch.setattr(LogSet, "decode", generic_counted)
    report = build_log(log, tmp_path / "m.aion", graph_period_ns=45 * S)
    assert report.graph_messages == 19
    assert any(n.startswith("14 partial scene-graph update(s)") for n in report.notes)
    assert len(reads) == 19 + 14
    assert reads[0] == 2  # the first graph: once more for the flag
    assert sum(reads.values()) == len(reads) + 1  # every other one once
