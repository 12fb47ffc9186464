"""``aion merge`` from real logs: the office log (tests/cli/logdata.py) on two days, built by
``aion build`` into two maps and merged; compared with ``aion build`` of both logs, with a
graph of another session (the same ids at other places), and every bad input."""

from __future__ import annotations

import hashlib
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.compare import pending_sorted, plain
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.state import MapState
from aion_cli.formats.mapfile import read_manifest
from aion_cli.mapquery import load_map
from tests.cli.conftest import assert_one_line_error, run, run_json, run_process
from tests.cli.logdata import EDGES, PLACES, save_graph_file, sym, write_office_log

DAY_S = 86_400


@dataclass(frozen=True)
class Days:
    """The office log on Monday and on Wednesday, their maps, and one map of both."""

    logs: tuple[Path, Path]
    maps: tuple[Path, Path]
    both: Path
    per_track: dict[int, int]
    folder: Path


@pytest.fixture(scope="module")
def days(tmp_path_factory: pytest.TempPathFactory) -> Days:
    folder = tmp_path_factory.mktemp("days")
    mon, wed = folder / "monday.mcap", folder / "wednesday.mcap"
    expected = write_office_log(mon)
    write_office_log(wed, shift_s=2 * DAY_S)
    for log in (mon, wed):
        assert run("build", log, "-o", log.with_suffix(".aion"), "-q").exit_code == 0
    both = folder / "both.aion"
    assert run("build", mon, wed, "-o", both, "-q").exit_code == 0
    return Days(
        (mon, wed),
        (mon.with_suffix(".aion"), wed.with_suffix(".aion")),
        both,
        expected.per_track,
        folder,
    )


def _state(path: Path) -> MapState:
    return load_map(path, writable=True).state


def _node_counts(path: Path) -> dict[int, float]:
    """Detections per place (by office index) of a map, for the places holding any (the
    places the robot watched empty have entries too, with none)."""
    state = _state(path)
    rows = state.entries.node_rows()
    index = {sym("p", i): i for i in PLACES}
    held = {
        index[int(node)]: float(state.entries.counts[r].sum() + state.entries.nodir[r])
        for node, r in zip(state.entries.node_id[rows], rows, strict=True)
    }
    return {place: n for place, n in held.items() if n > 0}


def test_merging_the_two_days_equals_building_from_both_logs(days: Days, tmp_path: Path) -> None:
    """merge(map(Mon), map(Wed)) == build(Mon, Wed), every member (ints exactly, floats to
    rtol 1e-12). The documented exactness conditions of engine.merge.merge_maps hold: the
    logs are disjoint, on different days; they carry the same scene graph (one session) and
    each sees the same three people at the same places from its first window on, with the
    robot at the same spot, so no entry is in one map only; Wednesday's day is still pending,
    so only Monday's day is closed (against the same empty history in both)."""
    out = tmp_path / "merged.aion"
    summary = run_json("merge", days.maps[1], days.maps[0], "-o", out, "--format", "json")
    assert summary["lineage"] == "same"
    assert summary["lineage_reason"] == "7 of 7 shared node ids lie within 1 m"
    assert summary["detections"] == 2 * sum(days.per_track.values())
    assert [i["name"] for i in summary["inputs"]] == ["monday.aion", "wednesday.aion"]
    assert summary["notes"] == []
    xa, ma = _state(days.both).to_arrays()
    xm, mm = _state(out).to_arrays()
    assert mm == ma
    pa, pm = pending_sorted(plain(xa)), pending_sorted(plain(xm))
    assert sorted(pa) == sorted(pm)
    for name in pa:
        if pa[name].dtype.kind in "fc":
            np.testing.assert_allclose(pm[name], pa[name], rtol=1e-12, atol=0, err_msg=name)
        else:
            np.testing.assert_array_equal(pm[name], pa[name], err_msg=name)
    # the manifest lists both logs, with the sha256 of their bytes, and the maps merged
    doc = read_manifest(out)
    sha = {log.name: hashlib.sha256(log.read_bytes()).hexdigest() for log in days.logs}
    assert [(i["name"], i["sha256"]) for i in doc["inputs"]] == list(sha.items())
    assert [m["name"] for m in doc["merged_from"]] == ["monday.aion", "wednesday.aion"]
    assert doc["merged_from"][0]["sha256"] == hashlib.sha256(days.maps[0].read_bytes()).hexdigest()
    both = read_manifest(days.both)
    assert doc["time_span"] == both["time_span"]
    assert doc["counts"] == both["counts"]
    assert doc["families"] == both["families"]
    # and the merged map answers like the built one
    predicted = run_json("predict", out, "--time", "2026-11-30 08:05", "--format", "json")
    expected = run_json("predict", days.both, "--time", "2026-11-30 08:05", "--format", "json")
    assert predicted["entries"] == expected["entries"]


def test_a_target_graph_away_from_the_maps_is_named(days: Days, tmp_path: Path) -> None:
    """``--graph`` of another site (other place ids, 500 m away): the maps' places release
    to hash cells and none binds, and the merge warns, as aion build does of the same map,
    asking whether the maps and the graph share a frame (it was a note, which -q silenced);
    the office graph itself says nothing."""
    moved = {k + 100: (x + 500.0, y, z) for k, (x, y, z) in PLACES.items()}
    far = save_graph_file(
        tmp_path / "moved.json", moved, [(a + 100, b + 100) for a, b in EDGES]
    )
    out = tmp_path / "far.aion"
    summary = run_json("merge", *days.maps, "-o", out, "--graph", far, "--format", "json")
    assert [n for n in summary["warnings"] if "away from every place of the scene graph" in n]
    assert not [n for n in summary["notes"] if "away from every place" in n]
    quiet = run("merge", *days.maps, "-o", out, "--graph", far, "-q")
    assert quiet.exit_code == 0, quiet.stderr
    assert quiet.stderr.startswith("warning: ")
    assert "away from every place of the scene graph" in quiet.stderr
    here = save_graph_file(tmp_path / "here.json", PLACES, EDGES)
    out = tmp_path / "here.aion"
    summary = run_json("merge", *days.maps, "-o", out, "--graph", here, "--format", "json")
    assert not [n for n in summary["warnings"] if "away from every place" in n]


def test_the_target_graph_files_notes_are_printed_as_builds_are(
    days: Days, tmp_path: Path
) -> None:
    """``merge --graph`` of a JSON graph named ``.sparkdsg`` says that it was read as JSON,
    as ``build --graph`` does (the merge kept the snapshot and dropped the read's notes)."""
    json_graph = save_graph_file(tmp_path / "office.json", PLACES, EDGES)
    renamed = json_graph.rename(tmp_path / "office.sparkdsg")
    out = tmp_path / "renamed.aion"
    summary = run_json("merge", *days.maps, "-o", out, "--graph", renamed, "--format", "json")
    assert [n for n in summary["notes"] if "office.sparkdsg holds a JSON graph" in n]


def test_a_target_graph_of_another_session_makes_the_merge_different(
    days: Days, tmp_path: Path
) -> None:
    """``--graph`` holding the maps' place ids p0..p6, but 500 m away (another session
    numbers its places from p0 again): --lineage auto releases the maps' places to hash
    cells instead of moving their flows 500 m with the ids; nothing binds so far away. The
    office graph itself keeps the lineage "same" and the flows on their places."""
    moved = save_graph_file(
        tmp_path / "moved.json", {k: (x + 500.0, y, z) for k, (x, y, z) in PLACES.items()}, EDGES
    )
    out = tmp_path / "moved.aion"
    summary = run_json("merge", *days.maps, "-o", out, "--graph", moved, "--format", "json")
    assert summary["lineage"] == "different"
    assert "the target graph moved.json hold, 0 lie within" in summary["lineage_reason"]
    assert _node_counts(out) == {}  # every detection on the hash cells where people walked
    assert summary["cells"] > 0
    here = save_graph_file(tmp_path / "office.json", PLACES, EDGES)
    out = tmp_path / "office.aion"
    summary = run_json("merge", *days.maps, "-o", out, "--graph", here, "--format", "json")
    assert summary["lineage"] == "same"
    assert _node_counts(out) == _node_counts(days.both)


def test_maps_of_another_session_are_released_and_rebound(days: Days, tmp_path: Path) -> None:
    """Wednesday's map is built with a graph of another session: the same ids p0..p6 at other
    places (p0 where Monday's p1 is, p2 where Monday's p4 is ...). The merged map's places
    are Wednesday's, each holding the people near it on both days (known answer)."""
    perm = {0: 1, 1: 0, 2: 4, 3: 3, 4: 2, 5: 6, 6: 5}  # Wednesday's p_i is at Monday's p_perm[i]
    graph = save_graph_file(tmp_path / "other.json", {i: PLACES[perm[i]] for i in PLACES}, EDGES)
    other = tmp_path / "wednesday-other.aion"
    assert run("build", days.logs[1], "--graph", graph, "-o", other, "-q").exit_code == 0
    n1, n2, n3 = (days.per_track[k] for k in (1, 2, 3))
    assert _node_counts(other) == {0: n1, 2: n2, 3: n3}  # track 1 at p0, track 2 at p2 now
    out = tmp_path / "merged.aion"
    summary = run_json("merge", days.maps[0], other, "-o", out, "--format", "json")
    assert summary["lineage"] == "different"
    assert (
        "of the 7 node ids both monday.aion and wednesday-other.aion hold, 1 lie"
        in (summary["lineage_reason"])
    )
    assert summary["released_nodes"] == 10  # the five places the robot watched, in each map
    assert _node_counts(out) == {0: 2 * n1, 2: 2 * n2, 3: 2 * n3}
    # the table names the lineage and the release
    result = run("merge", days.maps[0], other, "-o", tmp_path / "again.aion")
    assert result.exit_code == 0
    assert "different" in result.stderr
    assert "released" in result.stderr
    # forced to add by id, Monday's people would sit at the wrong places
    run_json("merge", days.maps[0], other, "-o", out, "--lineage", "same", "--format", "json")
    wrong = _node_counts(out)
    assert wrong[0] == n1
    assert wrong[1] == n1
    assert wrong[2] == n2
    assert wrong[4] == n2


def test_a_graph_file_is_the_merged_maps_graph(days: Days, tmp_path: Path) -> None:
    """--graph FILE with one place at (2, 0): track 1 of both days binds to it; the places the
    file lacks release their people to hash cells."""
    graph = save_graph_file(tmp_path / "one.json", {0: (2.0, 0.0, 0.0)}, [])
    out = tmp_path / "merged.aion"
    summary = run_json("merge", *days.maps, "-o", out, "--graph", graph, "--format", "json")
    assert summary["graph_source"] == "file one.json"
    assert summary["nodes"] == 1
    assert _node_counts(out) == {0: 2 * days.per_track[1]}
    state = _state(out)
    cells = state.entries.cell_rows()
    assert state.entries.counts[cells].sum() == 2 * (days.per_track[2] + days.per_track[3])


def test_a_log_in_both_maps_is_refused(days: Days, tmp_path: Path) -> None:
    out = tmp_path / "out.aion"
    result = run("merge", days.maps[0], days.both, "-o", out)
    assert result.exit_code == 2
    assert_one_line_error(
        result.stderr, "monday.mcap", "monday.aion", "both.aion", "never counted twice"
    )
    assert not out.exists()


def test_a_copy_of_a_log_under_another_name_is_named_both_ways(
    days: Days, tmp_path: Path
) -> None:
    # a robot's log copied under another name (from another machine, say) and built into a
    # second map: the error names the log as each map has it, not only the later name
    copy = tmp_path / "robot1-monday.mcap"
    shutil.copyfile(days.logs[0], copy)
    copied = tmp_path / "copied.aion"
    assert run("build", copy, "-o", copied, "-q").exit_code == 0
    result = run("merge", days.maps[0], copied, "-o", tmp_path / "out.aion")
    assert result.exit_code == 2
    assert_one_line_error(
        result.stderr, "the log monday.mcap (sha256 ", "a copy named robot1-monday.mcap in "
        "copied.aion) is in both monday.aion and copied.aion", "never counted twice"
    )


def test_bad_inputs_are_one_line_errors(days: Days, tmp_path: Path) -> None:
    mon, wed = days.maps
    out = tmp_path / "out.aion"
    cases = [
        (("merge", mon, "-o", out), ["at least two maps"]),
        (("merge", mon, tmp_path / "missing.aion", "-o", out), ["not found", "missing.aion"]),
        (("merge", mon, days.logs[1], "-o", out), ["wednesday.mcap", "not a readable aion map"]),
        (("merge", mon, mon, "-o", out), ["given twice"]),
        (("merge", mon, wed, "-o", mon), ["one of the input maps"]),
        (("merge", mon, wed, "-o", days.logs[0]), ["not an aion map"]),
        (("merge", mon, wed, "-o", out, "--lineage", "maybe"), ["maybe"]),
        (("merge", mon, wed, "-o", out, "--graph", tmp_path / "no.json"), ["no.json"]),
        (("merge", mon, wed), ["-o"]),
        (("merge", mon, "/dev/null", "-o", out), ["/dev/null is not a regular file, not a map"]),
        (("merge", mon, wed, "-o", out, "--nav-layer", "NOPE"), ["--nav-layer NOPE", "--graph"]),
    ]
    for args, fragments in cases:
        result = run(*args)
        assert result.exit_code == 2, (args, result.stderr)
        assert_one_line_error(result.stderr, *fragments)
    assert not out.exists()
    assert days.logs[0].stat().st_size > 0
    assert mon.exists()


def test_maps_of_different_models_are_refused(days: Days, tmp_path: Path) -> None:
    config = tmp_path / "model.toml"
    config.write_text(ModelConfig().replace(bind_radius=2.0).to_toml())
    other = tmp_path / "wide.aion"
    assert run("build", days.logs[1], "--config", config, "-o", other, "-q").exit_code == 0
    result = run("merge", days.maps[0], other, "-o", tmp_path / "out.aion")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "different model parameters", "bind_radius 1.0 vs 2.0")
    assert "hint: rebuild one of them" in result.stderr
    zoned = tmp_path / "tokyo.aion"
    assert run("build", days.logs[1], "--tz", "Asia/Tokyo", "-o", zoned, "-q").exit_code == 0
    result = run("merge", days.maps[0], zoned, "-o", tmp_path / "out.aion")
    assert result.exit_code == 2
    # named as zones (it read "different model parameters (fremen_clock None vs 'standard',
    # timezone 'UTC' vs 'Asia/Tokyo')", with a hint about --config files)
    assert_one_line_error(
        result.stderr, "monday.aion (UTC) and tokyo.aion (Asia/Tokyo)", "different time zones"
    )
    assert "hint: rebuild one of them with the other's --tz" in result.stderr


def test_the_installed_command_merges_and_has_help(days: Days, tmp_path: Path) -> None:
    out = tmp_path / "week.aion"
    done = run_process("merge", *days.maps, "-o", out)
    assert done.returncode == 0, done.stderr
    assert "lineage" in done.stderr
    assert "detections" in done.stderr
    assert "600" in done.stderr  # 2 x 300 detections
    info = run_json("info", out, "--format", "json")
    assert [i["name"] for i in info["inputs"]] == ["monday.mcap", "wednesday.mcap"]
    helped = run("merge", "--help")
    assert helped.exit_code == 0
    assert "aion merge " in helped.stdout.split("Examples:")[1]
    from aion_cli.merge_report import MergeReport

    listed = " ".join(helped.stdout.split("JSON keys (--format json):")[1].split())
    for key in MergeReport(out).to_dict():  # every key the JSON has is named in the help
        assert f" {key}" in f" {listed}" or f"{key}," in listed, key
    assert "merge" in run("--help").stdout


def test_a_merge_of_fixed_sensor_maps_describes_both_maps_windows(tmp_path: Path) -> None:
    """Two fixed sensors' maps merged: the manifest's observation counts the windows of both,
    as a build of both logs says (it described the later map's windows alone, while its
    window count was both maps')."""
    logs = []
    for k, start in enumerate(("2026-01-05T09:00", "2026-01-07T09:00")):
        log = tmp_path / f"day{k}.mcap"
        made = run("simulate", "-o", log, "--days", "0.05", "--start", start, "--robot",
                   "fixed", "--seed", str(k), "-q")  # fmt: skip
        assert made.exit_code == 0, made.stderr
        assert run("build", log, "-o", log.with_suffix(".aion"), "-q").exit_code == 0
        logs.append(log)
    merged, both = tmp_path / "merged.aion", tmp_path / "both.aion"
    assert run("merge", *[p.with_suffix(".aion") for p in logs], "-o", merged, "-q").exit_code == 0
    assert run("build", *logs, "-o", both, "-q").exit_code == 0
    said = read_manifest(merged)["observation"]
    assert said == read_manifest(both)["observation"]
    assert said.startswith("fixed sensor over the 16 windows")  # 8 ten-minute windows a log


def _sessions(tmp_path: Path, robot: str) -> list[Path]:
    """Two short simulated sessions two days apart (``robot``: ``fixed`` or ``patrol``)."""
    logs = []
    for k, start in enumerate(("2026-01-05T09:00", "2026-01-07T09:00")):
        log = tmp_path / f"{robot}{k}.mcap"
        made = run("simulate", "-o", log, "--days", "0.05", "--start", start, "--robot",
                   robot, "--seed", str(k), "-q")  # fmt: skip
        assert made.exit_code == 0, made.stderr
        logs.append(log)
    return logs


def test_a_map_from_before_exposure_merges_when_no_robot_observed_it(tmp_path: Path) -> None:
    """A map written before robot windows were weighed reads as ``exposure = false``; for two
    fixed sensors' maps that changes nothing, so they merge (under the newer setting) into
    the map a merge of two current maps gives. Robot maps are refused, with the way out."""
    whole = tmp_path / "whole.toml"
    whole.write_text(ModelConfig(exposure=False).to_toml())
    fixed = _sessions(tmp_path, "fixed")
    old, new = tmp_path / "old.aion", tmp_path / "new.aion"
    assert run("build", fixed[0], "--config", whole, "-o", old, "-q").exit_code == 0
    assert run("build", fixed[1], "-o", new, "-q").exit_code == 0
    current = tmp_path / "current.aion"
    assert run("build", fixed[0], "-o", current, "-q").exit_code == 0
    mixed, same = tmp_path / "mixed.aion", tmp_path / "same.aion"
    assert run("merge", old, new, "-o", mixed, "-q").exit_code == 0
    assert run("merge", current, new, "-o", same, "-q").exit_code == 0
    assert read_manifest(mixed)["state"]["config"]["exposure"] is True
    at = ("--time", "2026-01-07 09:30", "--format", "csv")
    assert run("predict", mixed, *at).stdout == run("predict", same, *at).stdout

    patrol = _sessions(tmp_path, "patrol")
    old, new = tmp_path / "old_robot.aion", tmp_path / "new_robot.aion"
    assert run("build", patrol[0], "--config", whole, "-o", old, "-q").exit_code == 0
    assert run("build", patrol[1], "-o", new, "-q").exit_code == 0
    refused = run("merge", old, new, "-o", tmp_path / "out.aion")
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "count a robot's windows differently", "exposure")
    assert "exposure = false" in refused.stderr


def test_info_table_names_the_maps_merged_and_their_lineage(days: Days, tmp_path: Path) -> None:
    """``aion info`` of a merged map: its table showed the logs but not that (nor which) maps
    were merged, nor how, which only its JSON (merged_from, lineage) said."""
    same = tmp_path / "same.aion"
    assert run("merge", days.maps[0], days.maps[1], "-o", same, "-q").exit_code == 0
    graph = save_graph_file(tmp_path / "other.json", {i: PLACES[(i + 1) % 7] for i in PLACES},
                            EDGES)
    other = tmp_path / "wednesday-other.aion"
    assert run("build", days.logs[1], "--graph", graph, "-o", other, "-q").exit_code == 0
    different = tmp_path / "different.aion"
    assert run("merge", days.maps[0], other, "-o", different, "-q").exit_code == 0
    for path, names, how in (
        (same, "monday.aion, wednesday.aion", "one scene-graph session"),
        (different, "monday.aion, wednesday-other.aion", "different scene-graph sessions"),
    ):
        doc = run_json("info", path, "--format", "json")
        assert ", ".join(m["name"] for m in doc["merged_from"]) == names
        assert doc["lineage"] == ("same" if path == same else "different")
        table = run("info", path)
        assert table.exit_code == 0, table.stderr
        cells = [line.split("│")[1:3] for line in table.stdout.splitlines() if line.count("│") == 3]
        start = next(k for k, (what, _) in enumerate(cells) if what.strip() == "merged from")
        end = next((k for k in range(start + 1, len(cells)) if cells[k][0].strip()), len(cells))
        row = " ".join(value.strip() for _, value in cells[start:end])  # a wrapped cell, joined
        assert row.startswith(f"2 maps by aion merge ({how}"), table.stdout
        maps = [value.split()[0] for what, value in cells if what.strip() == "merged map"]
        assert ", ".join(maps) == names, table.stdout
    unmerged = run("info", days.maps[0])
    assert "merged from" not in unmerged.stdout
