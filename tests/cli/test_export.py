"""``aion export``: scene files and tables, time series, paths, and bad option mixes (an export
into a folder an earlier one wrote: ``test_export_again.py``)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import Office, assert_one_line_error, run, run_json

AT = "2026-11-23 08:30"


def test_ply_scene_and_tables_match_predict(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "out"
    result = run("export", office.map, "--time", AT, "-o", out)
    assert result.exit_code == 0, result.stderr
    names = {p.name for p in out.iterdir()}
    assert {"nodes.ply", "arrows.ply", "edges.ply", "scene.ply"} <= names
    assert {"entries.csv", "entries.json"} <= names
    assert (out / "scene.ply").read_bytes().startswith(b"ply\n")
    exported = json.loads((out / "entries.json").read_text())
    predicted = run_json("predict", office.map, "--time", AT, "--format", "json")
    assert exported["time_ns"] == predicted["time_ns"]
    assert exported["zone"] == predicted["zone"] == "UTC"
    by_id = sorted(exported["entries"], key=lambda e: e["id"])
    assert by_id == sorted(predicted["entries"], key=lambda e: e["id"])
    rows = {r["id"]: r for r in csv.DictReader((out / "entries.csv").open())}
    assert rows["p1"]["direction_bin"] == "4"


def test_historical_pcd(office: Office, tmp_path: Path) -> None:
    result = run("export", office.map, "--historical", "--format", "pcd", "-o", tmp_path)
    assert result.exit_code == 0, result.stderr
    nodes = tmp_path / "nodes.pcd"
    assert nodes.is_file()
    assert b"POINTS 7" in nodes.read_bytes()[:400]
    assert json.loads((tmp_path / "entries.json").read_text())["time_ns"] is None


def test_time_series_and_path(office: Office, tmp_path: Path) -> None:
    result = run(
        "export",
        office.map,
        "--from",
        "2026-11-23 08:00",
        "--to",
        "2026-11-23 09:00",
        "--step",
        "30m",
        "-o",
        tmp_path,
        "--path-from",
        "p0",
        "--path-to",
        "p4",
    )
    assert result.exit_code == 0, result.stderr
    folders = sorted(p.name for p in tmp_path.iterdir() if p.is_dir())
    assert folders == ["20261123T080000Z", "20261123T083000Z", "20261123T090000Z"]
    assert (tmp_path / ".aion-export.json").is_file()  # what the export wrote, for the next
    for folder in folders:
        assert (tmp_path / folder / "path.ply").is_file()
        assert (tmp_path / folder / "entries.csv").is_file()


def test_a_path_s_ends_given_as_a_point_or_room_say_which_place_they_stand_for(
    office: Office, tmp_path: Path
) -> None:
    """--path-from R1 --path-to 0.1,0.2 drew a path between places the export never named
    (plan says which: 'its place nearest the room's centre, p2'); the export says it as plan
    does, with the same distances (R1's centre is 0.94 m from p2, by hand: tests/cli/test_plan.py),
    and nothing for ends given as place ids."""
    result = run("export", office.map, "--historical", "-o", tmp_path / "a",
                 "--path-from", "R1", "--path-to", "0.1,0.2")
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split())
    assert "--path-from room1 (R1): its place nearest the room's centre, p2 (0.94 m from it)" in (
        said
    ), said
    plan = run("plan", office.map, "--from", "R1", "--to", "0.1,0.2", "--time", AT)
    planned = " ".join(plan.stderr.split())
    assert "--to 0.1,0.2 snapped to p0" in planned, planned
    assert planned.split("--to ", 1)[1].split(")")[0] in said  # the same node and distance
    ids = run("export", office.map, "--historical", "-o", tmp_path / "b",
              "--path-from", "p2", "--path-to", "p0")
    assert ids.exit_code == 0, ids.stderr
    assert "--path-" not in ids.stderr


def test_a_path_drawn_with_historical_is_said_to_be_the_shortest_by_distance(
    office: Office, tmp_path: Path
) -> None:
    """--historical has no time to forecast costs at, so the path drawn is plan's distance-only
    path (the rows planned are those of the distance-only route between the same places);
    the export had drawn it without a word, beside flows that a temporal plan avoids. A path
    at --time gets no such note, and neither does --historical without a path."""
    from aion_cli.cli.common import load
    from aion_cli.exports import path_ends, planned_path
    from aion_cli.routes import plan_routes

    result = run("export", office.map, "--historical", "-o", tmp_path / "h.png",
                 "--path-from", "p2", "--path-to", "p0")
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split())
    assert "the path drawn is the shortest by distance (give --time for one" in said, said
    loaded = load(office.map)
    ends = path_ends(loaded, "p2", "p0")
    nav = ends[0]
    shortest = plan_routes(loaded, ends[1], ends[2], None, nav=nav).distance_only.rows
    assert np.array_equal(planned_path(loaded, None, ends), nav.xyz[shortest])
    timed = run("export", office.map, "--time", AT, "-o", tmp_path / "t.png",
                "--path-from", "p2", "--path-to", "p0")
    assert timed.exit_code == 0, timed.stderr
    assert "shortest by distance" not in timed.stderr
    bare = run("export", office.map, "--historical", "-o", tmp_path / "b.png")
    assert "shortest by distance" not in bare.stderr


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--time", AT, "--historical"], "choose one"),
        (["--from", AT], "--to"),
        (["--from", AT, "--to", "2026-11-23 07:00"], "before"),
        (["--from", AT, "--to", "2026-11-24 08:30", "--step", "fortnight"], "fortnight"),
        (["--time", AT, "--path-from", "p0"], "--path-to"),
        (["--time", AT, "--path-from", "p0", "--path-to", "p77"], "p77"),
        (["--time", AT, "--path-from", "p0", "--path-to", "p6"], "no path"),
        (["--time", AT, "--format", "obj"], "obj"),
        (["--time", AT, "--step", "1h"], "--step needs --from and --to"),  # was ignored
    ],
)
def test_bad_option_mixes(office: Office, tmp_path: Path, args: list[str], fragment: str) -> None:
    result = run("export", office.map, "-o", tmp_path / "out", *args)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, fragment)
    assert not (tmp_path / "out").exists()  # nothing half-written


@pytest.mark.parametrize(
    ("name", "magic"),
    [("map.png", b"\x89PNG\r\n\x1a\n"), ("day.mcap", b"\x89MCAP0\r\n"), ("g.json", b"{")],
)
def test_the_format_follows_the_output_suffix(
    office: Office, tmp_path: Path, name: str, magic: bytes
) -> None:
    """Without --format, -o naming a .png / .mcap / .json file writes that one file (it was
    a folder of PLY scenes named map.png)."""
    out = tmp_path / name
    result = run("export", office.map, "-o", out, "--time", AT)
    assert result.exit_code == 0, result.stderr
    assert out.is_file()
    assert out.read_bytes().startswith(magic)


@pytest.mark.parametrize(
    ("fmt", "name"),
    [("pcd", "map.png"), ("ply", "scene.pcd"), ("ply", "graph.json"), ("ply", "flows.csv"),
     ("pcd", "flows.csv")],
)  # fmt: skip
def test_a_scene_format_refuses_another_formats_file_name(
    office: Office, tmp_path: Path, fmt: str, name: str
) -> None:
    result = run("export", office.map, "-o", tmp_path / name, "--time", AT, "--format", fmt)
    assert result.exit_code == 2
    said = {".png": "format png", ".pcd": "format pcd", ".json": "format dsg", ".csv": "a table"}
    suffix = Path(name).suffix
    assert_one_line_error(
        result.stderr,
        f"the format {fmt} and the name {str(tmp_path / name)!r} disagree: {suffix} is the "
        f"suffix of {said[suffix]}",
    )
    assert f"hint: name it {Path(name).stem}.{fmt}, or a folder (e.g. out/)" in result.stderr
    assert not (tmp_path / name).exists()


def test_an_output_named_as_a_table_is_refused_unless_it_is_a_folder(
    office: Office, tmp_path: Path
) -> None:
    """``-o flows.csv`` (no --format) made a folder flows.csv/ holding PLY files, exit 0:
    a script then reading flows.csv as a table found a folder. It is refused now, naming
    the command that writes the table alone; an existing folder of that name is written
    into as before."""
    out = tmp_path / "flows.csv"
    result = run("export", office.map, "-o", out, "--time", AT)
    assert result.exit_code == 2
    assert_one_line_error(
        result.stderr, f"the format ply (the default) and the name {str(out)!r} disagree"
    )
    assert "--format csv > FILE.csv" in result.stderr
    assert not out.exists()
    out.mkdir()
    result = run("export", office.map, "-o", out, "--time", AT, "-q")
    assert result.exit_code == 0, result.stderr
    assert (out / "entries.csv").is_file()
    assert (out / "scene.ply").is_file()


@pytest.mark.parametrize("fmt", ["ply", "pcd"])
def test_a_scene_file_name_writes_the_whole_scene_in_one_file(
    office: Office, tmp_path: Path, fmt: str
) -> None:
    """``-o scene.ply`` (or .pcd) writes the one file a folder export calls scene.ply, byte
    for byte; a series needs a folder; another kind of file is never replaced."""
    folder = tmp_path / "folder"
    assert run("export", office.map, "--time", AT, "--format", fmt, "-o", folder).exit_code == 0
    one = tmp_path / f"one.{fmt}"
    result = run("export", office.map, "--time", AT, "-o", one)
    assert result.exit_code == 0, result.stderr
    assert one.read_bytes() == (folder / f"scene.{fmt}").read_bytes()
    again = run("export", office.map, "--time", AT, "-o", one)  # its own file: replaced
    assert again.exit_code == 0, again.stderr
    series = run("export", office.map, "--from", AT, "--to", "2026-11-23 09:30", "-o",
                 tmp_path / f"day.{fmt}")
    assert series.exit_code == 2
    assert_one_line_error(series.stderr, "a series writes one")
    notes = tmp_path / f"notes.{fmt}"
    notes.write_text("mine")
    refused = run("export", office.map, "--time", AT, "-o", notes)
    assert refused.exit_code == 2
    assert notes.read_text() == "mine"


def test_the_tables_say_whether_the_hour_was_observed(office: Office, tmp_path: Path) -> None:
    """The office log observed 08:00-08:20 UTC: entries.json at 08:30 says its hour was
    observed, at 03:00 that it was not; historically there is no hour to speak of.
    entries.csv says it too, on every row, as ``predict --format csv`` (before, its rows
    read the same at both times once the JSON was left behind)."""
    import csv

    for when, seen in ((AT, True), ("2026-11-23 03:00", False)):
        out = tmp_path / when[-5:].replace(":", "")
        result = run("export", office.map, "--time", when, "--tz", "UTC", "-o", out)
        assert result.exit_code == 0, result.stderr
        assert json.loads((out / "entries.json").read_text())["hour_observed"] is seen
        text = (out / "entries.csv").read_text()
        rows = list(csv.DictReader(text.splitlines()))
        assert rows
        assert {r["hour_observed"] for r in rows} == {"true" if seen else "false"}
        printed = run("predict", office.map, "--time", when, "--tz", "UTC", "--format", "csv")
        # predict's CSV, its rows in table order rather than busiest first
        assert sorted(text.splitlines()) == sorted(printed.stdout.splitlines())
    past = tmp_path / "historical"
    assert run("export", office.map, "--historical", "-o", past).exit_code == 0
    assert "hour_observed" not in json.loads((past / "entries.json").read_text())
    with open(past / "entries.csv", newline="") as fh:
        assert {r["hour_observed"] for r in csv.DictReader(fh)} == {""}


@pytest.mark.parametrize(
    ("span", "step", "hint"),
    [
        (("2026-11-23 06:00", "2026-11-24 06:00"), "10m", "--step 2h draws this span in 13 panels"),
        (("2026-11-23 06:00", "2026-11-23 18:00"), "10m", "--step 1h draws this span in 13 panels"),
        (("2026-11-23 00:00", "2026-12-23 00:00"), "1h", "--step 2d draws this span in 16 panels"),
    ],
)
def test_too_many_panels_names_a_step_that_fits(
    office: Office, tmp_path: Path, span: tuple[str, str], step: str, hint: str
) -> None:
    """24 h at 10 min is 145 panels: the error says which round step draws the same span in
    at most 24 (1 h would be 25), and nothing is written."""
    out = tmp_path / "day.png"
    result = run(
        "export", office.map, "--from", span[0], "--to", span[1], "--step", step, "-o", out
    )
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "more than 24")
    assert hint in result.stderr
    assert not out.exists()


def test_a_series_of_one_time_is_written_as_a_series(office: Office, tmp_path: Path) -> None:
    """``--from T --to T`` is a series that has one time: its frame goes into the subfolder
    named by the time, as every series' frames do (it went straight into -o, as ``--time``
    writes); a series' file formats refuse it as they refuse any series."""
    out = tmp_path / "one"
    result = run("export", office.map, "--from", AT, "--to", AT, "-o", out)
    assert result.exit_code == 0, result.stderr
    assert sorted(p.name for p in out.iterdir()) == [".aion-export.json", "20261123T083000Z"]
    frame = out / "20261123T083000Z"
    assert (frame / "entries.csv").is_file()
    assert (frame / "scene.ply").is_file()
    assert json.loads((frame / "entries.json").read_text())["time_ns"] == 1795422600 * 10**9
    single = tmp_path / "single"
    assert run("export", office.map, "--time", AT, "-o", single).exit_code == 0
    assert (single / "entries.csv").is_file()  # one --time: straight into -o
    assert (single / "entries.csv").read_bytes() == (frame / "entries.csv").read_bytes()
    for name, fragment in (("one.ply", "a series writes one"), ("one.json", "not a series")):
        refused = run("export", office.map, "--from", AT, "--to", AT, "-o", tmp_path / name)
        assert refused.exit_code == 2
        assert_one_line_error(refused.stderr, fragment)
        assert not (tmp_path / name).exists()


def test_a_series_of_too_many_frames_names_them_frames(office: Office, tmp_path: Path) -> None:
    """An export series over 1,000 steps said "the series would have N times": an export
    writes frames (a plan's series departures), and says so, with the count."""
    result = run("export", office.map, "--from", "2026-11-23 08:00", "--to", "2026-11-23 09:00",
                 "--step", "1s", "-o", tmp_path / "series")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "the series would have 3,601 frames (at most 1,000)")
    assert not (tmp_path / "series").exists()


@pytest.mark.parametrize("fmt", ["ply", "pcd"])
def test_a_scene_file_of_an_empty_map_is_an_error_not_a_crash(tmp_path: Path, fmt: str) -> None:
    """A map with no places, cells or mesh (``Map.from_state`` of an empty state) has no part
    to draw: ``-o scene.ply`` ended in "internal error: StopIteration" (exit 1). It is one
    line saying so (exit 2), and nothing is written; a folder export still writes its (empty)
    tables."""
    from aion_cli.api import Map
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.state import MapState

    empty = tmp_path / "empty.aion"
    Map.from_state(MapState.empty(ModelConfig()), timezone="UTC").save(empty)
    one = tmp_path / f"scene.{fmt}"
    result = run("export", empty, "--time", AT, "-o", one)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "nothing to draw", "no places, hash cells or mesh")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.aion"]
    folder = tmp_path / "out"
    assert run("export", empty, "--time", AT, "--format", fmt, "-o", folder).exit_code == 0
    tables = json.loads((folder / "entries.json").read_text())
    assert tables["entries"] == []
