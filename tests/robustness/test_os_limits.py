"""The machine's limits are the user's to fix, said in one line (exit 2), and leave nothing
behind: a full disk, a name or path too long for the file system, a lock whose pid could not
be written. Hidden staging and lock names of a legal 255-byte target stay legal.
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path
from typing import Any

import pytest

from tests.robustness.conftest import (
    Office,
    assert_one_error,
    build_json,
    fails,
    run,
    walk,
    write_log,
)

AT = "2026-11-23 08:30"


# -- names and paths too long --------------------------------------------------------------------


def long_path(tmp_path: Path, suffix: str) -> Path:
    """A path of ~5000 bytes (25 names of 200 bytes): over PATH_MAX."""
    return tmp_path.joinpath(*["x" * 200] * 25).with_suffix(suffix)


@pytest.mark.parametrize(
    "args",
    [
        ("info", "{long}.mcap"),
        ("predict", "{long}.aion", "--time", AT),
        ("build", "{log}", "-o", "{long}.aion"),
        ("info", "{name}.mcap"),
        ("predict", "{name}.aion", "--time", AT),
        ("build", "{log}", "-o", "{name}.aion"),
    ],
)
def test_a_name_or_path_too_long_is_one_error_exit_2(
    office: Office, tmp_path: Path, args: tuple[str, ...]
) -> None:
    """Before: a path over 4096 bytes printed a traceback (the error handler itself failed
    looking for a file in the way); a 300-byte name exited 1 as an internal fault."""
    long = str(long_path(tmp_path, ""))
    name = str(tmp_path / ("y" * 300))
    argv = [a.format(long=long, name=name, log=office.log) for a in args]
    result = run(*argv)
    fails(result, "File name too long")
    assert "use a shorter path" in result.stderr
    assert len(result.stderr) < 1000  # the path is shortened in the message


def test_the_error_handler_survives_a_path_too_long() -> None:
    from aion_cli.cli.errors import _file_in_the_way, report

    path = "/".join(["x" * 200] * 25)
    assert _file_in_the_way(path) is None
    assert report(OSError(errno.ENAMETOOLONG, "File name too long", path), False) == 2


@pytest.mark.parametrize("code", [errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG])
def test_the_machines_limits_are_exit_2(
    code: int, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: "No space left on device / rerun with --debug", exit 1, as if aion were at
    fault (build alone said it plainly)."""
    from aion_cli.cli.errors import report

    assert report(OSError(code, os.strerror(code), "out/x.csv"), False) == 2
    err = capsys.readouterr().err
    assert_one_error(err, os.strerror(code), "out/x.csv")
    assert "--debug" not in err


def test_a_staging_path_is_shown_as_the_output() -> None:
    from aion_cli.cli.errors import _shown_path

    assert _shown_path("tiny/.out.ab12cd34.tmp/out/entries.csv") == "tiny/out/entries.csv"
    assert _shown_path("tiny/.g.json.ab12cd34.tmp") == "tiny/g.json"
    assert _shown_path("out/.map.aion.4242.tmp") == "out/map.aion"  # the API's save
    # a folder of the user's that only looks like one is shown as it is
    assert _shown_path("/home/u/.cache.d.tmp/data/x.mcap") == "/home/u/.cache.d.tmp/data/x.mcap"


# -- a legal 255-byte name can be written ----------------------------------------------------------


def test_hidden_and_lock_names_of_a_long_target_fit(tmp_path: Path) -> None:
    from aion_cli.formats.mapfile import lock_path
    from aion_cli.formats.outputs import NAME_MAX, Staged, fitted_name, staging_prefix

    a, b = "a" * 250 + "1.aion", "a" * 250 + "2.aion"
    for name in (a, b, "é" * 127):
        assert len(os.fsencode(lock_path(tmp_path / name).name)) <= NAME_MAX
        assert len(os.fsencode(staging_prefix(name))) + 8 + len(".tmp") <= NAME_MAX
    assert lock_path(tmp_path / a) != lock_path(tmp_path / b)  # the hash tells them apart
    assert lock_path(tmp_path / a).name.startswith("a" * 200)  # recognisably the target's
    assert fitted_name("office.aion", 5) == "office.aion"  # short names are left alone
    staged = Staged(tmp_path / ("b" * 255))
    try:
        assert staged.folder.name.startswith(".bbbb")
        assert staged.folder.name.endswith(".tmp")
    finally:
        staged.discard()


def test_a_map_with_a_255_byte_name_is_built_and_continued(
    office: Office, tmp_path: Path
) -> None:
    """Before: "cannot create lock file ... check write permissions" (the .lock name was 260
    bytes)."""
    target = tmp_path / ("a" * 250 + ".aion")
    assert len(target.name) == 255
    result = run("build", office.log, "-o", target)
    assert result.exit_code == 0, result.stderr
    assert sorted(os.listdir(tmp_path)) == [target.name]  # no lock, no temporary file left
    assert run("compact", target, "-o", tmp_path / ("c" * 250 + ".aion")).exit_code == 0


@pytest.mark.parametrize("suffix", [".ply", ".pcd", ".json", ".mcap", ".png", ""])
def test_an_export_with_a_long_name_is_written(
    office: Office, tmp_path: Path, suffix: str
) -> None:
    """Before: exit 1 "File name too long": the hidden ``.<name>.<random>.tmp`` was over 255
    bytes."""
    out = tmp_path / ("b" * (250 - len(suffix)) + suffix)
    result = run("export", office.map, "--time", AT, "-o", out)
    assert result.exit_code == 0, result.stderr
    assert out.exists()
    assert [p.name for p in tmp_path.iterdir()] == [out.name]


def test_a_report_and_a_log_with_long_names_are_written(office: Office, tmp_path: Path) -> None:
    report = tmp_path / ("r" * 245)
    assert run("report", office.map, "-o", report).exit_code == 0
    assert (report / "index.html").is_file()
    csv = tmp_path / "tracks.csv"
    csv.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n1795420800000000000,1,0,0,0,0,1\n")
    out = tmp_path / ("t" * 245 + ".mcap")
    result = run("convert", csv, "-o", out)
    assert result.exit_code == 0, result.stderr
    assert out.is_file()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


# -- a lock whose pid could not be written -------------------------------------------------------


def test_a_lock_that_could_not_be_written_is_removed(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before: an empty ``c.aion.lock`` stayed, and the retry said "being written by another
    process (unknown)"."""
    from aion_cli.formats import mapfile_target

    def full(fd: int, *args: Any, **kw: Any) -> Any:
        os.close(fd)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    target = tmp_path / "c.aion"
    with monkeypatch.context() as patch:
        patch.setattr(mapfile_target.os, "fdopen", full)
        result = run("compact", office.map, "-o", target)
    fails(result, f"cannot write map {target}", "No space left on device")
    assert "free some disk space" in result.stderr
    assert ".lock" not in result.stderr
    assert os.listdir(tmp_path) == []
    again = run("compact", office.map, "-o", target)
    assert again.exit_code == 0, again.stderr


# -- messages ------------------------------------------------------------------------------


@pytest.mark.parametrize("what", ["log", "damaged"])
def test_a_map_option_that_is_not_a_map_says_so(
    office: Office, tmp_path: Path, what: str
) -> None:
    """``build LOG --map X`` without -o writes X: before, X was judged as the output first
    ("cannot write map X: it exists and is not an aion map")."""
    given = tmp_path / ("o3.mcap" if what == "log" else "damaged.aion")
    if what == "log":
        shutil.copyfile(office.log, given)
    else:
        given.write_bytes(office.map.read_bytes()[:20_000])
    before = given.read_bytes()
    result = run("build", office.log, "--map", given)
    fails(result, f"{given.name} is not a readable aion map")
    assert "cannot write map" not in result.stderr
    assert given.read_bytes() == before


def test_an_older_log_names_the_map_being_continued(tmp_path: Path) -> None:
    old = write_log(tmp_path / "old.mcap", walk(1200))
    new = write_log(tmp_path / "new.mcap", walk(1200, start_s=7200))
    build_json(new, "-o", tmp_path / "m2.aion")
    result = run("build", old, "--map", tmp_path / "m2.aion", "-o", tmp_path / "m3.aion")
    fails(result, "but m2.aion has already closed every window")
    assert not (tmp_path / "m3.aion").exists()


def test_a_json_error_reads_once_at(tmp_path: Path) -> None:
    bad = tmp_path / "g.json"
    bad.write_text('{"nodes": "abc')
    result = run("info", bad)
    fails(result, "Unterminated string starting at line 1 column 11")
    assert "at at" not in result.stderr


# -- a full disk under SQLite ---------------------------------------------------------------------


def test_a_full_disk_under_a_rosbag2_sqlite3_log_is_exit_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before: ``convert ... -o full/bag`` (rosbag2, sqlite3 storage) on a full disk said
    ``internal error: OperationalError: database or disk is full``, exit 1."""
    import sqlite3

    from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer

    def full(*args: Any, **kw: Any) -> None:
        raise sqlite3.OperationalError("database or disk is full")

    tracks = Path(__file__).parents[1] / "data" / "atc" / "atc-1024-9_test.csv"
    out = tmp_path / "out"
    out.mkdir()
    with monkeypatch.context() as patch:
        patch.setattr(Sqlite3Writer, "write", full)
        result = run(
            "convert",
            tracks,
            "--layout",
            "atc",
            "-o",
            out / "bag",
            "--container",
            "rosbag2-sqlite3",
        )
    fails(result, "No space left on device", "out/bag")
    assert "free some disk space" in result.stderr
    assert os.listdir(out) == []
