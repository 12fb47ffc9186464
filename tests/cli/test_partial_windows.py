"""A log that starts or ends inside a window observed only the part of it it recorded.

The office log without TF is a fixed sensor; shifted by 6 minutes it records 08:06-08:26,
so its three windows hold 4, 10 and 6 minutes of recording. Track 1 is detected every 10 s
at p1: 60 per full window. The map must say 60 (120 detections in two windows' worth of
recording), where whole windows said 40; the same log cut in two inside a window must give
the same map built at once, continued with ``--map`` or in parallel shards; and judged on
itself, the static forecast's activity must add up to the detections the log holds.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.cli.conftest import run, run_json
from tests.cli.logdata import write_office_log


def _flows(map_path: Path, *extra: str) -> dict[str, float]:
    out = run_json("predict", map_path, *extra, "--format", "json")
    return {e["id"]: e["flow"] for e in out["entries"]}


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    root = tmp_path_factory.mktemp("partial")
    whole = root / "shifted.mcap"
    expected = write_office_log(whole, tf=False, shift_s=360)
    first, second = root / "first.mcap", root / "second.mcap"
    write_office_log(first, tf=False, shift_s=360, duration_s=600)  # 08:06-08:16
    write_office_log(second, tf=False, shift_s=960, duration_s=600)  # 08:16-08:26
    return {"root": root, "whole": whole, "first": first, "second": second,
            "expected": expected}


def test_windows_recorded_in_part_give_the_true_rate(logs: dict[str, Any]) -> None:
    root = logs["root"]
    built = root / "shifted.aion"
    assert run("build", logs["whole"], "-o", built, "-q").exit_code == 0
    assert _flows(built, "--historical")["p1"] == pytest.approx(60.0)
    # the paper's whole windows: 120 detections over three windows
    config = root / "whole.toml"
    config.write_text("exposure = false\n")
    paper = root / "paper.aion"
    assert run("build", logs["whole"], "-o", paper, "-q", "--config", config).exit_code == 0
    assert _flows(paper, "--historical")["p1"] == pytest.approx(40.0)


def test_each_log_has_its_own_edges_and_a_pause_inside_one_does_not(tmp_path: Path) -> None:
    """The same 20 minutes again a day later: as two logs, each starts and ends inside a
    window (0.4, 1 and 0.6 of them: 240 detections in 4 windows' worth); as one log with a
    day's pause, only its own start and end cut a window (a tracker that publishes only when
    it sees someone stops at the last person, not when recording stops): 240 in 0.4 + 1 + 1 +
    1 + 1 + 0.6 = 5 windows."""
    first, second = tmp_path / "day1.mcap", tmp_path / "day2.mcap"
    write_office_log(first, tf=False, shift_s=360)
    write_office_log(second, tf=False, shift_s=360 + 86_400)
    two = tmp_path / "two.aion"
    assert run("build", first, second, "-o", two, "-q").exit_code == 0
    assert _flows(two, "--historical")["p1"] == pytest.approx(60.0)
    paused = tmp_path / "paused.mcap"
    write_office_log(paused, tf=False, shift_s=360, later_sessions_s=(86_400,))
    one = tmp_path / "one.aion"
    assert run("build", paused, "-o", one, "-q").exit_code == 0
    assert _flows(one, "--historical")["p1"] == pytest.approx(48.0)


def test_a_log_cut_inside_a_window_builds_the_same_map_every_way(
    logs: dict[str, Any],
) -> None:
    root = logs["root"]
    at_once, first, continued, parallel = (
        root / f"{name}.aion" for name in ("at_once", "first", "continued", "parallel")
    )
    assert run("build", logs["first"], logs["second"], "-o", at_once, "-q").exit_code == 0
    assert run("build", logs["first"], "-o", first, "-q").exit_code == 0
    assert run("build", logs["second"], "--map", first, "-o", continued, "-q").exit_code == 0
    assert run(
        "build", logs["first"], logs["second"], "-o", parallel, "-q", "--workers", "2"
    ).exit_code == 0
    # the first log alone ends 08:16: its second window is 6 minutes of recording
    assert _flows(first, "--historical")["p1"] == pytest.approx(60.0)
    # the two logs meet at 08:16: the window they share is recorded whole
    want = _flows(at_once, "--historical")
    assert want["p1"] == pytest.approx(60.0)
    for other in (continued, parallel):
        assert _flows(other, "--historical") == want
        for time in ("2026-11-23T08:15", "2026-11-24T03:00"):
            assert _flows(other, "--time", time) == _flows(at_once, "--time", time)


def test_judged_on_itself_the_static_activity_adds_up_to_its_detections(
    logs: dict[str, Any],
) -> None:
    root = logs["root"]
    built = root / "self.aion"
    assert run("build", logs["whole"], "-o", built, "-q").exit_code == 0
    out = run_json("evaluate", "holdout", built, logs["whole"], "--format", "json", "-q")
    series = out["hourly_series"]
    detections = logs["expected"].detections
    assert sum(series["truth"]) == detections
    # each place's rate times the share of each window recorded: exactly what was seen
    assert sum(series["aion static"]) == pytest.approx(detections)


def test_a_gap_between_two_logs_inside_a_window_is_not_recorded_every_way(
    tmp_path: Path,
) -> None:
    """One log records 08:06-08:14, the next 08:16-08:26: window 08:10 holds 4 + 4 minutes
    of recording, so 48 + 60 detections at p1 are 1.8 windows' worth (60 a window), built at
    once, in parallel or continued (at once the build's messages, one run of windows from
    08:06 to 08:26, had filled the gap: 54)."""
    first, second = tmp_path / "first.mcap", tmp_path / "second.mcap"
    write_office_log(first, tf=False, shift_s=360, duration_s=480)
    write_office_log(second, tf=False, shift_s=960, duration_s=600)
    at_once, parallel, alone, continued = (
        tmp_path / f"{name}.aion" for name in ("at_once", "parallel", "alone", "continued")
    )
    assert run("build", first, second, "-o", at_once, "-q").exit_code == 0
    assert run(
        "build", first, second, "-o", parallel, "-q", "--workers", "2"
    ).exit_code == 0
    assert run("build", first, "-o", alone, "-q").exit_code == 0
    assert run("build", second, "--map", alone, "-o", continued, "-q").exit_code == 0
    want = _flows(continued, "--historical")
    assert want["p1"] == pytest.approx(60.0)
    for other in (at_once, parallel):
        assert _flows(other, "--historical") == want


def test_logs_in_neighbouring_windows_keep_their_own_edges_every_way(tmp_path: Path) -> None:
    """One log records 08:06-08:14, the next 08:21-08:26 (no window shared: a parallel build
    gives each its own group): 48 + 30 detections at p1 in 0.4 + 0.4 + 0.1 + 0.5 = 1.3
    windows' worth, 60 a window, built at once too (the build's messages, one run of windows
    from 08:06 to 08:26, had read as 2 windows: 39)."""
    first, second = tmp_path / "first.mcap", tmp_path / "second.mcap"
    write_office_log(first, tf=False, shift_s=360, duration_s=480)
    write_office_log(second, tf=False, shift_s=1260, duration_s=300)
    at_once, parallel = tmp_path / "at_once.aion", tmp_path / "parallel.aion"
    assert run("build", first, second, "-o", at_once, "-q", "--workers", "1").exit_code == 0
    assert run(
        "build", first, second, "-o", parallel, "-q", "--workers", "2"
    ).exit_code == 0
    want = _flows(parallel, "--historical")
    assert want["p1"] == pytest.approx(60.0)
    assert _flows(at_once, "--historical") == want


def test_the_storage_files_of_one_rosbag2_bag_are_one_recording(tmp_path: Path) -> None:
    """A recorder that splits its bag by duration keeps recording between the last message of
    one storage file and the first of the next: a tracker publishing only when it sees
    someone leaves that time without a message, yet nobody was there. The same two files
    08:06-08:14 and 08:16-08:26 read as two logs record 1.8 windows (60 a window at p1); as
    one bag, 08:06-08:26, two whole windows: 108 detections, 54 a window (as two logs the bag
    read 60: the two minutes nobody passed were left out)."""
    from ruamel.yaml import YAML

    from aion_cli.formats.rosbag2_reindex import reindex

    bag = tmp_path / "bag"
    bag.mkdir()
    first, second = bag / "bag_0.mcap", bag / "bag_1.mcap"
    write_office_log(first, tf=False, shift_s=360, duration_s=480)
    write_office_log(second, tf=False, shift_s=960, duration_s=600)
    two_logs, reindexed, with_metadata = (
        tmp_path / f"{name}.aion" for name in ("two", "reindexed", "metadata")
    )
    assert run("build", first, second, "-o", two_logs, "-q").exit_code == 0
    assert _flows(two_logs, "--historical")["p1"] == pytest.approx(60.0)
    assert run("build", bag, "-o", reindexed, "-q").exit_code == 0
    assert _flows(reindexed, "--historical")["p1"] == pytest.approx(54.0)
    with (bag / "metadata.yaml").open("w") as f:
        YAML(typ="safe").dump({"rosbag2_bagfile_information": reindex(bag)}, f)
    assert run("build", bag, "-o", with_metadata, "-q").exit_code == 0
    assert _flows(with_metadata, "--historical")["p1"] == pytest.approx(54.0)
    # in parallel, the bag is one group's: the same
    parallel = tmp_path / "parallel.aion"
    assert run("build", bag, "-o", parallel, "-q", "--workers", "2").exit_code == 0
    assert _flows(parallel, "--historical") == _flows(with_metadata, "--historical")


def _split_bag(bag: Path) -> tuple[Path, Path, Path]:
    """The bag of the test above, with its metadata.yaml: 08:06-08:14 and 08:16-08:26."""
    from ruamel.yaml import YAML

    from aion_cli.formats.rosbag2_reindex import reindex

    bag.mkdir()
    first, second = bag / "bag_0.mcap", bag / "bag_1.mcap"
    write_office_log(first, tf=False, shift_s=360, duration_s=480)
    write_office_log(second, tf=False, shift_s=960, duration_s=600)
    metadata = bag / "metadata.yaml"
    with metadata.open("w") as f:
        YAML(typ="safe").dump({"rosbag2_bagfile_information": reindex(bag)}, f)
    return first, second, metadata


def test_a_bag_given_as_its_files_and_its_metadata_is_one_recording(tmp_path: Path) -> None:
    """``aion build bag/*`` names the bag's storage files and its metadata.yaml, which opens
    the whole bag: the bag is read once, as the one recording ``aion build bag`` reads (54 a
    window at p1), whichever comes first and in one pass or in parallel."""
    first, second, metadata = _split_bag(tmp_path / "bag")
    for name, args in {
        "glob": (first, second, metadata, "--workers", "1"),
        "metadata_first": (metadata, first, second, "--workers", "1"),
        "glob_parallel": (first, second, metadata, "--workers", "2"),
    }.items():
        out = tmp_path / f"{name}.aion"
        result = run("build", *args, "-o", out, "-q")
        assert result.exit_code == 0, result.stderr
        assert _flows(out, "--historical")["p1"] == pytest.approx(54.0), name


def test_a_split_bag_beside_another_log_builds_the_same_map_in_parallel(
    tmp_path: Path,
) -> None:
    """The bag (108 detections at p1 over its two whole windows) and the office log a day
    later (120 over 0.4 + 1 + 0.6 windows): 228 in 4 windows, 57 a window, in one pass and in
    parallel shards, where the bag is one path of several storage files."""
    _split_bag(tmp_path / "bag")
    other = tmp_path / "next_day.mcap"
    write_office_log(other, tf=False, shift_s=360 + 86_400)
    at_once, parallel = tmp_path / "at_once.aion", tmp_path / "parallel.aion"
    result = run("build", tmp_path / "bag", other, "-o", at_once, "-q", "--workers", "1")
    assert result.exit_code == 0, result.stderr
    assert _flows(at_once, "--historical")["p1"] == pytest.approx(57.0)
    result = run("build", tmp_path / "bag", other, "-o", parallel, "-q", "--workers", "2")
    assert result.exit_code == 0, result.stderr
    assert _flows(parallel, "--historical") == _flows(at_once, "--historical")
