"""``aion export -o DIR`` removes only files an export itself wrote into DIR (listed in the
folder's hidden manifest and unchanged since), never a file another command wrote there."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.cli.conftest import Office, assert_one_line_error, run

AT = "2026-11-23 08:30"


def _undirected_map(path: Path) -> Path:
    """A map of three detections without a heading: hash cells, no direction, so its
    export draws no arrows (no ``arrows.ply``)."""
    from aion_cli.api import Map
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import DetectionBatch
    from aion_cli.timeparse import parse_time, resolve_zone

    t0 = parse_time("2026-11-23 08:00", resolve_zone("UTC"))
    mapper = Mapper(ModelConfig())
    mapper.set_fixed_sensor(t0, t0 + 3600 * 10**9)
    xyz = np.array([[0.2, 0.2, 0.0], [0.7, 0.2, 0.0], [3.2, 1.3, 0.0]])
    mapper.add_detections(
        DetectionBatch.from_arrays(t0 + np.arange(3) * 10**9, xyz, np.full(3, np.nan))
    )
    mapper.advance(t0 + 3600 * 10**9)
    Map.from_state(mapper.state, timezone="UTC").save(path)
    return path


def test_an_arrowless_export_keeps_a_plan_scene_named_arrows_ply(
    office: Office, tmp_path: Path
) -> None:
    """``aion plan --export out/arrows.ply`` then an export drawing no arrows into ``out/``:
    the plan's scene (an aion PLY file, but no export's) was removed as a stale arrows part.
    It stays, byte for byte."""
    undirected = _undirected_map(tmp_path / "undirected.aion")
    fresh = tmp_path / "fresh"
    assert run("export", undirected, "--time", AT, "-o", fresh, "-q").exit_code == 0
    assert not (fresh / "arrows.ply").exists()  # the export below draws no arrows
    out = tmp_path / "out"
    out.mkdir()
    scene = out / "arrows.ply"
    plan = ["plan", office.map, "--from", "p0", "--to", "p4", "--time", AT, "--export", scene]
    assert run(*plan).exit_code == 0
    before = scene.read_bytes()
    result = run("export", undirected, "--time", AT, "-o", out)
    assert result.exit_code == 0, result.stderr
    assert scene.read_bytes() == before


def test_an_export_removes_its_own_stale_parts_not_a_plan_scene_written_over_one(
    office: Office, tmp_path: Path
) -> None:
    """The office exported into ``out/`` (nodes, arrows, edges), the plan's scene saved over
    its ``arrows.ply``, then an export without nodes, edges or arrows: the earlier export's
    nodes and edges go (a viewer would draw them on the other map), the plan's scene stays."""
    out = tmp_path / "out"
    assert run("export", office.map, "--time", AT, "-o", out, "-q").exit_code == 0
    assert {"nodes.ply", "edges.ply", "arrows.ply"} <= {p.name for p in out.iterdir()}
    scene = out / "arrows.ply"
    plan = ["plan", office.map, "--from", "p0", "--to", "p4", "--time", AT, "--export", scene]
    assert run(*plan).exit_code == 0
    before = scene.read_bytes()
    result = run("export", _undirected_map(tmp_path / "u.aion"), "--time", AT, "-o", out)
    assert result.exit_code == 0, result.stderr
    assert scene.read_bytes() == before
    assert not (out / "nodes.ply").exists()
    assert not (out / "edges.ply").exists()
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "arrows.ply", "cells.ply", "entries.csv", "entries.json", "scene.ply",
    ]  # fmt: skip


def test_an_export_refuses_to_replace_a_plan_scene_unless_forced(
    office: Office, tmp_path: Path
) -> None:
    """``aion plan --export out/arrows.ply`` then ``aion export -o out/`` (which draws
    arrows): the plan's scene was replaced by the export's arrows, exit 0. Now refused,
    naming the file, nothing written; ``--force`` replaces it with the export's arrows (as
    a fresh folder's); a later export replaces the files an export wrote, as before."""
    fresh = tmp_path / "fresh"
    assert run("export", office.map, "--time", AT, "-o", fresh, "-q").exit_code == 0
    out = tmp_path / "out"
    out.mkdir()
    scene = out / "arrows.ply"
    plan = ["plan", office.map, "--from", "p0", "--to", "p4", "--time", AT, "--export", scene]
    assert run(*plan).exit_code == 0
    before = scene.read_bytes()
    assert before != (fresh / "arrows.ply").read_bytes()
    result = run("export", office.map, "--time", AT, "-o", out)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, str(scene), "no export into", "nothing was written")
    assert "--force" in result.stderr
    assert scene.read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == ["arrows.ply"]  # nothing else written
    forced = run("export", office.map, "--time", AT, "-o", out, "--force", "-q")
    assert forced.exit_code == 0, forced.stderr
    assert scene.read_bytes() == (fresh / "arrows.ply").read_bytes()
    again = run("export", office.map, "--time", AT, "-o", out, "-q")  # its own files now
    assert again.exit_code == 0, again.stderr
    assert scene.read_bytes() == (fresh / "arrows.ply").read_bytes()


def test_an_export_file_changed_since_is_refused_and_a_users_file_even_forced(
    office: Office, tmp_path: Path
) -> None:
    """A file an export wrote but someone changed since is no longer the export's: refused
    without --force. A file that is not aion's at all is refused even with --force."""
    out = tmp_path / "out"
    assert run("export", office.map, "--time", AT, "-o", out, "-q").exit_code == 0
    nodes = out / "nodes.ply"
    nodes.write_bytes(nodes.read_bytes() + b"\n")
    changed = nodes.read_bytes()
    result = run("export", office.map, "--time", AT, "-o", out)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, str(nodes), "no export into")
    assert nodes.read_bytes() == changed
    assert run("export", office.map, "--time", AT, "-o", out, "--force", "-q").exit_code == 0
    assert nodes.read_bytes() != changed
    mine = out / "edges.ply"
    mine.write_text("my own notes\n")
    result = run("export", office.map, "--time", AT, "-o", out, "--force")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, str(mine), "not a file aion wrote")
    assert mine.read_text() == "my own notes\n"


def test_a_folder_an_older_aion_exported_into_says_so_and_force_takes_it_over(
    office: Office, tmp_path: Path
) -> None:
    """A folder exported into before exports kept their list (no manifest): the refusal
    says the list is missing (not that another command wrote the files); --force replaces
    aion's files once, and the folder then has its list (a plain export works again)."""
    out = tmp_path / "out"
    assert run("export", office.map, "--time", AT, "-o", out, "-q").exit_code == 0
    (out / ".aion-export.json").unlink()  # as an older aion left it
    result = run("export", office.map, "--time", AT, "-o", out)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "no export into", "has no .aion-export.json")
    assert run("export", office.map, "--time", AT, "-o", out, "--force", "-q").exit_code == 0
    assert (out / ".aion-export.json").is_file()
    assert run("export", office.map, "--time", AT, "-o", out, "-q").exit_code == 0
