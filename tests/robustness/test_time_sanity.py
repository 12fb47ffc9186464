"""Time sanity (issue 14, point 2): one message with an absurd log time cannot stretch a build.

A build's time span comes from the messages it uses (detections, scene graphs, dynamic TF),
never from unrelated topics or a container's summary; a message of a used topic far from its
topic's other messages is dropped and counted with a warning; times that int64 nanoseconds
cannot hold are dropped (or, when nothing else is left, exit 2); closing windows costs
O(recorded windows), however long the gap. Every log is written here with
``formats.writers.LogWriter``, or copied record by record with the ``mcap`` library to place
a log time that LogWriter (rightly) refuses to write.
"""

from __future__ import annotations

import re
import struct
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import MAX_TIME_NS, Mapper
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.types import DetectionBatch
from aion_cli.engine.windows import window_ns
from aion_cli.errors import InputError
from aion_cli.log_times import STRAY_MAX_MESSAGES, stray_mask
from tests.robustness.conftest import (
    T0,
    Message,
    S,
    assert_one_error,
    assert_same_arrays,
    build_json,
    map_arrays,
    person,
    robot_tf,
    run,
    walk,
    write_log,
)
from tests.robustness.mcap_edit import STRING_CDR, copy_with, payload_of

HOUR_MESSAGES = 3600  # one person per second for an hour: six 600-s windows
Y2038 = int(datetime(2038, 1, 1, tzinfo=UTC).timestamp()) * S
Y2261_END = int(datetime(2261, 12, 31, tzinfo=UTC).timestamp()) * S  # int64, past the range
BEYOND_INT64 = 9_300_000_000_000_000_000  # 2264: an MCAP (uint64) time int64 cannot hold


@pytest.fixture(scope="module")
def hour(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A one-hour fixed-sensor log and its map (the reference every variant must equal)."""
    folder = tmp_path_factory.mktemp("hour")
    log = write_log(folder / "hour.mcap", walk(HOUR_MESSAGES))
    out = folder / "hour.aion"
    build_json(log, "-o", out)
    return log, out


def same_map(report: dict[str, Any], reference: Path, variant: Path) -> None:
    """The variant's map equals the reference map (every array) and has its time span."""
    assert_same_arrays(map_arrays(variant), map_arrays(reference))
    assert report["time_span"]["start_ns"] == T0
    assert report["time_span"]["end_ns"] == T0 + (HOUR_MESSAGES - 1) * S
    assert report["detections"] == {"read": HOUR_MESSAGES, "used": HOUR_MESSAGES, "dropped": {}}


# -- unrelated topics and summaries have no say ---------------------------------------------


@pytest.mark.parametrize("when", [Y2038, Y2261_END, BEYOND_INT64, 1 * S])
def test_one_far_message_on_an_unread_topic_changes_nothing(
    when: int, hour: tuple[Path, Path], tmp_path: Path
) -> None:
    """Before: the far window counted as an observed empty window of the fixed sensor (flow
    600 -> 514 per window at 2038 and 2261, and in 1970), and past 2262 the build was an
    internal error (exit 1)."""
    log, reference = hour
    odd = copy_with(
        log, tmp_path / "odd.mcap", [("/chatter", "std_msgs/msg/String", STRING_CDR, when)]
    )
    report = build_json(odd, "-o", tmp_path / "odd.aion")
    same_map(report, reference, tmp_path / "odd.aion")
    assert report["observation"].startswith("fixed sensor over the 6 windows")
    if when <= MAX_TIME_NS:  # the index knows a window there: it is left out, with a note
        assert any("not taken as observed" in n for n in report["notes"]), report["notes"]


def lie_about_the_end(log: Path, end_ns: int) -> Path:
    """Set the MCAP summary's Statistics ``message_end_time`` to ``end_ns`` (in place; the
    summary CRC is zeroed, which readers take as "not computed")."""
    data = bytearray(log.read_bytes())
    footer = len(data) - 8 - (1 + 8 + 20)
    assert data[footer] == 0x02
    summary_start = struct.unpack_from("<Q", data, footer + 9)[0]
    struct.pack_into("<I", data, footer + 9 + 16, 0)
    pos = summary_start
    while pos < footer:
        opcode, length = struct.unpack_from("<BQ", data, pos)
        if opcode == 0x0B:  # Statistics: counts (8+2+4+4+4+4 bytes), start time, end time
            struct.pack_into("<Q", data, pos + 9 + 26 + 8, end_ns)
            log.write_bytes(bytes(data))
            return log
        pos += 9 + length
    raise AssertionError("no Statistics record")


@pytest.mark.parametrize("end", [Y2038, BEYOND_INT64])
def test_a_summary_whose_end_time_lies_changes_nothing(
    end: int, hour: tuple[Path, Path], tmp_path: Path
) -> None:
    """Before: the lying end closed the log's last window and became the map's time span
    (2038), or was an internal error (past 2262)."""
    log, reference = hour
    liar = tmp_path / "liar.mcap"
    liar.write_bytes(log.read_bytes())
    lie_about_the_end(liar, end)
    report = build_json(liar, "-o", tmp_path / "liar.aion")
    same_map(report, reference, tmp_path / "liar.aion")


# -- used topics: strays dropped and counted --------------------------------------------------


def test_a_stray_detection_message_is_dropped_counted_and_warned(
    hour: tuple[Path, Path], tmp_path: Path
) -> None:
    """One /tracks message stamped (and logged) 2038 in an hour of 2026: dropped, counted in
    ``log_times_dropped``, warned about, also with ``-q``; the map equals the clean one."""
    _, reference = hour
    msgs = [*walk(HOUR_MESSAGES), person(Y2038, (2.1, 0.1, 0.0))]
    log = write_log(tmp_path / "stray.mcap", msgs)
    report = build_json(log, "-o", tmp_path / "stray.aion")
    same_map(report, reference, tmp_path / "stray.aion")
    assert report["log_times_dropped"] == {"/tracks": {"out_of_range": 0, "stray": 1}}
    warning = (
        "1 message(s) on /tracks dropped: log time more than a day away from the topic's "
        "other messages (first: 2038-01-01 00:00:00 UTC"
    )
    assert any(w.startswith(warning) for w in report["warnings"]), report["warnings"]
    quiet = run("build", log, "-o", tmp_path / "q.aion", "-q")
    assert quiet.exit_code == 0, quiet.stderr
    assert f"warning: {warning}" in quiet.stderr


def test_detection_log_times_beyond_int64_are_dropped_as_out_of_range(
    hour: tuple[Path, Path], tmp_path: Path
) -> None:
    """A real /tracks payload logged at a uint64 time past 2262: before, an internal error."""
    log, reference = hour
    odd = copy_with(
        log, tmp_path / "big.mcap", [("/tracks", "", payload_of(log, "/tracks"), BEYOND_INT64)]
    )
    report = build_json(odd, "-o", tmp_path / "big.aion")
    same_map(report, reference, tmp_path / "big.aion")
    assert report["log_times_dropped"] == {"/tracks": {"out_of_range": 1, "stray": 0}}
    assert any(
        "1 message(s) on /tracks dropped: log time outside 1900-01-01 .. 2261-01-01 UTC" in w
        for w in report["warnings"]
    ), report["warnings"]


def test_a_log_whose_detections_all_lie_beyond_int64_is_exit_2(tmp_path: Path) -> None:
    """Twenty real /tracks payloads, every one logged past 2262: nothing usable is left, so
    the build stops with one error line (before: an internal error, exit 1)."""
    source = write_log(tmp_path / "one.mcap", walk(1))
    extra = [
        ("/tracks", "", payload_of(source, "/tracks"), BEYOND_INT64 + k * S) for k in range(20)
    ]
    mixed = copy_with(source, tmp_path / "mixed.mcap", extra)
    only_bad = tmp_path / "only_bad.mcap"
    _copy_only_beyond(mixed, only_bad)
    result = run("build", only_bad, "-o", tmp_path / "bad.aion")
    assert result.exit_code == 2, result.stderr
    assert_one_error(
        result.stderr,
        "every one of the 20 detection messages has a log time outside "
        "1900-01-01 .. 2261-01-01 UTC",
    )
    assert not (tmp_path / "bad.aion").exists()


def _copy_only_beyond(src: Path, dst: Path) -> None:
    """The messages of ``src`` logged past int64, with its schemas and channels."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with src.open("rb") as fin, dst.open("wb") as fout:
        writer = Writer(fout)
        writer.start(profile="ros2", library="aion tests")
        ids: dict[int, int] = {}
        for schema, chan, message in make_reader(fin).iter_messages():
            if message.log_time <= MAX_TIME_NS:
                continue
            if chan.id not in ids:
                assert schema is not None
                sid = writer.register_schema(schema.name, schema.encoding, schema.data)
                ids[chan.id] = writer.register_channel(chan.topic, "cdr", sid)
            writer.add_message(ids[chan.id], message.log_time, message.data, message.log_time)
        writer.finish()


def robot_walk() -> list[Message]:
    """An hour of people with the robot's TF every 5 s."""
    return [*walk(HOUR_MESSAGES), *(robot_tf(T0 + k * S) for k in range(0, HOUR_MESSAGES, 5))]


def test_a_stray_robot_pose_is_ignored(tmp_path: Path) -> None:
    """One /tf message at 2038 (log time and stamp): before, its pose made the 2038 window an
    observed one (flow 600 -> 514 per window); now the map equals the clean one."""
    clean = write_log(tmp_path / "clean.mcap", sorted(robot_walk(), key=lambda m: m[3]))
    odd = write_log(
        tmp_path / "odd.mcap", sorted([*robot_walk(), robot_tf(Y2038)], key=lambda m: m[3])
    )
    build_json(clean, "-o", tmp_path / "clean.aion")
    report = build_json(odd, "-o", tmp_path / "odd.aion")
    assert_same_arrays(map_arrays(tmp_path / "odd.aion"), map_arrays(tmp_path / "clean.aion"))
    assert report["observation"] == "tf map->base_link"
    assert report["time_span"]["end_ns"] == T0 + (HOUR_MESSAGES - 1) * S
    text = " ".join(report["warnings"])
    assert "1 robot pose(s) ignored: stamped more than a day away" in text
    assert "1 message(s) on /tf ignored for the time span" in text


def test_sessions_days_apart_are_kept(tmp_path: Path) -> None:
    """Two recordings three days apart in one log (and a day of sparse messages) are bulk,
    not strays: nothing is dropped and both sessions are in the map."""
    msgs = [*walk(300), *walk(300, start_s=3 * 86400)]
    report = build_json(write_log(tmp_path / "two.mcap", msgs), "-o", tmp_path / "two.aion")
    assert report["detections"]["used"] == 600
    assert report["log_times_dropped"] == {}
    assert report["time_span"]["end_ns"] == T0 + (3 * 86400 + 299) * S


def test_a_short_log_days_after_another_is_its_own_time_not_a_stray(
    hour: tuple[Path, Path], tmp_path: Path
) -> None:
    """A log of five messages three days after the hour's is that log's own time: one build
    of both keeps it (it dropped them as a stray clock, while adding the short log with
    ``--map`` and the parallel build, a shard of its own, kept them), and equals both."""
    log, reference = hour
    short = write_log(tmp_path / "short.mcap", walk(5, start_s=3 * 86400))
    report = build_json(log, short, "-o", tmp_path / "one.aion", "--workers", "1")
    assert report["log_times_dropped"] == {}
    assert report["detections"]["used"] == HOUR_MESSAGES + 5
    assert report["time_span"]["end_ns"] == T0 + (3 * 86400 + 4) * S
    continued = tmp_path / "continued.aion"
    build_json(short, "--map", reference, "-o", continued)
    assert_same_arrays(map_arrays(tmp_path / "one.aion"), map_arrays(continued))
    build_json(log, short, "-o", tmp_path / "two.aion", "--workers", "2")
    assert_same_arrays(map_arrays(tmp_path / "one.aion"), map_arrays(tmp_path / "two.aion"))


# -- the rule itself --------------------------------------------------------------------------


def test_the_stray_rule() -> None:
    day = 86_400 * S
    bulk = T0 + np.arange(1000, dtype=np.int64) * S
    # a lone message (either side), a run of ten: strays; eleven: a session of its own
    for extra, stray in [
        ([T0 + 400 * day], 1),
        ([T0 - 9 * day], 1),
        (list(T0 + 2 * day + np.arange(10) * S), 10),
        (list(T0 + 2 * day + np.arange(11) * S), 0),
    ]:
        t = np.concatenate([bulk, np.array(extra, np.int64)])
        mask = stray_mask(t[::-1])  # any order
        assert int(mask.sum()) == stray, extra
        assert not mask[::-1][: bulk.size].any()
    # just under a day away is the same run
    assert not stray_mask(np.append(bulk, bulk[-1] + day)).any()
    assert stray_mask(np.append(bulk, bulk[-1] + day + 1)).sum() == 1
    # sparse topics (no run of more than ten) and small topics lose nothing
    assert not stray_mask(T0 + np.arange(30, dtype=np.int64) * 2 * day).any()
    assert not stray_mask(np.array([T0, T0 + 400 * day], np.int64)).any()
    # a run of at most ten messages but more than 5 % of the topic stays
    small = np.concatenate(
        [
            T0 + np.arange(100, dtype=np.int64) * S,
            T0 + 9 * day + np.arange(STRAY_MAX_MESSAGES, dtype=np.int64) * S,
        ]
    )
    assert not stray_mask(small).any()


# -- window closing costs O(recorded windows) -------------------------------------------------


def _batch(t: np.ndarray) -> DetectionBatch:
    n = len(t)
    return DetectionBatch.from_arrays(
        t, np.column_stack([np.full(n, 2.1), np.full(n, 0.1), np.zeros(n)]), np.zeros(n), np.ones(n)
    )


def test_a_long_fixed_sensor_gap_closes_only_recorded_windows(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Two recordings 230 years apart (11.6 million windows between them): closing visits the
    twelve recorded windows and closes two days, not one per elapsed window or day."""
    from aion_cli.engine.state import MapState

    config = ModelConfig()
    delta = window_ns(config.window_s)
    mapper = Mapper(config)
    w_first = (-2_000_000_000 * S) // delta  # 1906
    w_far = (MAX_TIME_NS - 3600 * S) // delta  # 2260
    windows = np.concatenate([w_first + np.arange(6), w_far + np.arange(6)]).astype(np.int64)
    mapper.set_fixed_windows(windows)
    recorded: list[int] = []
    days: list[int] = []
    record, close_day = MapState.record_window, MapState.close_day

    def counted_record(self: MapState, window: int, *args: Any) -> None:
        recorded.append(int(window))
        record(self, window, *args)

    def counted_close(self: MapState) -> None:
        days.append(1)
        close_day(self)

    monkeypatch.setattr(MapState, "record_window", counted_record)
    monkeypatch.setattr(MapState, "close_day", counted_close)
    mapper.add_detections(_batch(w_first * delta + np.arange(60, dtype=np.int64) * 60 * S))
    mapper.add_detections(_batch(w_far * delta + np.arange(60, dtype=np.int64) * 60 * S))
    mapper.advance(MAX_TIME_NS)
    assert recorded == windows.tolist()
    assert len(days) <= 3


@pytest.mark.parametrize("t", [MAX_TIME_NS + 1, 2**63 - 1, 2**63 + 5, -(2**63)])
def test_times_outside_the_range_are_an_input_error(t: int) -> None:
    """Before: ``advance`` past 2262 was an OverflowError (exit 1 from the CLI)."""
    mapper = Mapper(ModelConfig())
    with pytest.raises(InputError, match=re.escape("outside 1900-01-01 .. 2261-01-01 UTC")):
        mapper.advance(t)


def _covered_reference(src: ObservationSource, first: int, stop: int, delta: int) -> list[int]:
    """Covered windows by definition, window by window (the slow way)."""
    out = set()
    for w in range(first, stop):
        lo, hi = w * delta, (w + 1) * delta
        if np.any((src.pose_t >= lo) & (src.pose_t < hi)) or src.fixed_covers(w, delta):
            out.add(w)
    return sorted(out)


def test_covered_windows_equal_their_definition() -> None:
    """Merged intervals and binary search give the windows the definition gives, for
    overlapping, touching, empty and nested intervals and poses."""
    from aion_cli.engine.types import Trajectory

    rng = np.random.default_rng(14)
    delta = 100
    for _ in range(50):
        src = ObservationSource()
        for _ in range(int(rng.integers(0, 6))):
            s = int(rng.integers(-500, 3000))
            src.set_fixed_sensor(s, s + int(rng.integers(0, 700)))
        src.add_fixed_windows(rng.integers(-5, 30, size=int(rng.integers(0, 5))), delta)
        t = rng.integers(-500, 3000, size=int(rng.integers(0, 8)))
        src.add_trajectory(Trajectory(t.astype(np.int64), np.zeros((len(t), 3))))
        first, stop = sorted(int(v) for v in rng.integers(-8, 35, size=2))
        got = src.covered_windows(first, stop, delta).tolist()
        assert got == _covered_reference(src, first, stop, delta)
        w = np.arange(-8, 35, dtype=np.int64)
        expect = [
            bool(
                np.any(
                    (src.fixed_start < (x + 1) * delta)
                    & (src.fixed_end > x * delta)
                    & (src.fixed_end > src.fixed_start)
                )
            )
            for x in w.tolist()
        ]
        assert src.fixed_mask(w, delta).tolist() == expect
