"""``aion build``: counts, provenance, topics, graphs, observation, config and continuation,
checked against what the generated office log is known to hold (its frames:
``test_build_frames.py``)."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import tomllib
from pathlib import Path

from aion_cli.engine.config import ModelConfig
from tests.cli.conftest import Office, assert_one_line_error, run, run_json, run_process
from tests.cli.logdata import (
    DURATION_S,
    PLACES,
    write_office_log,
)

FIXED_TWO_WINDOWS = (
    "fixed sensor over the 2 windows with messages (2 of the 2 windows of 10 min from the first "
    "to the last)"
)


def test_counts_and_provenance(office: Office) -> None:
    report = office.build
    expected = office.expected
    assert report["detections"] == {"read": 300, "used": 300, "dropped": {}}
    assert expected.detections == 300
    assert report["nodes"] == len(PLACES)
    assert report["nodes_with_flow"] == 3  # p1, p3, p4: where the three people stand
    assert report["graph"]["source"] == "log"
    assert report["graph"]["messages"] == expected.graph_messages
    assert report["graph"]["topics"] == ["/hydra/backend/dsg"]
    assert report["detection_topics"] == ["/tracks"]
    assert report["observation"] == "tf map->base_link"
    span = report["time_span"]
    assert span["start_ns"] == expected.start_ns
    assert span["end_ns"] == expected.end_ns
    assert span["seconds"] == (expected.end_ns - expected.start_ns) / 1e9
    (entry,) = report["inputs"]
    assert entry["sha256"] == hashlib.sha256(office.log.read_bytes()).hexdigest()
    assert entry["size"] == office.log.stat().st_size
    assert report["map_bytes"] == office.map.stat().st_size
    # every detection stands within 1 m of a place: all cells end up bound to nodes
    assert report["cells"] == 0
    assert report["bound_cells"] == 3
    assert report["windows"] == 2  # 20 minutes: one closed 600-s window and the open one


def test_a_log_shorter_than_a_window_observed_one(tmp_path: Path) -> None:
    """A fixed sensor's 4-minute log (THÖR's runs, a leg_tracker bag) counts 0.4 of its
    window: the summary said "windows observed 0" beside the detections it used and "fixed
    sensor over the 1 window with messages"."""
    log = tmp_path / "short.mcap"
    write_office_log(log, graph=False, tf=False, duration_s=240)
    report = run_json("build", log, "-o", tmp_path / "short.aion", "--format", "json")
    assert report["detections"]["used"] > 0
    assert report["observation"].startswith("fixed sensor over the 1 window with messages")
    assert report["windows"] == 1
    table = run("build", log, "-o", tmp_path / "again.aion")
    assert re.search(r"observed windows \(most of any entry\)\s*│\s*1\s*│", table.stderr), (
        table.stderr
    )


def test_a_log_shorter_than_a_window_is_not_said_to_span_it(tmp_path: Path) -> None:
    """A fixed sensor's 250-second log, inside one 10-minute window: the build's summary and
    ``aion info`` said "fixed sensor over the 1 window with messages (10 min of a 10 min
    span)", four times the log's time; they count the windows: 1 of the 1 window (of 10
    min) from the first to the last. The manifest keeps the text, which read back says the
    sensor observed all of its logs' time (no advice to declare spans)."""
    from aion_cli.formats.mapfile import read_manifest

    log, out = tmp_path / "short.mcap", tmp_path / "short.aion"
    write_office_log(log, graph=False, tf=False, duration_s=250)
    report = run_json("build", log, "-o", out, "--format", "json")
    words = "fixed sensor over the 1 window with messages (1 of the 1 windows of 10 min from "
    assert report["observation"] == words + "the first to the last)"
    assert "min span" not in report["observation"]
    info = run_json("info", out, "--format", "json")
    assert info["observation"] == report["observation"] == read_manifest(out)["observation"]
    assert not any("--observed" in note for note in report["notes"])


def test_observed_windows_and_windows_with_messages_are_told_apart(tmp_path: Path) -> None:
    """A fixed sensor from 08:05 to 08:50: messages in the five windows 08:00..08:40 (what
    ``aion info`` counts), recorded for 0.5 + 4 of them (the first from 08:05 on), the count
    the map's flows divide by: 4.5, shown rounded half up (5; Python's round made it 4, an
    even 4 beside the 5 windows with messages). The build table and the report called
    it "windows observed" beside "5 windows with messages"; they now name it for what it is,
    and the report's row is the build's."""
    log = tmp_path / "late.mcap"
    write_office_log(log, tf=False, shift_s=300, duration_s=2700)
    info = run("info", log)
    assert info.exit_code == 0, info.stderr
    assert "fixed sensor over the 5 windows of 10 min with messages" in " ".join(
        info.stderr.split()
    ), info.stderr
    out = tmp_path / "late.aion"
    table = run("build", log, "-o", out)
    assert table.exit_code == 0, table.stderr
    assert re.search(r"observed windows \(most of any entry\)\s*│\s*5\s*│", table.stderr), (
        table.stderr
    )
    assert "windows observed" not in table.stderr
    page = run("report", out, "--time", "2026-11-23 08:30", "-o", tmp_path / "report", "-q")
    assert page.exit_code == 0, page.stderr
    html = (tmp_path / "report" / "index.html").read_text()
    assert "observed windows (most of any entry)</td><td class=\"n\">5</td>" in html
    assert "windows observed" not in html


def test_help_names_every_json_key(office: Office) -> None:
    """``build --help`` lists the JSON report's keys: every key the report has, nested ones
    included, is named there (mean_speed_m_s was missing)."""
    import re

    shown = " ".join(run("build", "--help").stdout.split())

    def keys(doc: object) -> set[str]:
        if not isinstance(doc, dict):
            return set()
        out = set()
        for key, value in doc.items():
            if key not in ("dropped", "detections_by_topic", "detection_decoding",
                           "log_times_dropped"):  # keyed by reasons and topics: their values
                out.add(key)
                out |= keys(value) if key != "inputs" else set()
        return out

    missing = sorted(k for k in keys(office.build) if not re.search(rf"\b{k}\b", shown))
    assert missing == []


def test_default_output_is_the_first_log_name(office: Office, tmp_path: Path) -> None:
    log = tmp_path / "run7.mcap"
    shutil.copy(office.log, log)
    result = run("build", log, "-q")
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "run7.aion").is_file()
    assert result.stdout == ""


def test_summary_table_goes_to_stderr(office: Office, tmp_path: Path) -> None:
    result = run("build", office.log, "-o", tmp_path / "m.aion")
    assert result.exit_code == 0, result.stderr
    assert result.stdout == ""
    assert "detections read" in result.stderr
    assert "300" in result.stderr


def test_ros1_bag_gives_the_same_counts_and_frames_go_through_tf(tmp_path: Path) -> None:
    bag = tmp_path / "office.bag"
    write_office_log(bag, "bag", frame="base_link")
    report = run_json("build", bag, "--format", "json")
    assert report["detections"]["used"] == 300
    assert report["bound_cells"] == 3  # positions moved back into the map frame by TF


def test_named_detection_topic_that_does_not_exist(office: Office, tmp_path: Path) -> None:
    result = run("build", office.log, "--detections-topic", "/people", "-o", tmp_path / "x.aion")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "/people")
    assert "--detections-topic /tracks" in result.stderr  # ready to paste
    assert not (tmp_path / "x.aion").exists()


def test_the_map_never_overwrites_a_log(office: Office) -> None:
    before = office.log.read_bytes()
    result = run("build", office.log, "-o", office.log)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "overwrite the log")
    assert office.log.read_bytes() == before


def test_missing_and_unreadable_logs(tmp_path: Path) -> None:
    result = run("build", tmp_path / "missing.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "missing.mcap")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not a log at all")
    result = run("build", junk)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr)
    assert not (tmp_path / "junk.aion").exists()


def test_print_config_round_trips_and_a_bad_config_is_refused(tmp_path: Path) -> None:
    result = run("build", "--print-config")
    assert result.exit_code == 0
    parsed = tomllib.loads(result.stdout)["model"]
    assert ModelConfig.from_dict(parsed) == ModelConfig()
    bad = tmp_path / "bad.toml"
    bad.write_text("[model]\ncell_size = -1\n")
    result = run("build", "x.mcap", "--config", bad)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "cell_size")
    unknown = tmp_path / "unknown.toml"
    unknown.write_text("[model]\ncel_size = 1\n")
    result = run("build", "x.mcap", "--config", unknown)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "cel_size")


def test_print_config_with_map_prints_the_parameters_the_map_keeps(
    office: Office, tmp_path: Path
) -> None:
    """``aion build --print-config --map site.aion`` printed the defaults, not the map's
    parameters, which a continued build uses (the file, given back with --config, was then
    refused as differing). It prints the map's now; --config FILE still prints the file's."""
    config = tmp_path / "model.toml"
    config.write_text(ModelConfig(cell_size=0.25, window_s=1200.0).to_toml())
    site = tmp_path / "site.aion"
    assert run("build", office.log, "-o", site, "--config", config, "-q").exit_code == 0
    printed = run("build", "--print-config", "--map", site)
    assert printed.exit_code == 0, printed.stderr
    kept = ModelConfig.from_dict(tomllib.loads(printed.stdout)["model"])
    assert (kept.cell_size, kept.window_s) == (0.25, 1200.0)
    assert kept == ModelConfig.from_toml_text(config.read_text())
    again = tmp_path / "again.toml"
    again.write_text(printed.stdout)  # given back, it is the map's own config
    assert run("build", "--print-config", "--config", again).stdout == printed.stdout
    assert tomllib.loads(run("build", "--print-config").stdout)["model"]["cell_size"] == 0.5

def test_config_file_is_used_and_recorded(office: Office, tmp_path: Path) -> None:
    config = tmp_path / "model.toml"
    config.write_text(ModelConfig(cell_size=0.25, bind_radius=0.1).to_toml())
    out = tmp_path / "fine.aion"
    report = run_json("build", office.log, "-o", out, "--config", config, "--format", "json")
    # a 0.1-m bind radius binds nothing: the detections stay on 0.25-m hash cells
    assert report["cells"] == 3
    assert report["bound_cells"] == 0
    predicted = run_json("predict", out, "--historical", "--layer", "cells", "--format", "json")
    assert {e["id"] for e in predicted["entries"]} == {e["id"] for e in predicted["entries"]}
    assert len(predicted["entries"]) == 3


def test_continuing_a_map_equals_building_at_once(tmp_path: Path) -> None:
    day1, day2 = tmp_path / "day1.mcap", tmp_path / "day2.mcap"
    write_office_log(day1)
    write_office_log(day2, shift_s=86400)
    both = tmp_path / "both.aion"
    once = run_json("build", day1, day2, "-o", both, "--format", "json")
    assert once["detections"]["used"] == 600
    step = tmp_path / "step.aion"
    run_json("build", day1, "-o", step, "--format", "json")
    cont = run_json("build", day2, "--map", step, "--format", "json")
    assert cont["continued"] is True
    assert cont["map"] == str(step)
    assert cont["time_span"] == once["time_span"]
    at = "2026-11-24 08:05"
    a = run_json("predict", both, "--time", at, "--format", "json")["entries"]
    b = run_json("predict", step, "--time", at, "--format", "json")["entries"]
    assert a == b
    manifest = run_json("info", step, "--format", "json")
    assert manifest["counts"]["used"] == 600  # over both builds
    assert manifest["last_build"]["used"] == 300
    assert [i["name"] for i in manifest["inputs"]] == ["day1.mcap", "day2.mcap"]
    # the same log cannot be added twice
    result = run("build", day2, "--map", step)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "already in the map")


def test_duration_constant_matches_the_log(office: Office) -> None:
    assert office.expected.end_ns - office.expected.start_ns < DURATION_S * 1_000_000_000


def test_observation_from_the_scene_graph_agents_or_fixed(tmp_path: Path) -> None:
    """Without TF, robot poses come from the scene graph's agent layer; a graph without
    agents (the office's) means a fixed sensor, and the summary says so.

    30 minutes (windows 1-2 closed, 3 open); the person at p3 leaves after window 1. The
    agent-layer robot stands near p3 in window 1 only, so window 2 is unobserved at p3 and
    teaches nothing (60 detections in 1 window); a fixed sensor saw p3 empty in windows 2 and
    3 (it recorded messages in all three; queries count the open window as closing it would
    record it): 60 detections in 3 windows."""
    fixed_log = tmp_path / "fixed.mcap"
    write_office_log(fixed_log, tf=False, duration_s=1800)
    report = run_json("build", fixed_log, "--format", "json")
    assert report["observation"] == (
        "fixed sensor over the 3 windows with messages (3 of the 3 windows of 10 min from the "
        "first to the last)"
    )
    assert report["detections"]["used"] == 180 + 180 + 60
    fixed = run_json(
        "predict", tmp_path / "fixed.aion", "--historical", "--node", "p3", "--format", "json"
    )
    assert fixed["entries"][0]["flow"] == 20.0

    agents_log = tmp_path / "agents.mcap"
    write_office_log(agents_log, tf=False, agents=True, duration_s=1800)
    report = run_json("build", agents_log, "--format", "json")
    assert report["observation"] == "scene-graph agent layer"
    seen = run_json(
        "predict", tmp_path / "agents.aion", "--historical", "--node", "p3", "--format", "json"
    )
    assert seen["entries"][0]["flow"] == 60.0


def test_several_detection_topics_are_all_used_unless_named(tmp_path: Path) -> None:
    log = tmp_path / "two.mcap"
    write_office_log(log, second_topic="/tracks_fused")
    report = run_json("build", log, "--format", "json")
    assert report["detection_topics"] == ["/tracks", "/tracks_fused"]
    assert report["detections"]["used"] == 600
    report = run_json(
        "build",
        log,
        "--detections-topic",
        "/tracks_fused",
        "-o",
        tmp_path / "one.aion",
        "--format",
        "json",
    )
    assert report["detection_topics"] == ["/tracks_fused"]
    assert report["detections"]["used"] == 300


def test_rosbag2_folder_map_is_named_after_the_folder(tmp_path: Path) -> None:
    folder = tmp_path / "run3"
    write_office_log(folder, "rosbag2-sqlite3")
    result = run("build", f"{folder}/", "-q")
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "run3.aion").is_file()
    doc = run_json("info", tmp_path / "run3.aion", "--format", "json")
    assert doc["counts"]["used"] == 300


def test_subprocess_build_json_on_stdout_and_nothing_else(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "sub.aion"
    proc = run_process("build", office.log, "-o", out, "--format", "json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["detections"]["used"] == 300
    assert report["map_bytes"] == out.stat().st_size
    assert proc.stderr == ""  # no progress bar when stderr is not a terminal, no table with json


def test_a_missing_robot_frame_is_noted(office: Office, tmp_path: Path) -> None:
    report = run_json(
        "build", office.log, "--base-frame", "robot", "-o", tmp_path / "r.aion", "--format", "json"
    )
    assert report["observation"] == FIXED_TWO_WINDOWS
    # the warning names the frame TF moves (the chain note, which said it again, is left out)
    said = report["warnings"] + report["notes"]
    assert any("no map->robot chain" in line and "base_link" in line for line in said), said


def test_fixed_sensor_logs_continue_like_building_at_once(tmp_path: Path) -> None:
    """Without a robot trajectory each file is observed over its own span, not the gap
    between files, so continuing a map equals building from both logs at once."""
    day1, day2 = tmp_path / "day1.mcap", tmp_path / "day2.mcap"
    write_office_log(day1, tf=False)
    write_office_log(day2, tf=False, shift_s=86400)
    both = tmp_path / "both.aion"
    once = run_json("build", day1, day2, "-o", both, "--format", "json")
    # windows 0-1 and 144-145 hold messages: 4 windows of a 146-window span
    assert once["observation"] == (
        "fixed sensor over the 4 windows with messages (4 of the 146 windows of 10 min from the "
        "first to the last)"
    )
    step = tmp_path / "step.aion"
    run_json("build", day1, "-o", step, "--format", "json")
    cont = run_json("build", day2, "--map", step, "--format", "json")
    assert cont["windows"] == once["windows"]
    at = "2026-11-24 08:05"
    a = run_json("predict", both, "--time", at, "--format", "json")["entries"]
    b = run_json("predict", step, "--time", at, "--format", "json")["entries"]
    assert a == b


def test_time_spans_read_in_seconds_under_a_minute() -> None:
    from aion_cli.cli.build_summary import span_text

    assert span_text(0.3) == "0.3 s"
    assert span_text(59.4) == "59.4 s"
    assert span_text(59.6) == "1m00s"
    assert span_text(None) == "-"


def test_time_spans_of_two_days_or_more_read_in_days_and_hours() -> None:
    """A log stamped mostly in 1970 and once in 2026 read ``491015h59m59s``: under two days a
    span keeps hours, minutes and seconds; from two days on it reads days and hours."""
    from datetime import UTC, datetime

    from aion_cli.cli.build_summary import span_text

    day = 86400
    assert span_text(day + 23 * 3600 + 59 * 60 + 59) == "47h59m59s"  # 1 d 23 h 59 m 59 s
    assert span_text(2 * day - 0.4) == "2d00h"  # rounds to the second first, as the rest do
    assert span_text(2 * day) == "2d00h"
    assert span_text(5 * day) == "5d00h"  # the sample's 5 days read 120h00m00s
    assert span_text(2 * day + 5 * 3600 + 29 * 60) == "2d05h"  # to the nearest hour
    assert span_text(2 * day + 5 * 3600 + 30 * 60) == "2d06h"
    # 56 years from 1970 to 2026: 56 x 365 days and one more for each of the 14 leap years
    # 1972, 1976, ..., 2024
    years = datetime(2026, 1, 1, 15, tzinfo=UTC) - datetime(1970, 1, 1, tzinfo=UTC)
    assert span_text(years.total_seconds()) == f"{56 * 365 + 14:,}d15h" == "20,454d15h"
