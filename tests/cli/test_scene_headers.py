"""PLY / PCD scenes say in their header which time their flows are forecast at and whether a
log observed that hour (``predictions.scene_about``), as ``entries.json`` and ``aion predict
--format json`` say it: a scene file on its own (``export -o scene.ply``, ``plan --export``)
had nothing to tell a forecast at an hour no log observed (each entry's static rate) from a
measured one. The office map's log observed 08:00-08:20 UTC."""

from __future__ import annotations

import json
from pathlib import Path

from aion_cli.formats.scene_files import is_aion_scene_file
from tests.cli.conftest import Office, run, run_json

EARLY, SEEN = "2026-11-30 07:00", "2026-11-30 08:05"


def aion_comments(path: Path) -> list[str]:
    """The header comments after aion's marker (``comment ...`` in PLY, ``# ...`` in PCD)."""
    data = path.read_bytes()
    end = data.index(b"end_header\n") if data.startswith(b"ply\n") else data.index(b"\nDATA ")
    lines = data[:end].decode("ascii").splitlines()
    start = "comment " if data.startswith(b"ply\n") else "# "
    said = [line.removeprefix(start) for line in lines if line.startswith(start)]
    at = said.index("written by aion export")  # the marker (after PCD's own first line)
    return said[at + 1 :]


def _said(doc: dict[str, object]) -> list[str]:
    """The lines a scene at the time of predict's JSON ``doc`` carries, from that document."""
    flag = "true" if doc["hour_observed"] else "false"
    return [
        "aion mode predicted", f"aion time {doc['time']}", f"aion zone {doc['zone']}",
        f"aion hour_observed {flag}",
    ]


def test_a_folder_export_says_its_time_and_hour_in_every_scene_file(
    office: Office, tmp_path: Path
) -> None:
    out = tmp_path / "early"
    assert run("export", office.map, "--time", EARLY, "--tz", "UTC", "-o", out).exit_code == 0
    doc = json.loads((out / "entries.json").read_text())
    assert doc["hour_observed"] is False
    expected = _said(doc)
    assert expected[1:] == ["aion time 2026-11-30 07:00:00+00:00", "aion zone UTC",
                            "aion hour_observed false"]
    scenes = sorted(out.glob("*.ply"))
    assert {p.name for p in scenes} >= {"scene.ply", "nodes.ply", "edges.ply"}
    for path in scenes:
        assert aion_comments(path) == expected, path.name
        assert is_aion_scene_file(path)


def test_one_scene_file_and_a_plans_scene_say_it_too(office: Office, tmp_path: Path) -> None:
    one = tmp_path / "seen.pcd"
    assert run("export", office.map, "--time", SEEN, "--tz", "UTC", "-o", one).exit_code == 0
    seen = run_json("predict", office.map, "--time", SEEN, "--tz", "UTC", "--format", "json")
    assert seen["hour_observed"] is True
    assert aion_comments(one) == _said(seen)
    plan = tmp_path / "plan.ply"
    ends = ("--from", "p0", "--to", "p4", "--tz", "UTC")
    result = run("plan", office.map, *ends, "--time", EARLY, "--export", plan)
    assert result.exit_code == 0, result.stderr
    early = run_json("predict", office.map, "--time", EARLY, "--tz", "UTC", "--format", "json")
    assert aion_comments(plan) == _said(early)
    assert aion_comments(plan)[-1] == "aion hour_observed false"


def test_a_historical_scene_says_it_is_as_observed(office: Office, tmp_path: Path) -> None:
    past = tmp_path / "past.ply"
    assert run("export", office.map, "--historical", "-o", past).exit_code == 0
    assert aion_comments(past) == ["aion mode historical"]
