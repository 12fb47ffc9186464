"""``aion simulate`` through the real command group: files, summary, input errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from aion_cli.cli.main import cli
from tests.cli.conftest import assert_one_line_error


def _run(*args: str | Path) -> tuple[int, str]:
    result = CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)
    return result.exit_code, result.output


def test_simulate_writes_log_and_truth(tmp_path: Path) -> None:
    out = tmp_path / "office"
    code, output = _run(
        "simulate",
        "-o",
        out,
        "--days",
        "0.02",
        "--start",
        "2026-01-06T12:00",
        "--detection-type",
        "pose_array",
        "--tour-every",
        "10",
    )
    assert code == 0, output
    log = tmp_path / "office.mcap"  # the suffix of the format is added
    assert log.exists()
    meta = json.loads((tmp_path / "office.mcap.truth.json").read_text())
    assert meta["topics"]["/people_tracker/pose_array"] == "geometry_msgs/msg/PoseArray"
    assert meta["config"]["start"] == "2026-01-06T12:00"
    assert "wrote" in output
    assert "loop closures" in output
    # a second run refuses to overwrite, --force allows it
    code, output = _run("simulate", "-o", log, "--days", "0.01", "--quiet")
    assert code == 2
    assert "exists already" in output
    code, _ = _run("simulate", "-o", log, "--days", "0.01", "--quiet", "--force")
    assert code == 0


def test_a_scene_nobody_came_to_says_why_it_has_no_detection(tmp_path: Path) -> None:
    """Monday 00:00 to 00:14: the office routine brings nobody before 07:30, so the scene
    has no detection, and a warning says so and what to give instead; 12:00 has people."""
    code, output = _run("simulate", "-o", tmp_path / "night.mcap", "--days", "0.01", "--quiet")
    assert code == 0, output
    meta = json.loads((tmp_path / "night.mcap.truth.json").read_text())
    assert meta["detections"] == 0
    assert meta["true_samples"] == 0
    assert "warning: night.mcap: nobody was detected, and nobody came" in " ".join(output.split())
    assert "--start" in output
    code, output = _run(
        "simulate", "-o", tmp_path / "noon.mcap", "--days", "0.01", "--start", "2026-01-06T12:00",
        "--robot", "fixed", "--quiet",
    )
    assert code == 0, output
    assert json.loads((tmp_path / "noon.mcap.truth.json").read_text())["detections"] > 0
    assert "nobody was detected" not in output
    code, output = _run(  # nobody asked for: said so, not blamed on office hours
        "simulate", "-o", tmp_path / "none.mcap", "--days", "0.01", "--agents", "0", "--quiet"
    )
    assert code == 0, output
    assert "--agents 0 simulates no people" in " ".join(output.split())
    assert "office hours" not in output


def test_a_night_start_with_a_time_is_not_asked_for_a_time_of_day(tmp_path: Path) -> None:
    """A --start that has a time of day (Monday 01:30, before anyone comes) is asked for one
    within the office hours, on its own day: the warning asked for a time of day it had, on
    the default's day (2026-01-05T08:00)."""
    code, output = _run(
        "simulate", "-o", tmp_path / "late.mcap", "--days", "0.01", "--start",
        "2026-03-30T01:30", "--quiet",
    )
    assert code == 0, output
    said = " ".join(output.split())
    assert "nobody came" in said
    assert "give a --start within those hours (e.g. 2026-03-30T09:00) or more --days" in said
    assert "with a time of day" not in said
    code, output = _run(
        "simulate", "-o", tmp_path / "day.mcap", "--days", "0.01", "--start", "2026-03-30",
        "--quiet",
    )
    assert code == 0, output
    assert "give --start with a time of day (e.g. 2026-03-30T09:00)" in " ".join(output.split())
    # within the hours, a few minutes in which nobody walked: more --days, not another time
    code, output = _run(
        "simulate", "-o", tmp_path / "desk.mcap", "--days", "0.006", "--start",
        "2026-01-07T09:01", "--robot", "fixed", "--quiet",
    )
    assert code == 0, output
    meta = json.loads((tmp_path / "desk.mcap.truth.json").read_text())
    said = " ".join(output.split())
    assert meta["true_samples"] == 0  # seed 0's people sit through these minutes
    assert "nobody walked" in said
    assert "give more --days" in said
    assert "within those hours" not in said
    assert "nobody came" not in said
    code, output = _run(  # a Saturday: a weekday, not a time
        "simulate", "-o", tmp_path / "sat.mcap", "--days", "0.01", "--start",
        "2026-01-10T10:00", "--quiet",
    )
    said = " ".join(output.split())
    assert "a Saturday; give a weekday --start or more --days" in said


def test_an_output_named_as_another_file_kind_is_refused(tmp_path: Path) -> None:
    """-o apt.bag with the default --format mcap wrote apt.bag.mcap; a name with another
    log's or file's suffix is refused with the format or name to give; an unknown or no
    suffix still gets the format's."""
    for name, hint in (("apt.bag", "--format bag"), ("apt.png", "-o apt.mcap")):
        code, output = _run("simulate", "-o", tmp_path / name, "--days", "0.01", "--quiet")
        assert code == 2, output
        assert "--format mcap writes a .mcap log" in output
        assert hint in output
        assert not list(tmp_path.iterdir())
    code, output = _run("simulate", "-o", tmp_path / "apt.bag", "--format", "bag", "--days",
                        "0.01", "--quiet")
    assert code == 0, output
    assert (tmp_path / "apt.bag").is_file()
    code, output = _run("simulate", "-o", tmp_path / "plain", "--days", "0.01", "--quiet")
    assert code == 0, output
    assert (tmp_path / "plain.mcap").is_file()


@pytest.mark.parametrize(
    ("fmt", "name", "hint"),
    [("rosbag2", "apt.mcap", "--format mcap for a .mcap file, or -o apt for the folder"),
     ("rosbag2-sqlite3", "apt.db3", "-o apt for the folder")],
)
def test_a_rosbag2_folder_named_as_a_file_is_refused(
    tmp_path: Path, fmt: str, name: str, hint: str
) -> None:
    """--format rosbag2 -o apt.mcap wrote a folder apt.mcap holding apt.mcap.mcap (which
    every reader takes for an MCAP file by its name); refused as convert refuses a container
    that contradicts -o's suffix, with the format or the folder name to give."""
    code, output = _run("simulate", "-o", tmp_path / name, "--format", fmt, "--days", "0.01",
                        "--quiet")
    assert code == 2, output
    said = " ".join(output.split())
    assert f"error: --format {fmt} writes a rosbag2 folder, not -o {name}" in said
    assert hint in said
    assert not list(tmp_path.iterdir())


def test_several_scenes_are_refused_a_folder_named_as_a_log(tmp_path: Path) -> None:
    """--scenes 2 -o paper.mcap made a folder named paper.mcap holding the scenes' logs."""
    code, output = _run("simulate", "-o", tmp_path / "paper.mcap", "--scenes", "2", "--days",
                        "0.01", "--quiet")
    assert code == 2, output
    assert "-o names the folder of the scenes' logs, not a file: paper.mcap" in output
    assert "-o paper/" in output
    assert not list(tmp_path.iterdir())
    code, output = _run("simulate", "-o", tmp_path / "paper", "--scenes", "2", "--days",
                        "0.01", "--quiet")
    assert code == 0, output
    assert sorted(p.name for p in (tmp_path / "paper").glob("*.mcap")) == [
        "scene_00.mcap", "scene_01.mcap"
    ]


def test_simulate_input_errors_exit_2(tmp_path: Path) -> None:
    cases = [
        ("--robot", "fixed", "--frame", "base_link"),
        ("--detection-type", "sensor_msgs/Image"),
        ("--start", "monday"),
        ("--days", "0"),
        ("--environment", str(tmp_path / "missing.json")),
        ("--patrol-hours", "7to20"),
        ("--patrol-hours", "8-8"),  # an empty span: a robot that never tours, silently
        ("--patrol-hours", "24-0"),  # empty too (24 is 0): no tour started, silently
        ("--patrol-hours", "8.6-8.9"),  # 08:36-08:54 holds no start of the 30-min grid
        ("--days", "400"),
        ("--tz", "Mars/Olympus"),
        ("--tz", "Europe/London", "--utc-offset", "1"),
        # numbers out of any sense (each was an internal error or a log of NaN positions)
        ("--seed", "-1"),
        ("--agents", "99999999999999999999"),
        ("--rate", "1e-300"),
        ("--noise", "1e300"),
        ("--noise", "inf"),
        ("--tour-every", "1e-300"),
        ("--dsg-period", "inf"),
        ("--window", "1e-300"),
        ("--window", "inf"),
        ("--utc-offset", "nan"),
        ("--utc-offset", "25"),
        ("--scenes", "99999999999999999999"),
        ("--start", "2039-01-01"),  # beyond a ROS 2 stamp (int32 seconds): was internal
        ("--start", "2262-06-01"),  # beyond int64 nanoseconds
    ]
    for extra in cases:
        code, output = _run("simulate", "-o", tmp_path / "x.mcap", "--quiet", *extra)
        assert code == 2, (extra, output)
        assert "error:" in output
        assert "Traceback" not in output
    assert not (tmp_path / "x.mcap").exists()


def test_a_fixed_sensor_refuses_the_patrol_options_it_would_ignore(tmp_path: Path) -> None:
    """--robot fixed sees every person at every tick and never tours: --tour-every,
    --patrol-hours, --sensor-range, --no-line-of-sight and --dsg-period (scene graphs while the
    robot drives) were accepted and did nothing (a 'fixed sensor with an 8-10 h patrol' wrote
    the same log as one without). They are refused, each named; their default values, and the
    same options with --robot patrol, are fine."""
    log = tmp_path / "fixed.mcap"
    common = ("simulate", "-o", log, "--days", "0.02", "--start", "2026-01-05T12:00", "-q")
    code, output = _run(*common, "--robot", "fixed", "--tour-every", "10",
                        "--patrol-hours", "8-10")
    assert code == 2, output
    assert_one_line_error(output)
    said = " ".join(output.split())
    assert "--tour-every and --patrol-hours set the patrolling robot" in said, said
    assert "leave out --tour-every and --patrol-hours, or use --robot patrol" in said, said
    assert not log.exists()
    for extra in (("--sensor-range", "3"), ("--no-line-of-sight",), ("--dsg-period", "5")):
        code, output = _run(*common, "--robot", "fixed", *extra)
        assert code == 2, (extra, output)
        assert f"{extra[0]} sets the patrolling robot" in " ".join(output.split())
    code, output = _run(*common, "--robot", "fixed", "--sensor-range", "8",
                        "--patrol-hours", "0-24")  # the defaults, given: nothing ignored
    assert code == 0, output
    code, output = _run(*common, "--force", "--tour-every", "10", "--patrol-hours", "8-10",
                        "--sensor-range", "3", "--no-line-of-sight")
    assert code == 0, output


def test_the_empty_scene_hint_s_example_start_is_within_the_hours(tmp_path: Path) -> None:
    """People arrive about 08:30: a Monday 06:00 start for a quarter of an hour was told
    "give a --start within those hours (e.g. 2026-01-05T08:00)", half an hour before they
    do. The example is 09:00 now, and a scene started there is not one nobody came to."""
    common = ("--days", "0.01", "--robot", "fixed", "--quiet", "--force")
    code, output = _run("simulate", "-o", tmp_path / "s.mcap", "--start", "2026-01-05T06:00",
                        *common)  # fmt: skip
    assert code == 0, output
    said = " ".join(output.split())
    assert "nobody came" in said
    assert "give a --start within those hours (e.g. 2026-01-05T09:00)" in said, said
    code, output = _run("simulate", "-o", tmp_path / "s.mcap", "--start", "2026-01-05T09:00",
                        *common)  # fmt: skip
    assert code == 0, output
    assert "nobody came" not in " ".join(output.split())


def test_the_empty_scene_warning_reads_start_as_simulate_does(tmp_path: Path) -> None:
    """--start in any ISO form simulate accepts (a space before the time, the basic form) is
    read for the warning as the scene reads it: a night start on a Wednesday is asked for a
    time within the hours on its own day (it was taken for a Monday without a time of day:
    'e.g. 2026-01-07 01:30T08:00')."""
    for start in ("2026-01-07 01:30", "20260107T0130"):
        code, output = _run(
            "simulate", "-o", tmp_path / "night.mcap", "--days", "0.01", "--start", start,
            "--quiet", "--force",
        )
        assert code == 0, output
        said = " ".join(output.split())
        assert "give a --start within those hours (e.g. 2026-01-07T09:00)" in said, said


def test_the_truth_records_one_zone_the_clock_followed(tmp_path: Path) -> None:
    """The truth's config carried ``utc_offset_h`` beside ``timezone``: 0.0 beside
    ``Asia/Tokyo`` (+9 h) and beside ``Europe/London`` (+1 h in summer). It records one
    zone, the one the clock followed, as ``aion build --tz`` takes it."""
    cases = (
        (("--tz", "Asia/Tokyo"), "Asia/Tokyo"),
        (("--tz", "Europe/London"), "Europe/London"),
        (("--utc-offset", "5.5"), "UTC+05:30"),
        ((), "UTC"),
    )
    for n, (zone_args, zone) in enumerate(cases):
        log = tmp_path / f"z{n}.mcap"
        code, output = _run("simulate", "-o", log, "--days", "0.01", "--start",
                             "2026-07-06T12:00", "-q", *zone_args)  # fmt: skip
        assert code == 0, output
        config = json.loads((tmp_path / f"z{n}.mcap.truth.json").read_text())["config"]
        assert config["timezone"] == zone
        assert "utc_offset_h" not in config


def test_tz_local_is_the_machines_zone_by_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--tz local`` names the machine's zone, as ``build --tz local`` stores it; it was
    refused as an unknown zone 'local'."""
    from aion_cli import time_zones

    monkeypatch.delenv("TZ", raising=False)
    monkeypatch.setattr(time_zones, "_zone_name_from_system", lambda: "Asia/Tokyo")
    log = tmp_path / "local.mcap"
    code, output = _run("simulate", "-o", log, "--days", "0.01", "--start", "2026-07-06T12:00",
                        "-q", "--tz", "local")  # fmt: skip
    assert code == 0, output
    config = json.loads((tmp_path / "local.mcap.truth.json").read_text())["config"]
    assert config["timezone"] == "Asia/Tokyo"


def test_a_parked_robots_tf_gap_aion_would_not_bridge_is_refused(tmp_path: Path) -> None:
    """``aion build`` takes a gap over 10 s between TF samples as time the pose was unknown
    (tf2's cache length): a patrol robot whose parked heartbeat is 30 s apart, or 13.3 s
    (10 s in whole ticks of 0.15 Hz), would observe nothing while parked, so the log would
    disagree with its own truth; the default (10 s at 2 Hz) and a fixed sensor (no TF) are
    written."""
    for extra, every in (
        (("--tf-idle-period", "30"), "every 30 s"),
        (("--rate", "0.15"), "every 13.3333 s"),
    ):
        code, output = _run("simulate", "-o", tmp_path / "x.mcap", "--quiet", "--days", "0.01",
                            *extra)  # fmt: skip
        assert code == 2, (extra, output)
        assert_one_line_error(output, every, "--tf-idle-period")
    for extra in ((), ("--robot", "fixed", "--tf-idle-period", "30")):
        log = tmp_path / f"ok{len(extra)}.mcap"
        code, output = _run("simulate", "-o", log, "--quiet", "--days", "0.01", *extra)
        assert code == 0, (extra, output)


@pytest.mark.parametrize("value", ["", "  "])
def test_an_empty_environment_says_so(tmp_path: Path, value: str) -> None:
    """``--environment "$DSG"`` with the variable unset said 'scene-graph file not found: .'
    (the current folder), which names no file the user gave."""
    result = CliRunner().invoke(
        cli, ["simulate", "-o", str(tmp_path / "x.mcap"), "--environment", value]
    )
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "--environment is empty (an unset shell variable?)")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("seed", ["-1", "9223372036854775808", "99999999999999999999"])
def test_a_seed_out_of_range_names_the_range(tmp_path: Path, seed: str) -> None:
    """A seed too large was told it 'must be a whole number from 0', which it is."""
    result = CliRunner().invoke(cli, ["simulate", "-o", str(tmp_path / "x.mcap"), "--seed", seed])
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, f"--seed must be a whole number 0 .. {2**63 - 1}")


def test_spaces_around_start_are_no_part_of_the_time() -> None:
    """--start " 2026-01-05T09:00 " (a quoted shell variable) is read as the time it holds,
    as --time is; before, Python's "Invalid isoformat string" text was the answer."""
    import datetime as dt

    from aion_cli.sim.scenario import parse_start

    assert parse_start(" 2026-01-05T09:00 ") == (dt.date(2026, 1, 5), 9 * 3600.0)
    assert parse_start("2026-01-05  09:30") == (dt.date(2026, 1, 5), 9.5 * 3600.0)


def test_event_counts_speak_of_one_as_one(tmp_path: Path) -> None:
    """simulate's summary said '1 loop closures (1 moves, 1 merges, 0 removals)'."""
    from aion_cli.cli.simulate import _event_counts
    from aion_cli.sim.scenario import SceneResult

    truth = tmp_path / "t.json"
    truth.write_text(json.dumps(
        {"loop_closures": 1, "event_counts": {"move": 1, "merge": 1, "remove": 2000}}
    ))
    said = _event_counts(SceneResult(tmp_path / "l.mcap", tmp_path / "t.npz", truth, {}))
    assert said == "1 loop closure (1 move, 1 merge, 2,000 removals)"
