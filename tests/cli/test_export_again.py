"""``aion export`` into a folder an earlier export wrote: the files it drew and this one does
not (a path, a series' extra frames) go, the user's own files and a plan's scene stay, and a
folder keeps its name."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.cli.conftest import Office, assert_one_line_error, run
from tests.cli.test_export import AT


def test_an_existing_folder_keeps_its_name(office: Office, tmp_path: Path) -> None:
    """--format ply into a folder that exists, whatever its name: the scene goes into it."""
    out = tmp_path / "renders.png"
    out.mkdir()
    result = run("export", office.map, "-o", out, "--time", AT, "--format", "ply")
    assert result.exit_code == 0, result.stderr
    assert (out / "entries.csv").is_file()


@pytest.mark.parametrize("fmt", ["ply", "pcd"])
def test_export_without_path_drops_the_earlier_exports_path(
    office: Office, tmp_path: Path, fmt: str
) -> None:
    # an export with --path-from/--path-to, then one without into the same folder: the
    # earlier path file is no part of the new scene (a viewer would draw it), so it goes
    out = tmp_path / "out"
    first = ["export", office.map, "--time", AT, "--format", fmt, "-o", out]
    assert run(*first, "--path-from", "p0", "--path-to", "p4").exit_code == 0
    assert (out / f"path.{fmt}").is_file()
    mine = out / "notes.txt"
    mine.write_text("kept")
    result = run(*first)
    assert result.exit_code == 0, result.stderr
    assert not (out / f"path.{fmt}").exists()
    assert (out / f"nodes.{fmt}").is_file()
    assert mine.read_text() == "kept"


def test_series_without_path_drops_each_frames_earlier_path(
    office: Office, tmp_path: Path
) -> None:
    series = ["--from", "2026-11-23 08:00", "--to", "2026-11-23 08:30", "--step", "30m"]
    args = ["export", office.map, *series, "-o", tmp_path]
    assert run(*args, "--path-from", "p0", "--path-to", "p4").exit_code == 0
    assert len(list(tmp_path.glob("*/path.ply"))) == 2
    result = run(*args)
    assert result.exit_code == 0, result.stderr
    assert list(tmp_path.glob("*/path.ply")) == []
    assert len(list(tmp_path.glob("*/nodes.ply"))) == 2


def test_export_keeps_a_plan_scene_saved_as_path_ply(office: Office, tmp_path: Path) -> None:
    # README's 'aion plan ... --export path.ply' is a whole scene, not an export's path part
    scene = tmp_path / "path.ply"
    planned = run("plan", office.map, "--from", "p0", "--to", "p4", "--time", AT, "--export", scene)
    assert planned.exit_code == 0, planned.stderr
    before = scene.read_bytes()
    result = run("export", office.map, "--time", AT, "-o", tmp_path)
    assert result.exit_code == 0, result.stderr
    assert scene.read_bytes() == before


def test_a_shorter_series_removes_the_earlier_series_extra_frames(
    office: Office, tmp_path: Path
) -> None:
    """A series of 2 frames written over one of 4 in the same folder: the 2 old frames it
    does not write go (the folder held both runs, 4 frames played as one series); a frame
    folder holding a file of the user's keeps it, and so does a folder named as a frame
    whose files aion did not write."""
    out = tmp_path / "series"
    longer = ["--from", "2026-11-23 06:00", "--to", "2026-11-23 09:00", "--step", "1h"]
    assert run("export", office.map, *longer, "-o", out, "-q").exit_code == 0
    assert len(list(out.glob("2026*"))) == 4
    mine = out / "20261123T090000Z" / "notes.txt"
    mine.write_text("mine")
    theirs = out / "20261123T100000Z"
    theirs.mkdir()
    (theirs / "scene.ply").write_text("a scan of someone else's")
    (out / "readme.txt").write_text("mine too")
    shorter = ["--from", "2026-11-23 06:00", "--to", "2026-11-23 07:00", "--step", "1h"]
    result = run("export", office.map, *shorter, "-o", out)
    assert result.exit_code == 0, result.stderr
    assert sorted(p.name for p in out.iterdir()) == [
        ".aion-export.json", "20261123T060000Z", "20261123T070000Z", "20261123T090000Z",
        "20261123T100000Z", "readme.txt",
    ]  # fmt: skip
    assert [p.name for p in mine.parent.iterdir()] == ["notes.txt"]
    assert mine.read_text() == "mine"
    assert (theirs / "scene.ply").read_text() == "a scan of someone else's"
    said = " ".join(result.stderr.split())
    assert "for times this one has not: 1 frame(s) (20261123T080000Z)" in said
    assert "aion's files of 1 more, which keep the files aion did not write (20261123T090000Z)" in (
        said
    )
    # a single time written straight into the folder leaves a series' frames alone
    assert run("export", office.map, "--time", AT, "-o", out, "-q").exit_code == 0
    assert (out / "20261123T060000Z" / "scene.ply").is_file()


@pytest.mark.parametrize("fmt", ["ply", "pcd"])
def test_an_export_removes_the_parts_an_earlier_export_drew_and_it_does_not(
    office: Office, tmp_path: Path, fmt: str
) -> None:
    """The office (places, edges, arrows) exported into a folder, then a map of hash cells
    only into the same folder: its nodes, arrows and edges stayed beside the new cells and
    tables, and a viewer opening the folder drew the office's places on the other map. The
    folder now holds the scene files an export into an empty folder writes, and the user's
    own file."""
    from aion_cli.api import Map
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch
    from aion_cli.timeparse import parse_time, resolve_zone

    t0 = parse_time("2026-11-23 08:00", resolve_zone("UTC"))
    mapper = Mapper(ModelConfig())
    mapper.set_fixed_sensor(t0, t0 + 3600 * 10**9)
    xyz = np.array([[0.2, 0.2, 0.0], [0.7, 0.2, 0.0], [3.2, 1.3, 0.0]])
    mapper.add_detections(DetectionBatch.from_arrays(t0 + np.arange(3) * 10**9, xyz, np.zeros(3)))
    mapper.advance(t0 + 3600 * 10**9)
    cells = tmp_path / "cells.aion"
    Map.from_state(mapper.state, timezone="UTC").save(cells)
    fresh = tmp_path / "fresh"
    assert run("export", cells, "--historical", "--format", fmt, "-o", fresh).exit_code == 0
    out = tmp_path / "out"
    assert run("export", office.map, "--historical", "--format", fmt, "-o", out).exit_code == 0
    assert (out / f"nodes.{fmt}").is_file()
    (out / "notes.txt").write_text("mine")
    result = run("export", cells, "--historical", "--format", fmt, "-o", out)
    assert result.exit_code == 0, result.stderr
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted([p.name for p in fresh.iterdir()] + ["notes.txt"])
    assert not (out / f"nodes.{fmt}").exists()
    assert (out / f"scene.{fmt}").read_bytes() == (fresh / f"scene.{fmt}").read_bytes()


def test_an_entries_json_of_the_users_is_not_replaced(office: Office, tmp_path: Path) -> None:
    """A JSON file of the user's named entries.json with a "map" and "entries" of its own
    (a glossary, another tool's list) was taken for a table an export wrote and replaced
    without a word. Only a predict document (its mode, bins and times too) is replaced: the
    user's file stops the export (exit 2) and is kept, and an export's own is replaced."""
    out = tmp_path / "out"
    out.mkdir()
    mine = out / "entries.json"
    text = '{"map": "berlin", "entries": [{"word": "Karte"}]}'
    mine.write_text(text)
    result = run("export", office.map, "--time", AT, "-o", out)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "entries.json")
    assert mine.read_text() == text
    assert sorted(p.name for p in out.iterdir()) == ["entries.json"]
    mine.unlink()
    for _ in range(2):  # an export's own tables are replaced by the next export
        done = run("export", office.map, "--time", AT, "-o", out)
        assert done.exit_code == 0, done.stderr
    assert json.loads(mine.read_text())["mode"] == "predicted"
