"""Export targets follow the rule of ``formats/outputs.py``: only aion's own outputs are
replaced, and an output appears complete or not at all — also where the writing library
(open3d, spark_dsg) reports no error on a full disk.

Each "someone else's file" test puts a valid file of the target's format there (a recorded
robot log, an open3d point cloud, a photo) and checks it byte for byte afterwards. A full disk
is simulated by making the writers fail the way they do on one (open3d returns True and leaves
a cut-off file; spark_dsg leaves a cut-off file and raises nothing).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.robustness.conftest import Office, assert_one_error, run

AT = "2026-11-23 08:30"


def export(office: Office, out: Path, *args: str) -> Any:
    return run("export", office.map, "--time", AT, "-o", out, *args)


def refused(result: Any, *fragments: str) -> None:
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, *fragments)
    assert "--force" not in result.stderr  # export has no --force: the hint names none
    assert "replaces only files it wrote itself" in result.stderr


def leftovers(folder: Path) -> list[str]:
    """Hidden staging files or folders left in ``folder`` (not the manifest of the files
    exports wrote there, ``export_stale.MANIFEST``)."""
    from aion_cli.export_stale import MANIFEST

    return sorted(p.name for p in folder.iterdir() if p.name.startswith(".") and p.name != MANIFEST)


def open3d_file(path: Path) -> Path:
    """A point cloud as open3d writes it (someone else's scan, not an aion export)."""
    import open3d as o3d

    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(np.arange(15, dtype=np.float64).reshape(5, 3))
    assert o3d.io.write_point_cloud(path, cloud)
    return path


# -- only aion's own outputs are replaced ------------------------------------------------------


def test_a_recorded_log_at_an_mcap_target_is_never_replaced(
    office: Office, tmp_path: Path
) -> None:
    log = tmp_path / "o2.mcap"
    shutil.copyfile(office.log, log)
    before = log.read_bytes()
    refused(export(office, log), "o2.mcap exists", "not an MCAP scene aion wrote")
    assert log.read_bytes() == before
    assert leftovers(tmp_path) == []


def test_an_mcap_scene_aion_exported_is_replaced(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "scene.mcap"
    assert export(office, out).exit_code == 0
    again = export(office, out)
    assert again.exit_code == 0, again.stderr


@pytest.mark.parametrize("suffix", ["ply", "pcd"])
def test_someone_elses_scene_file_is_never_replaced(
    office: Office, tmp_path: Path, suffix: str
) -> None:
    user = open3d_file(tmp_path / f"user.{suffix}")
    before = user.read_bytes()
    refused(export(office, user), f"user.{suffix} exists", "scene aion wrote")
    assert user.read_bytes() == before


@pytest.mark.parametrize("fmt", ["ply", "pcd"])
def test_a_folder_export_replaces_only_files_an_export_wrote(
    office: Office, tmp_path: Path, fmt: str
) -> None:
    """A re-export replaces its own files; a same-named file of someone else's stops the
    export before any file moves, and a file of another name stays."""
    out = tmp_path / "out"
    assert export(office, out, "--format", fmt).exit_code == 0
    assert export(office, out, "--format", fmt).exit_code == 0  # its own files: replaced
    (out / "notes.txt").write_text("mine\n")
    scene = open3d_file(out / f"scene.{fmt}")
    entries = (out / "entries.csv").read_bytes()
    before = scene.read_bytes()
    refused(export(office, out, "--format", fmt), f"scene.{fmt} exists", "nothing was written")
    assert scene.read_bytes() == before
    assert (out / "entries.csv").read_bytes() == entries  # nothing moved in
    assert (out / "notes.txt").read_text() == "mine\n"
    assert leftovers(out) == []
    assert leftovers(tmp_path) == []


def test_a_folder_export_keeps_a_csv_of_someone_elses(office: Office, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "entries.csv").write_text("a,b\n1,2\n")
    refused(export(office, out), "entries.csv exists")
    assert (out / "entries.csv").read_text() == "a,b\n1,2\n"


def test_an_entries_csv_of_an_export_before_hour_observed_is_still_aions(
    office: Office, tmp_path: Path
) -> None:
    """entries.csv now ends with ``hour_observed``; one an earlier aion exported (the same
    columns without it) is still an export's file, which ``--force`` may replace, while a CSV
    of someone else's with another last column is not."""
    from aion_cli.export_stale import is_export_file

    out = tmp_path / "out"
    assert export(office, out).exit_code == 0
    lines = (out / "entries.csv").read_text().splitlines()
    assert lines[0].endswith(",name,hour_observed")
    assert is_export_file(out / "entries.csv")
    older = tmp_path / "older" / "entries.csv"
    older.parent.mkdir()
    older.write_text("".join(line.rsplit(",", 1)[0] + "\n" for line in lines))
    assert older.read_text().splitlines()[0].endswith(",family,direction_family,name")
    assert is_export_file(older)
    assert export(office, older.parent, "--force").exit_code == 0  # replaced as aion's
    assert older.read_text().splitlines()[0].endswith(",name,hour_observed")
    other = tmp_path / "other" / "entries.csv"
    other.parent.mkdir()
    other.write_text(lines[0].replace(",hour_observed", ",notes") + "\n")
    assert not is_export_file(other)
    refused(export(office, other.parent, "--force"), "entries.csv exists")


def test_a_photo_at_a_png_target_is_never_replaced(office: Office, tmp_path: Path) -> None:
    from matplotlib.figure import Figure

    photo = tmp_path / "photo.png"
    Figure(figsize=(1, 1)).savefig(photo, format="png")  # a PNG aion did not draw
    before = photo.read_bytes()
    result = export(office, photo)
    assert result.exit_code == 2
    assert_one_error(result.stderr, "not a picture aion drew")
    assert photo.read_bytes() == before
    own = tmp_path / "own.png"
    assert export(office, own).exit_code == 0
    assert export(office, own).exit_code == 0  # a picture aion drew is replaced


# -- a failed write leaves nothing and says so -------------------------------------------------


def cut_off_open3d(monkeypatch: pytest.MonkeyPatch, keep: int) -> None:
    """open3d's writers as on a full disk: the file cut off after ``keep`` bytes, True
    returned (what open3d's PCD writer does when fwrite fails; PLY files are written by
    ``formats.ply_files``, whose writes raise)."""
    import open3d as o3d

    for name in ("write_point_cloud",):
        real = getattr(o3d.io, name)

        def cut(path: str, geometry: Any, *args: Any, _real: Any = real, **kw: Any) -> bool:
            _real(path, geometry, *args, **kw)
            with open(path, "r+b") as fh:
                fh.truncate(keep)
            return True

        monkeypatch.setattr(o3d.io, name, cut)


@pytest.mark.parametrize("keep", [0, 400])
@pytest.mark.parametrize("target", ["s.pcd", "out"])
def test_a_cut_off_scene_file_is_an_error_and_leaves_nothing(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, keep: int, target: str
) -> None:
    cut_off_open3d(monkeypatch, keep)
    out = tmp_path / target
    result = export(office, out, *(("--format", "pcd") if target == "out" else ()))
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "came out incomplete", f"nothing was written to {out}")
    assert sorted(os.listdir(tmp_path)) == []


def test_a_writer_returning_false_is_an_error(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import open3d as o3d

    monkeypatch.setattr(o3d.io, "write_point_cloud", lambda *a, **k: False)
    result = export(office, tmp_path / "s.pcd")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "cannot write")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("target", ["s.ply", "out"])
def test_a_full_disk_writing_a_ply_file_is_an_error_and_leaves_nothing(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, target: str
) -> None:
    """``formats.ply_files`` writes PLY files with Python's file functions: a write that
    fails as on a full disk, after part of a file is written, is one error naming the file
    and the output, exit 2, and nothing is left."""
    import errno

    import aion_cli.formats.ply_files as ply_files

    real = ply_files._write_vertices

    def full(fh: Any, *args: Any) -> None:
        real(fh, *args)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(ply_files, "_write_vertices", full)
    out = tmp_path / target
    result = export(office, out)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "cannot write", "No space left on device",
                     f"nothing was written to {out}")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("name", ["g.json", "g.sparkdsg"])
@pytest.mark.parametrize("keep", [0, 1000])
def test_a_cut_off_scene_graph_is_an_error_and_leaves_nothing(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, keep: int
) -> None:
    import spark_dsg

    real = spark_dsg.DynamicSceneGraph.save

    def save(self: Any, path: str, *args: Any, **kw: Any) -> None:
        real(self, path, *args, **kw)
        with open(path, "r+b") as fh:
            fh.truncate(keep)

    monkeypatch.setattr(spark_dsg.DynamicSceneGraph, "save", save)
    result = export(office, tmp_path / name)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, f"cannot write {tmp_path / name}", "came out incomplete")
    assert os.listdir(tmp_path) == []


def test_a_full_disk_writing_the_tables_is_exit_2_naming_the_output(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A write failing as on a full disk (ENOSPC while entries.json is written, naming no
    file): one error naming the output, exit 2 (the user's machine, not a bug), nothing
    left."""
    import errno

    import aion_cli.entry_text as entry_text

    real = entry_text.predict_json

    def full(*args: Any, **kw: Any) -> Any:
        chunks = real(*args, **kw)
        yield next(chunks)  # the head is written, then the disk is full
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(entry_text, "predict_json", full)
    out = tmp_path / "out"
    result = export(office, out)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "No space left on device", str(out))
    assert "free some disk space" in result.stderr
    assert os.listdir(tmp_path) == []


def test_exported_scene_files_are_marked_and_still_read(office: Office, tmp_path: Path) -> None:
    """The marker is a header comment readers skip: open3d reads the marked files whole."""
    import open3d as o3d

    from aion_cli.formats.scene_files import is_aion_scene_file

    out = tmp_path / "out"
    assert export(office, out).exit_code == 0
    assert export(office, tmp_path / "pcd", "--format", "pcd").exit_code == 0
    mesh = o3d.io.read_triangle_mesh(out / "scene.ply")
    cloud = o3d.io.read_point_cloud(tmp_path / "pcd" / "scene.pcd")
    assert len(mesh.vertices) > 0
    assert len(mesh.triangles) > 0
    assert len(cloud.points) > 0
    assert all(is_aion_scene_file(p) for p in out.glob("*.ply"))
    assert not is_aion_scene_file(open3d_file(tmp_path / "user.ply"))


# -- names that are not UTF-8 ------------------------------------------------------------------


@pytest.mark.parametrize("target", ["x.png", "x.json", "x.mcap", "out"])
def test_a_map_name_that_is_not_utf8_is_written_as_text(
    office: Office, tmp_path: Path, target: str
) -> None:
    named = tmp_path / os.fsdecode(b"map\xff.aion")
    shutil.copyfile(office.map, named)
    out = tmp_path / target
    result = run("export", named, "--time", AT, "-o", out)
    assert result.exit_code == 0, result.stderr
    if target == "x.json":
        import json

        doc = json.loads((out).read_text(encoding="utf-8"))
        assert doc["metadata"]["aion"]["map"] == "map\ufffd.aion"
    if target == "out":
        import json

        doc = json.loads((out / "entries.json").read_bytes().decode("utf-8"))
        assert doc["map"].endswith("map\ufffd.aion")


def test_safe_text_replaces_only_undecodable_bytes() -> None:
    from aion_cli.formats.outputs import safe_text

    assert safe_text(Path(os.fsdecode(b"a\xffb.aion"))) == "a\ufffdb.aion"
    assert safe_text(b"caf\xc3\xa9.aion") == "café.aion"
    assert safe_text("lone \ud800 surrogate") == "lone \ufffd surrogate"
    # both at once: the escaped byte is U+FFFD too (it had become "?")
    assert safe_text("a" + os.fsdecode(b"\xff") + "b \ud800") == "a\ufffdb \ufffd"
    assert safe_text(3) == "3"


def test_a_report_of_a_map_whose_name_is_not_utf8_is_written(
    office: Office, tmp_path: Path
) -> None:
    """Before: UnicodeEncodeError writing index.html (and matplotlib refused the title)."""
    named = tmp_path / os.fsdecode(b"map\xff.aion")
    shutil.copyfile(office.map, named)
    result = run("report", named, "-o", tmp_path / "rep")
    assert result.exit_code == 0, result.stderr
    page = (tmp_path / "rep" / "index.html").read_bytes().decode("utf-8")
    assert "map\ufffd.aion" in page
    again = run("report", named, "-o", tmp_path / "rep")  # its own page and pictures: replaced
    assert again.exit_code == 0, again.stderr


def test_a_report_replaces_its_own_pictures_never_someone_elses(
    office: Office, tmp_path: Path
) -> None:
    from matplotlib.figure import Figure

    out = tmp_path / "rep"
    out.mkdir()
    photo = out / "map.png"
    Figure(figsize=(1, 1)).savefig(photo, format="png")
    before = photo.read_bytes()
    refused(run("report", office.map, "-o", out), "map.png exists", "nothing was written")
    assert photo.read_bytes() == before
    assert sorted(p.name for p in out.iterdir()) == ["map.png"]
    photo.unlink()
    assert run("report", office.map, "-o", out).exit_code == 0
    again = run("report", office.map, "-o", out)  # its own page and pictures: replaced
    assert again.exit_code == 0, again.stderr


def test_a_foreign_file_is_refused_before_anything_is_computed(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A file of someone else's under a name the export or the report writes (in the folder,
    or in a series' frame folder) refuses the command before a frame is computed or a
    picture drawn: a 1,000-frame series was computed, then thrown away."""
    import aion_cli.exports
    import aion_cli.report.writer

    def computed(*_: Any, **__: Any) -> Any:
        raise AssertionError("computed before the refusal")

    monkeypatch.setattr(aion_cli.exports, "_export_one", computed)
    monkeypatch.setattr(aion_cli.report.writer, "gather", computed)
    out = tmp_path / "out"
    out.mkdir()
    (out / "cells.ply").write_text("a scan of mine\n")
    refused(export(office, out), "cells.ply exists", "nothing was written")
    frame = out / "20261123T083000Z"
    frame.mkdir()
    (frame / "entries.json").write_text('{"mine": 1}')
    (out / "cells.ply").unlink()
    refused(
        run("export", office.map, "-o", out, "--from", "2026-11-23 08:00", "--to",
            "2026-11-23 09:00", "--step", "30m", "--tz", "UTC"),
        "20261123T083000Z/entries.json exists",
    )
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "index.html").write_text("<p>my page</p>")
    refused(run("report", office.map, "-o", rep), "index.html exists", "nothing was written")
    assert (rep / "index.html").read_text() == "<p>my page</p>"


def test_a_dangling_link_as_the_folder_is_refused_before_anything_is_computed(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``-o out`` where ``out`` is a symbolic link to a folder that does not exist: the
    export computed every frame, then said ``error: Not a directory: .../out`` (and the
    report likewise); now both say what ``out`` is before computing anything, and leave the
    link and its folder as they were."""
    import aion_cli.exports
    import aion_cli.report.writer

    def computed(*_: Any, **__: Any) -> Any:
        raise AssertionError("computed before the refusal")

    monkeypatch.setattr(aion_cli.exports, "_export_one", computed)
    monkeypatch.setattr(aion_cli.report.writer, "gather", computed)
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "gone")
    for result in (
        export(office, link),
        export(office, link, "--format", "pcd"),
        run("report", office.map, "-o", link),
    ):
        assert result.exit_code == 2, result.stderr
        assert_one_error(result.stderr, f"{link} is a dangling symbolic link", "not a folder")
    assert os.readlink(link) == str(tmp_path / "gone")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
