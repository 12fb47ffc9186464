"""``aion info`` shows the span the build will have: a message whose log time is damaged (a
run of at most ten messages more than a day from its topic's others, the build's stray rule,
:mod:`aion_cli.log_times`) is left out of the span shown and named in one warning. Before,
one sqlite3 ``timestamp`` 100 days late made a 6.4-second bag show as 100 days long, without
a word, while ``build`` dropped that message."""

from __future__ import annotations

import shutil
import sqlite3
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest

from aion_cli.engine.mapper import MAX_TIME_NS
from tests.cli.conftest import run_json
from tests.robustness.conftest import T0 as T0_WALK
from tests.robustness.conftest import build_json, person, walk, write_log
from tests.robustness.mcap_edit import STRING_CDR, copy_with, payload_of
from tests.shared_data import real

S = 1_000_000_000
DAYS_100 = 100 * 86_400 * S
T0 = 1_700_000_000 * S


def test_a_damaged_sqlite3_timestamp_does_not_widen_the_span(tmp_path: Path) -> None:
    """rosbag2's own reindex test bag (three sqlite3 files, no metadata.yaml), one row's
    timestamp moved 100 days on: the span is the undamaged bag's, and the stray is named."""
    source = real("logs", "rosbag2_tests", "rosbag2_py_sqlite3_reindex_test_bags_multiple_files")
    intact = run_json("info", source, "--format", "json")
    copy = tmp_path / "bag"
    shutil.copytree(source, copy)
    with sqlite3.connect(copy / "multiple_files_1.db3") as db:
        (stamp,) = db.execute("SELECT timestamp FROM messages WHERE id = 4").fetchone()
        db.execute("UPDATE messages SET timestamp = ? WHERE id = 4", (stamp + DAYS_100,))
    damaged = run_json("info", copy, "--format", "json")
    assert damaged["messages"] == intact["messages"]
    assert (damaged["start_ns"], damaged["end_ns"], damaged["span_s"]) == (
        intact["start_ns"],
        intact["end_ns"],
        intact["span_s"],
    )
    strays = [w for w in damaged["warnings"] if "stray log time" in w]
    assert len(strays) == 1
    assert "1 on /chatter" in strays[0]
    assert len(damaged["warnings"]) == len(intact["warnings"]) + 1


@pytest.mark.parametrize("container", ["bag", "mcap", "rosbag2-sqlite3"])
def test_a_stray_log_time_is_left_out_of_the_span_in_every_container(
    container: str, tmp_path: Path
) -> None:
    """30 messages one a second on /chatter and /people_count, and one /chatter message
    100 days later: the span is 29 s, the stray named; a second stray-free log is untouched."""
    from aion_cli.formats.writers import LogWriter

    path = tmp_path / ("log.bag" if container == "bag" else "log.mcap" if container == "mcap"
                       else "log")  # fmt: skip
    with LogWriter(path, container) as w:
        for k in range(30):
            w.write("/chatter", "std_msgs/msg/String", {"data": f"m{k}"}, T0 + k * S)
            w.write("/people_count", "std_msgs/msg/Int32", {"data": k}, T0 + k * S)
        w.write("/chatter", "std_msgs/msg/String", {"data": "late"}, T0 + DAYS_100)
    info = run_json("info", path, "--format", "json")
    assert (info["start_ns"], info["end_ns"]) == (T0, T0 + 29 * S)
    assert info["span_s"] == 29.0
    (warning,) = [w for w in info["warnings"] if "stray log time" in w]
    assert "1 on /chatter (first: 2024-02-22 22:13:20 UTC)" in warning, warning


def _thirty_seconds(path: Path, container: str, t0: int, stray: int | None = None) -> None:
    """30 messages one a second on /chatter and /people_count from ``t0``; with ``stray``,
    one more /chatter message at that time."""
    from aion_cli.formats.writers import LogWriter

    with LogWriter(path, container) as w:
        for k in range(30):
            w.write("/chatter", "std_msgs/msg/String", {"data": f"m{k}"}, t0 + k * S)
            w.write("/people_count", "std_msgs/msg/Int32", {"data": k}, t0 + k * S)
        if stray is not None:
            w.write("/chatter", "std_msgs/msg/String", {"data": "late"}, stray)


@pytest.mark.parametrize("container", ["bag", "mcap"])
def test_the_time_recorded_by_several_logs_leaves_a_stray_out(
    container: str, tmp_path: Path
) -> None:
    """Two logs of 29 s a week apart, the first with one message a year late: 58 s recorded,
    as for the two logs without the stray (before: the whole week between them)."""
    week = 7 * 86_400 * S
    a, b, clean = (tmp_path / f"{n}.{container}" for n in ("a", "b", "clean"))
    _thirty_seconds(a, container, T0, stray=T0 + 365 * 86_400 * S)
    _thirty_seconds(b, container, T0 + week)
    _thirty_seconds(clean, container, T0)
    damaged = run_json("info", a, b, "--format", "json")
    intact = run_json("info", clean, b, "--format", "json")
    assert damaged["recordings"] == intact["recordings"] == 2
    assert damaged["recorded_s"] == intact["recorded_s"] == 58.0
    assert damaged["span_s"] == intact["span_s"] == (week + 29 * S) / S
    assert any("1 on /chatter" in w for w in damaged["warnings"] if "stray log time" in w)


@pytest.mark.parametrize("when", [2**63 + 5, 2**64 - 1, MAX_TIME_NS + 86_400 * S])
def test_a_log_time_past_2261_is_left_out_of_the_span_as_the_build_drops_it(
    when: int, tmp_path: Path
) -> None:
    """Two minutes of /tracks and one more /tracks message at an MCAP (uint64) log time past
    the range a build takes (2261-01-01): info shows the two minutes, as the build's time
    span, and names the time as the build does. Before: a span of 87,076 days (2^63 + 5) or
    193,828 days (2^64 - 1) ending in 2262 or 2554, without a word."""
    clean = write_log(tmp_path / "clean.mcap", walk(120))
    late = copy_with(
        clean, tmp_path / "late.mcap", [("/tracks", "", payload_of(clean, "/tracks"), when)]
    )
    intact = run_json("info", clean, "--format", "json")
    info = run_json("info", late, "--format", "json")
    assert info["messages"] == intact["messages"] + 1
    for key in ("start_ns", "end_ns", "span_s", "recorded_s", "start", "end"):
        assert info[key] == intact[key], key
    assert (info["start_ns"], info["end_ns"]) == (T0_WALK, T0_WALK + 119 * S)
    first = (datetime(1970, 1, 1, tzinfo=UTC) + timedelta(microseconds=when // 1000)).strftime(
        "%Y-%m-%d %H:%M:%S UTC"
    )
    (warning,) = [w for w in info["warnings"] if "left out of the span" in w]
    assert "outside 1900-01-01 .. 2261-01-01 UTC" in warning, warning
    assert f"1 on /tracks (first: {first})" in warning, warning
    report = build_json(late, "-o", tmp_path / "late.aion")
    assert report["log_times_dropped"] == {"/tracks": {"out_of_range": 1, "stray": 0}}
    span = report["time_span"]
    assert (span["start_ns"], span["end_ns"]) == (info["start_ns"], info["end_ns"])


@pytest.mark.parametrize("late", [T0 + 365 * 86_400 * S, 2**64 - 1])
def test_a_topic_rate_is_over_the_time_without_the_left_out_times(
    late: int, tmp_path: Path
) -> None:
    """30 messages a second on /chatter and /people_count over 29 s, plus one /chatter
    message a year late (or at MCAP's last log time): /people_count's rate is the clean
    log's, /chatter's its 31 messages over 29 s (before: over the year, 9.8e-07 Hz)."""
    clean = tmp_path / "clean.mcap"
    _thirty_seconds(clean, "mcap", T0)
    if late <= MAX_TIME_NS:
        damaged = tmp_path / "damaged.mcap"
        _thirty_seconds(damaged, "mcap", T0, stray=late)
    else:
        damaged = copy_with(clean, tmp_path / "damaged.mcap", [("/chatter", "", STRING_CDR, late)])
    rates = {
        name: {t["topic"]: t["rate_hz"] for t in run_json("info", p, "--format", "json")["topics"]}
        for name, p in (("clean", clean), ("damaged", damaged))
    }
    assert rates["damaged"]["/people_count"] == rates["clean"]["/people_count"]
    assert rates["damaged"]["/chatter"] == pytest.approx(31 / 29, abs=1e-3)


def test_a_log_whose_every_time_lies_past_2261_says_so(tmp_path: Path) -> None:
    """Twenty /tracks messages, every one logged past int64 (2264): info shows the log's own
    span (the times are real, 19 s apart) and says every time lies outside the range a build
    takes (before: the 2264 span without a word; the build stops with exit 2)."""
    from tests.robustness.test_time_sanity import BEYOND_INT64, _copy_only_beyond

    source = write_log(tmp_path / "one.mcap", walk(1))
    payload = payload_of(source, "/tracks")
    extra = [("/tracks", "", payload, BEYOND_INT64 + k * S) for k in range(20)]
    mixed = copy_with(source, tmp_path / "mixed.mcap", extra)
    only_bad = tmp_path / "only_bad.mcap"
    _copy_only_beyond(mixed, only_bad)
    info = run_json("info", only_bad, "--format", "json")
    assert (info["start_ns"], info["end_ns"]) == (BEYOND_INT64, BEYOND_INT64 + 19 * S)
    assert (info["span_s"], info["recorded_s"]) == (19.0, 19.0)
    (warning,) = [w for w in info["warnings"] if "2261-01-01" in w]
    assert warning.startswith("every log time lies outside 1900-01-01 .. 2261-01-01 UTC"), warning
    assert "20 on /tracks (first: 2264-09-14 21:20:00 UTC)" in warning, warning


def test_a_span_shown_within_one_second_gives_ends_that_read_apart(tmp_path: Path) -> None:
    """20 messages 0.04 s apart and a stray 100 days on: the span shown read
    "(08:00:00 UTC .. 08:00:00 UTC)"; now with the decimals that tell its ends apart."""
    messages = [person(T0_WALK + k * S // 25, (2.1, 0.1, 0.0)) for k in range(20)]
    messages.append(person(T0_WALK + DAYS_100, (2.1, 0.1, 0.0)))
    info = run_json("info", write_log(tmp_path / "short.mcap", messages), "--format", "json")
    (stray,) = [w for w in info["warnings"] if "stray log time" in w]
    assert "(2026-11-23 08:00:00.0 UTC .. 2026-11-23 08:00:00.7 UTC)" in stray
