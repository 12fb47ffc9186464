"""``aion convert --observed`` records its spans in the log (MCAP metadata, a ROS 1 bag's
latched topic, rosbag2 custom_data) beside the empty marker messages, and ``aion build``
reads them as ``--observed`` spans: converting with the spans and building gives the
observed windows of converting without them and building with ``--observed``. Before, the
markers made a window the span only partly covers count whole (27.0 windows against 26.2)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from aion_cli.formats.mapfile import read_manifest
from tests.cli.atc_sessions import SPAN, convert_atc, observed_windows, write_two_sessions
from tests.cli.conftest import assert_one_line_error, run, run_json


@pytest.fixture(scope="module")
def two(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_two_sessions(tmp_path_factory.mktemp("two") / "two.csv")


def test_converting_with_spans_observes_what_building_with_them_does(
    two: Path, tmp_path: Path
) -> None:
    """The span ends at 12:02 inside 12:00-12:10, which holds only markers: 24 windows to
    12:00, 0.2 of the next, then 08:00-08:10 on the 24th and 08:10-08:20 to its last message
    (08:19:34, to the 10 s step: 29/30), 26.17 windows by either route."""
    marked, plain = tmp_path / "a.mcap", tmp_path / "b.mcap"
    convert_atc(two, marked, "--observed", SPAN)
    convert_atc(two, plain)
    a = run_json("build", marked, "-o", tmp_path / "a.aion", "--format", "json")
    b = run_json("build", plain, "-o", tmp_path / "b.aion", "--observed", SPAN,
                 "--format", "json")
    via_convert = observed_windows(tmp_path / "a.aion")
    via_build = observed_windows(tmp_path / "b.aion")
    assert via_build.max() == pytest.approx(24 + 0.2 + 1 + 29 / 30)
    assert via_convert.tobytes() == via_build.tobytes()
    assert a["windows"] == b["windows"] == 26
    assert any(n.startswith("a.mcap records the spans the sensor was observing")
               for n in a["notes"])


def test_observed_given_replaces_the_recorded_spans(two: Path, tmp_path: Path) -> None:
    """--observed takes precedence: the markers then count as messages (as in a log that
    records no spans), so the window 12:00-12:10 counts whole: 27 - 1/30 windows."""
    marked = tmp_path / "a.mcap"
    convert_atc(two, marked, "--observed", SPAN)
    built = run_json("build", marked, "-o", tmp_path / "a.aion", "--observed", SPAN,
                     "--format", "json")
    assert observed_windows(tmp_path / "a.aion").max() == pytest.approx(25 + 1 + 29 / 30)
    assert any(n.startswith("--observed replaces the observed spans a.mcap records")
               for n in built["notes"])


def test_a_log_that_records_no_spans_counts_its_markers_whole(
    two: Path, tmp_path: Path
) -> None:
    """A log converted by older aion (the same rosbag2 folder without the spans): the
    markers are messages, the window 12:00-12:10 counts whole, as before."""
    marked = tmp_path / "old"
    convert_atc(two, marked, "--observed", SPAN)
    meta = marked / "metadata.yaml"
    doc = yaml.safe_load(meta.read_text())
    custom = doc["rosbag2_bagfile_information"]["custom_data"]
    assert custom.pop("aion.observed") == "1795420800000000000..1795435320000000000"
    meta.write_text(yaml.safe_dump(doc))
    run_json("build", marked, "-o", tmp_path / "old.aion", "--format", "json")
    assert observed_windows(tmp_path / "old.aion").max() == pytest.approx(25 + 1 + 29 / 30)


@pytest.mark.parametrize("name", ["a.mcap", "a.bag", "a"])
def test_every_container_records_the_spans(two: Path, tmp_path: Path, name: str) -> None:
    """MCAP, ROS 1 bag and rosbag2 read back the spans convert was given (two of them, in
    ns), and aion info LOG lists them."""
    from aion_cli.formats.log_zone import declared_spans

    log = tmp_path / name
    convert_atc(two, log, "--observed", SPAN, "--observed", "2026-11-24 07:31..2026-11-24 07:44")
    spans = ((1795420800 * 10**9, 1795435320 * 10**9), (1795505460 * 10**9, 1795506240 * 10**9))
    assert declared_spans([log]) == {str(log): spans}
    info = run_json("info", log, "--format", "json")
    assert [(s["start"], s["end"]) for s in info["observed_spans"][str(log)]] == [
        ("2026-11-23 08:00:00 UTC", "2026-11-23 12:02:00 UTC"),
        ("2026-11-24 07:31:00 UTC", "2026-11-24 07:44:00 UTC"),
    ]
    if name.endswith(".bag"):  # the bag's extra topic is named for what it is
        topic = next(t for t in info["topics"] if t["topic"] == "/aion/observed")
        assert topic["why"].startswith("the spans the sensor was observing")


def test_the_markers_of_two_logs_with_touching_spans_are_each_log_s() -> None:
    """Log A marks [0, 100 s) at 0, 30, 60, 90 s and 100 s - 1 ns, log B [100 s, 200 s) at
    100, 130, ..., 190 s and 200 s - 1 ns; a detection message shares the stamp 30 s. Without
    the markers one message is left, the detection's (the spans merged into [0, 200 s) would
    have marked 99.999... s and 100 s as no log did)."""
    from aion_cli.log_observed import marker_times, unmarked_times
    from aion_cli.log_times import TopicTimes

    s = 10**9
    a = [0, 30 * s, 60 * s, 90 * s, 100 * s - 1]
    b = [100 * s, 130 * s, 160 * s, 190 * s, 200 * s - 1]
    times = np.array([*b, 30 * s, *a], np.int64)  # any order
    marks = marker_times(((0, 100 * s), (100 * s, 200 * s)), TopicTimes(()), {})
    assert unmarked_times(times, marks).tolist() == [30 * s]


def test_a_span_before_the_first_detection_is_observed_by_either_route(tmp_path: Path) -> None:
    """The span starts at 08:00, the first detection is at 08:10:05 and the last at
    08:29:34: the window 08:00-08:10 holds no detection but is declared, so both routes
    observe it, then 08:10-08:20 and 08:20-08:30 to the last message (29/30): 2 + 29/30
    windows. build --observed had left 08:00-08:10 unknown (1 + 29/30), where the
    converted log, whose markers start at 08:00, observed it."""
    via_convert, via_build, b = _both_routes(tmp_path, "2026-11-23 08:00..2026-11-23 08:25")
    assert via_build.max() == pytest.approx(2 + 29 / 30)
    assert via_convert.tobytes() == via_build.tobytes()
    assert any(n.startswith("--observed: 1 window(s) without a message") for n in b["notes"])
    assert not any("lie " in n for n in b["notes"])  # no declared window left unknown
    # the map's time starts at the span's start by either route, so an hour it observed is
    # not said to lie before its data (it started at the first detection, 08:10:05)
    starts = {read_manifest(tmp_path / f"{m}.aion")["time_span"]["start_ns"] for m in "ab"}
    assert starts == {1795420800 * 10**9}
    at = run("predict", tmp_path / "b.aion", "--time", "2026-11-23 08:05")
    assert at.exit_code == 0
    assert "before the map's data" not in at.stderr


def _late_rows(path: Path, minutes: range) -> Path:
    """ATC rows from 08:10 UTC on 2026-11-23: one person a minute (of ``minutes``) walking
    for 30 s from 5 s past it (minutes 0-19: the last row at 08:29:34)."""
    t0 = 1795421400  # 2026-11-23 08:10 UTC
    path.write_text("".join(
        f"{t0 + minute * 60 + 5 + i}.000,{minute + 1},{-10 + i * 0.5:.3f},1.000,0.5,0.0\n"
        for minute in minutes for i in range(30)
    ))
    return path


def _both_routes(tmp_path: Path, span: str) -> tuple[np.ndarray, np.ndarray, Any]:
    """The :func:`_late_rows` of minutes 0-19 observed over ``span`` by either route: converted
    with ``--observed`` and built as it is (``a.mcap`` → ``a.aion``), and converted plain and
    built with ``--observed`` (``b.mcap`` → ``b.aion``). Each map's observed windows, and the
    second build's JSON report."""
    late = _late_rows(tmp_path / "late.csv", range(20))
    marked, plain = tmp_path / "a.mcap", tmp_path / "b.mcap"
    convert_atc(late, marked, "--observed", span)
    convert_atc(late, plain)
    run_json("build", marked, "-o", tmp_path / "a.aion", "--format", "json")
    b = run_json("build", plain, "-o", tmp_path / "b.aion", "--observed", span,
                 "--format", "json")
    return observed_windows(tmp_path / "a.aion"), observed_windows(tmp_path / "b.aion"), b


def test_a_span_after_the_last_detection_is_observed_by_either_route(tmp_path: Path) -> None:
    """The span 08:00-08:55, detections 08:10:05 to 08:29:34: the windows 08:30-08:40 and
    08:40-08:50 and half of 08:50-09:00 hold no detection but are declared, so both routes
    observe 08:00 to 08:55: 5.5 windows, and both maps end at the span's last instant
    (08:54:59.999999999, the converted log's last marker). build --observed had stopped at
    the last message (3 windows, the map ending at 08:29:34), where the converted log,
    whose markers run to 08:55, observed them. The same from two files, with one worker or
    two, and from a map of the first file (its span to 08:20) continued with the second and
    the whole span. A map of the first file given the whole span has observed 08:20-08:55:
    the second file is refused, as after a log converted with the span (its markers run to
    08:55)."""
    span = "2026-11-23 08:00..2026-11-23 08:55"
    via_convert, via_build, b = _both_routes(tmp_path, span)
    assert via_convert.max() == pytest.approx(5.5)
    assert via_build.tobytes() == via_convert.tobytes()
    assert not any("stay unknown" in n for n in b["notes"])  # no declared window left out
    end = (1795420800 + 55 * 60) * 10**9 - 1
    assert read_manifest(tmp_path / "a.aion")["time_span"]["end_ns"] == end
    assert read_manifest(tmp_path / "b.aion")["time_span"]["end_ns"] == end
    # the same detections in two files (08:10-08:20, 08:20-08:30)
    files = []
    for k, minutes in enumerate((range(10), range(10, 20))):
        files.append(tmp_path / f"f{k}.mcap")
        convert_atc(_late_rows(tmp_path / f"f{k}.csv", minutes), files[k])
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}.aion"
        run_json("build", *files, "-o", out, "--observed", span, "--workers", workers,
                 "--format", "json")
        assert observed_windows(out).tobytes() == via_convert.tobytes()
        assert read_manifest(out)["time_span"]["end_ns"] == end
    step = tmp_path / "step.aion"
    run_json("build", files[0], "-o", step, "--observed", "2026-11-23 08:00..2026-11-23 08:20",
             "--format", "json")
    run_json("build", files[1], "--map", step, "--observed", span, "--format", "json")
    assert observed_windows(step).tobytes() == via_convert.tobytes()
    assert read_manifest(step)["time_span"]["end_ns"] == end
    for key in ("windows", "recording_reach"):
        assert read_manifest(step)["counts"][key] == read_manifest(tmp_path / "w1.aion")[
            "counts"][key]
    whole = tmp_path / "whole.aion"
    run_json("build", files[0], "-o", whole, "--observed", span, "--format", "json")
    refused = run("build", files[1], "--map", whole, "-q", "--observed", span)
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "but whole.aion has already closed every window "
                          "before 2026-11-23 08:50:00 UTC: logs must be added to a map in time "
                          "order")


@pytest.mark.parametrize("workers", ["1", "2"])
def test_two_logs_whose_spans_overlap_mark_their_shared_stamps_twice(
    two: Path, tmp_path: Path, workers: str
) -> None:
    """Nobody on the 25th: log A records 08:00-09:00, log B 08:30-09:30, so each marks
    08:30, 08:30:30, ... 08:59:30: two empty messages at each of those stamps. Beside the
    people's log, 08:00-09:30 is 9 windows without a detection, as one log recording
    08:00-09:30 says. The markers were removed once per stamp, so B's kept 08:30-09:00 as
    windows with a message: "6 window(s) without a message"."""
    empty = tmp_path / "none.csv"
    empty.write_text("")
    people = tmp_path / "people.mcap"
    convert_atc(two, people)
    spans = {"a": ("2026-11-25 08:00..2026-11-25 09:00",),
             "b": ("2026-11-25 08:30..2026-11-25 09:30",),
             "ab": ("2026-11-25 08:00..2026-11-25 09:30",)}
    for name, span in spans.items():
        convert_atc(empty, tmp_path / f"{name}.mcap", *(a for s in span for a in ("--observed", s)))
    notes, windows = {}, {}
    for name, logs in (("two", ("a", "b")), ("one", ("ab",))):
        built = run_json("build", people, *(tmp_path / f"{k}.mcap" for k in logs), "-o",
                         tmp_path / f"{name}.aion", "--format", "json", "--workers", workers)
        notes[name] = [n for n in built["notes"] if "window(s)" in n and "observed" in n]
        windows[name] = observed_windows(tmp_path / f"{name}.aion")
    assert notes["two"] == notes["one"] == [
        "the observed spans the logs record: 9 window(s) with no message but the logs' empty "
        "markers taken as observed (1.5 h), the time between the logs included"
    ]
    assert windows["two"].max() == pytest.approx(4 - 1 / 30 + 9)
    assert windows["two"].tobytes() == windows["one"].tobytes()


@pytest.mark.parametrize("logs", [1, 2])
def test_one_logs_own_declared_span_has_no_time_between_logs(tmp_path: Path, logs: int) -> None:
    """A Lincoln file whose header declares 2017-06-09 08:13:47..11:13:47 (two walkers for
    20 s at 09:13:47), converted with its header span and built alone: the note of the
    windows the span made observed said "the time between the logs included", of one log.
    It says so only of logs apart: the same file a day later, built beside it, keeps it."""
    t0 = 1_496_999_627  # 2017-06-09 09:13:47 UTC
    built = []
    for day in range(logs):
        t = t0 + day * 86_400
        rows = [f"{t + k} {k} -1.0\n{t + k} 10.0 {5.0 - 0.8 * k}" for k in range(20)]
        text = tmp_path / f"day{day}.txt"
        text.write_text(f"{t - 3600} {t + 7200}\n-8 12\n-3 17\n" + "\n".join(rows) + "\n")
        log = tmp_path / f"day{day}.mcap"
        converted = run("convert", text, "--layout", "lincoln", "-o", log, "-q")
        assert converted.exit_code == 0, converted.stderr
        built.append(log)
    report = run_json("build", *built, "-o", tmp_path / "m.aion", "--format", "json")
    assert not [n for n in report["notes"] if n.startswith("--observed: ")]  # none given
    (note,) = [n for n in report["notes"] if n.startswith("the observed spans the logs record")]
    # 08:10-11:20 is 19 windows a day, the one of 09:10 holding the walkers
    head = (
        f"the observed spans the logs record: {18 * logs} window(s) with no message but the "
        "logs' empty markers taken as observed "
    )
    assert note.startswith(head), note
    assert note.endswith("the time between the logs included") is (logs == 2), note
