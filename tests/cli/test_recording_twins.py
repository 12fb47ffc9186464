"""One recording in two log files is refused in every route, told from the samples of
detections the maps' manifests keep (``recordings``, :mod:`aion_cli.recording_twins`).

Before, a log converted again by ``aion convert`` (another container, other ``--observed``
spans) or cut at another start has another sha256, and the merge compared whole maps' entry
checksums: a copy inside a larger merged map, or one observed over other spans, was merged
(every person counted twice), and ``aion build --map`` of the copy was refused only as out of
time order, with a hint to rebuild from all logs (the copy among them). Two robots at the
same hours and one place on other days must still merge."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats.mapfile import read_manifest
from tests.cli.atc_sessions import convert_atc
from tests.cli.conftest import assert_one_line_error, run, run_json


def _rows(path: Path, day: int, seed: int, minutes: range = range(20)) -> Path:
    """ATC rows on 2026-11-``day`` from 08:00 UTC: a person a minute (of ``minutes``)
    walking for 30 s from 5 s past it, from a start and with a speed of their own
    (``seed``), 0.1 s apart."""
    rng = np.random.default_rng(seed)
    t0 = datetime(2026, 11, day, 8, 0, tzinfo=UTC).timestamp()
    rows = []
    for minute in range(20):
        x0, y0 = rng.uniform(-10, 10, 2)
        vx = rng.uniform(0.5, 1.5)
        if minute not in minutes:
            continue
        for i in range(0, 300, 3):
            t = t0 + minute * 60 + 5 + i / 10
            rows.append(f"{t:.3f},{minute + 100 * seed},{x0 + vx * i / 10:.3f},{y0:.3f},1.0,0.0")
    path.write_text("\n".join(rows) + "\n")
    return path


def _map(tmp: Path, csv: Path, log: str, *convert: str) -> Path:
    """``csv`` converted into ``log`` (``convert``: more options) and built into a map."""
    convert_atc(csv, tmp / log, *convert)
    out = tmp / f"{log.replace('.', '_')}.aion"
    run_json("build", tmp / log, "-o", out, "--format", "json")
    return out


@pytest.fixture(scope="module")
def maps(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Maps of day 23 (``a.mcap``), of day 25 (``c.mcap``), both merged (``m.aion``), and
    of day 23 again: converted to a ROS 1 bag (``a.bag``), with other spans observed, and
    cut to start 5 minutes later."""
    tmp = tmp_path_factory.mktemp("twins")
    day23, day25 = _rows(tmp / "23.csv", 23, 1), _rows(tmp / "25.csv", 25, 2)
    out = {
        "a": _map(tmp, day23, "a.mcap"),
        "c": _map(tmp, day25, "c.mcap"),
        "bag": _map(tmp, day23, "a.bag"),
        "observed": _map(
            tmp, day23, "obs.mcap", "--observed", "2026-11-23 07:30..2026-11-23 09:00"
        ),
        "cut": _map(tmp, _rows(tmp / "cut.csv", 23, 1, range(5, 20)), "cut.mcap"),
    }
    out["m"] = tmp / "m.aion"
    assert run("merge", out["a"], out["c"], "-o", out["m"], "-q").exit_code == 0
    return out


def test_a_converted_copy_of_a_log_inside_a_merged_map_is_refused_by_the_merge(
    maps: dict[str, Path], tmp_path: Path
) -> None:
    out = tmp_path / "out.aion"
    done = run("merge", maps["m"], maps["bag"], "-o", out)
    assert done.exit_code == 2, done.stderr
    assert_one_line_error(
        done.stderr,
        "m.aion (a.mcap) and a_bag.aion (a.bag) hold the same detections",
        "one recording in two log files",
    )
    assert "hint: merge without a_bag.aion, or rebuild it without a.bag" in done.stderr
    assert not out.exists()


@pytest.mark.parametrize("copy", ["observed", "cut"])
def test_a_copy_observed_otherwise_or_cut_later_is_refused_by_the_merge(
    maps: dict[str, Path], tmp_path: Path, copy: str
) -> None:
    """The maps' entries differ (other windows observed, fewer people), so the check of
    equal members let them through; their detections over their common time are the same."""
    done = run("merge", maps["a"], maps[copy], "-o", tmp_path / "out.aion")
    assert done.exit_code == 2, done.stderr
    named = {  # in time order: the spans observed start at 07:30
        "observed": "obs_mcap.aion (obs.mcap) and a_mcap.aion (a.mcap)",
        "cut": "a_mcap.aion (a.mcap) and cut_mcap.aion (cut.mcap)",
    }[copy]
    assert_one_line_error(done.stderr, f"{named} hold the same detections")


@pytest.mark.parametrize("workers", ["1", "0"])
def test_a_converted_copy_is_refused_when_built_onto_a_merged_map(
    maps: dict[str, Path], tmp_path: Path, workers: str
) -> None:
    """a.bag's detections lie in windows m.aion has closed: before, the refusal said to
    rebuild the map from all its logs and a.bag at once, which would count them twice. In
    this process (the stream's first batch) and with the default workers (the fold)."""
    out = tmp_path / "out.aion"
    log = maps["bag"].parent / "a.bag"
    done = run("build", log, "--map", maps["m"], "-o", out, "-q", "--workers", workers)
    assert done.exit_code == 2, done.stderr
    assert_one_line_error(done.stderr, "a.bag and a.mcap (in m.aion) hold the same detections",
                          "nothing was added")
    assert "hint: leave a.bag out: m.aion holds its recording already" in done.stderr
    assert "time order" not in done.stderr
    assert not out.exists()


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_cut_copy_of_a_maps_last_minutes_is_refused_when_built_onto_it(
    tmp_path: Path, workers: str
) -> None:
    """The copy's detections all lie in the map's open window (08:10-08:20), which takes
    data: the build went through and the map held minutes 12-19 twice."""
    whole = _rows(tmp_path / "whole.csv", 23, 3)
    built = _map(tmp_path, whole, "whole.mcap")
    before = read_manifest(built)
    convert_atc(_rows(tmp_path / "tail.csv", 23, 3, range(12, 20)), tmp_path / "tail.bag")
    done = run("build", tmp_path / "tail.bag", "--map", built, "-q", "--workers", workers)
    assert done.exit_code == 2, done.stderr
    assert_one_line_error(done.stderr, "tail.bag and whole.mcap (in whole_mcap.aion) hold the "
                          "same detections")
    assert read_manifest(built) == before  # nothing written


def test_two_robots_at_the_same_hours_and_a_place_on_other_days_are_accepted(
    maps: dict[str, Path], tmp_path: Path
) -> None:
    """Other people at the same hours (robot 2 on day 23), and the same walks (seed 1) on
    day 25: nothing alike; they merge, are continued, and are built together without the
    warning of logs holding the same detections."""
    other = _map(tmp_path, _rows(tmp_path / "r2.csv", 23, 7), "r2.mcap")
    merged = tmp_path / "fleet.aion"
    done = run("merge", maps["m"], other, "-o", merged, "-q")
    assert done.exit_code == 0, done.stderr
    used = [read_manifest(p)["counts"]["used"] for p in (maps["m"], other, merged)]
    assert used[2] == used[0] + used[1] > 0
    assert len(read_manifest(merged)["recordings"]) == 3
    # the same walks two days later, continued onto day 23's map
    later = tmp_path / "later.mcap"
    convert_atc(_rows(tmp_path / "l.csv", 25, 1), later)
    step = tmp_path / "step.aion"
    run_json("build", maps["a"].parent / "a.mcap", "-o", step, "--format", "json")
    report = run_json("build", later, "--map", step, "--format", "json")
    assert report["detections"]["used"] == read_manifest(maps["a"])["counts"]["used"]
    both = run_json("build", maps["a"].parent / "a.mcap", tmp_path / "r2.mcap", "-o",
                    tmp_path / "both.aion", "--format", "json")
    assert not any("same detections" in w for w in both["warnings"])


def test_the_sample_is_the_same_whatever_the_workers(tmp_path: Path) -> None:
    """A build in two worker processes samples what one pass does: the shards' samples
    joined are the sample of all the detections."""
    logs = []
    for day, seed in ((23, 4), (25, 5)):
        logs.append(tmp_path / f"{day}.mcap")
        convert_atc(_rows(tmp_path / f"{day}.csv", day, seed), logs[-1])
    entries = []
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}.aion"
        run_json("build", *logs, "-o", out, "--workers", workers, "--format", "json")
        entries.append(read_manifest(out)["recordings"])
    assert entries[0] == entries[1]
    assert [log["name"] for log in entries[0][0]["logs"]] == ["23.mcap", "25.mcap"]
    assert entries[0][0]["detections"] == read_manifest(tmp_path / "w1.aion")["counts"]["used"]
