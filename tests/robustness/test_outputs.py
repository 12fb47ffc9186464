"""Outputs never lose data: ``--force`` replaces only what aion wrote, special files and the
current folder are refused before anything is written, and an interrupted write leaves the
previous output as it was (``formats/outputs.py``, ``LogWriter``, ``write_map``, ``simulate``,
``export``).

Each test puts something valuable where an output goes (the input CSV, a folder of other
files, a device, a FIFO, a previous log) and checks it byte for byte afterwards. Interrupted
writes and log times out of range: ``test_interrupted_writes.py``.
"""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.robustness.conftest import (
    T0,
    Office,
    S,
    assert_one_error,
    run,
    walk,
    write_log,
)

CSV_HEADER = "t_ns,track_id,x,y,z,heading_rad,speed_mps"


def tracks_csv(path: Path, n: int = 20, t0: int = T0) -> Path:
    """A canonical tracks CSV: one person walking +x at 1 m/s, 1 Hz, from ``t0``."""
    rows = [f"{t0 + k * S},1,{0.1 * k:.2f},0.0,0.0,0.0,1.0" for k in range(n)]
    path.write_text("\n".join([CSV_HEADER, *rows]) + "\n")
    return path


def digest(path: Path) -> str:
    """sha256 of a file, or of a folder's names and file contents (recursively)."""
    h = hashlib.sha256()
    if path.is_dir():
        for p in sorted(path.rglob("*")):
            h.update(str(p.relative_to(path)).encode())
            if p.is_file():
                h.update(p.read_bytes())
    else:
        h.update(path.read_bytes())
    return h.hexdigest()


def hidden(folder: Path) -> list[str]:
    """Staging folders / temporary files aion would leave behind (names start with '.'; not
    the manifest of the files exports wrote there, ``export_stale.MANIFEST``)."""
    from aion_cli.export_stale import MANIFEST

    return sorted(p.name for p in folder.iterdir() if p.name.startswith(".") and p.name != MANIFEST)


def message_count(path: Path) -> int:
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        return sum(1 for _ in reader.messages())


# -- convert ----------------------------------------------------------------------------------


def test_convert_force_never_deletes_a_folder_holding_the_input(tmp_path: Path) -> None:
    folder = tmp_path / "data"
    folder.mkdir()
    csv = tracks_csv(folder / "tracks.csv")
    (folder / "notes.txt").write_text("field notes\n")
    before = digest(folder)
    result = run("convert", csv, "-o", folder, "--force")
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "data exists and is a folder holding 2 item(s)", "tracks.csv")
    assert "replaces only aion's own outputs" in result.stderr
    assert digest(folder) == before  # the CSV and the notes survive, nothing added
    assert hidden(tmp_path) == []


def test_convert_force_never_replaces_a_recorded_mcap(tmp_path: Path) -> None:
    """An MCAP log a robot recorded (its header names another library) is not aion's to
    replace, --force or not; one aion wrote is."""
    from mcap.writer import Writer

    recorded = tmp_path / "robot.mcap"
    with recorded.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="rosbag2 jazzy")
        writer.finish()
    before = recorded.read_bytes()
    csv = tracks_csv(tmp_path / "tracks.csv")
    result = run("convert", csv, "-o", recorded, "--force")
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "not an MCAP log aion wrote")
    assert recorded.read_bytes() == before
    ours = tmp_path / "ours.mcap"
    assert run("convert", csv, "-o", ours).exit_code == 0
    assert run("convert", csv, "-o", ours, "--force").exit_code == 0


def test_convert_force_replaces_a_rosbag2_folder_it_wrote(tmp_path: Path) -> None:
    out = tmp_path / "bag"
    out.mkdir()  # an empty folder holds nothing to lose: --force may use it
    assert run("convert", tracks_csv(tmp_path / "a.csv", n=5), "-o", out).exit_code == 2
    assert run("convert", tmp_path / "a.csv", "-o", out, "--force").exit_code == 0
    assert message_count(out) == 5
    result = run("convert", tracks_csv(tmp_path / "b.csv", n=12), "-o", out, "--force")
    assert result.exit_code == 0, result.stderr
    assert message_count(out) == 12  # the new log, complete
    assert sorted(p.name for p in out.iterdir()) == ["bag.db3", "metadata.yaml"]
    assert hidden(tmp_path) == []
    # one foreign file inside makes it a folder aion did not write: refused, nothing lost
    (out / "calibration.yaml").write_text("k: 1\n")
    before = digest(out)
    result = run("convert", tmp_path / "a.csv", "-o", out, "--force")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "calibration.yaml", "not a rosbag2 folder aion wrote")
    assert digest(out) == before


def test_convert_force_replaces_only_a_log_of_its_own_kind(tmp_path: Path) -> None:
    csv = tracks_csv(tmp_path / "t.csv", n=4)
    target = tmp_path / "out.mcap"
    target.write_text("my thesis, chapter 3\n")
    result = run("convert", csv, "-o", target, "--force")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "out.mcap exists and is another file", "not an MCAP log")
    assert target.read_text() == "my thesis, chapter 3\n"
    # the CSV itself as the output: refused, intact
    before = csv.read_bytes()
    result = run("convert", csv, "-o", csv, "--container", "mcap", "--force")
    assert result.exit_code == 2
    assert csv.read_bytes() == before
    # an MCAP log aion wrote is replaced by the new one
    target.unlink()
    assert run("convert", csv, "-o", target).exit_code == 0
    again = run("convert", tracks_csv(tmp_path / "u.csv", n=9), "-o", target, "--force")
    assert again.exit_code == 0, again.stderr
    assert message_count(target) == 9


@pytest.mark.parametrize("command", ["convert", "simulate", "simulate-mcap"])
def test_the_current_folder_is_refused(
    command: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    csv = tracks_csv(tmp_path / "t.csv")
    (tmp_path / "keep.txt").write_text("keep\n")
    monkeypatch.chdir(tmp_path)
    before = digest(tmp_path)
    if command == "convert":
        args: tuple[Any, ...] = ("convert", csv, "-o", ".", "--force")
    elif command == "simulate":
        args = ("simulate", "-o", ".", "--format", "rosbag2", "--days", "0.01", "--quiet",
                "--force")  # fmt: skip
    else:  # one scene into an MCAP file, whose name ".mcap" would be appended to "."
        args = ("simulate", "-o", ".", "--days", "0.01", "--quiet")
    result = run(*args)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "is the current folder")
    assert digest(tmp_path) == before


def _special_targets(tmp_path: Path) -> list[Path]:
    fifo = tmp_path / "pipe.mcap"
    os.mkfifo(fifo)
    return [Path("/dev/null"), fifo]


@pytest.mark.parametrize("force", [False, True])
def test_devices_and_fifos_are_refused_before_writing(tmp_path: Path, force: bool) -> None:
    """``/dev/null`` and a FIFO, as the output of convert, simulate, build and export: exit 2
    in one line; the device is still a device, the FIFO still a FIFO (nothing opened it for
    writing, which would block), and no lock or staging file appears beside them."""
    csv = tracks_csv(tmp_path / "t.csv")
    log = write_log(tmp_path / "w.mcap", walk(20))
    extra = ("--force",) if force else ()
    for target in _special_targets(tmp_path):
        mode = os.stat(target).st_mode
        cases: list[tuple[Any, ...]] = [
            ("convert", csv, "-o", target, "--container", "mcap", *extra),
            ("simulate", "-o", target, "--days", "0.01", "--quiet", *extra),
            ("build", log, "-o", target),
        ]
        for args in cases:
            result = run(*args)
            assert result.exit_code == 2, (args, result.stderr)
            assert_one_error(result.stderr)
            assert any(word in result.stderr for word in ("device", "FIFO")), result.stderr
            assert os.stat(target).st_mode == mode
        assert not Path(f"{target}.lock").exists()
        assert not Path(f"{target}.mcap").exists()  # simulate appends the suffix: refused too
    assert hidden(tmp_path) == []


def test_export_and_plan_export_refuse_special_files(office: Office, tmp_path: Path) -> None:
    fifo = tmp_path / "scene.ply"
    os.mkfifo(fifo)
    result = run("export", office.map, "--historical", "-o", "/dev/null")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "/dev/null is a character device, not a folder")
    result = run("plan", office.map, "--from", "p1", "--to", "p2", "--export", fifo)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "FIFO")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


# -- maps -------------------------------------------------------------------------------------


def test_build_output_must_be_a_map_or_new(office: Office, tmp_path: Path) -> None:
    log = write_log(tmp_path / "w.mcap", walk(20))
    notes = tmp_path / "notes.txt"
    notes.write_text("do not lose me\n")
    result = run("build", log, "-o", notes)
    assert result.exit_code == 2
    assert_one_error(result.stderr, "exists and is not an aion map")
    assert notes.read_text() == "do not lose me\n"
    folder = tmp_path / "out"
    folder.mkdir()
    result = run("build", log, "-o", folder)
    assert result.exit_code == 2
    assert_one_error(result.stderr, "is a folder, not a file: name a file in it")  # -o's check
    # a folder named as a map is: the file suggested in it is a map's (maps.aion/NAME had no
    # .aion), or the map is to be named otherwise
    maps = tmp_path / "maps.aion"
    maps.mkdir()
    result = run("build", log, "-o", maps)
    assert result.exit_code == 2
    assert_one_error(result.stderr, f"(e.g. {maps / 'map.aion'}) or another name for the file")
    assert list(maps.iterdir()) == []
    # an existing map is replaced (the build says so)
    target = office.copy_map(tmp_path / "m.aion")
    result = run("build", log, "-o", target)
    assert result.exit_code == 0, result.stderr
    assert "existed and is replaced" in result.stderr
    assert hidden(tmp_path) == []


def test_a_map_named_as_another_kind_of_file_is_refused(office: Office, tmp_path: Path) -> None:
    """``aion build LOG -o x.png`` wrote a map (a zip) named as a picture, without a word;
    ``aion merge ... -o x.json`` likewise. Now exit 2 with the name a map takes, nothing
    written; a name of no known kind (``.map``) is still the user's choice."""
    from aion_cli.formats.mapfile import is_aion_map

    log = write_log(tmp_path / "w.mcap", walk(20))
    for name in ("x.png", "x.json", "x.CSV", "x.mcap"):
        result = run("build", log, "-o", tmp_path / name)
        assert result.exit_code == 2, result.stderr
        assert_one_error(result.stderr, f"cannot write map {tmp_path / name}")
        assert f"hint: name it {Path(name).stem}.aion" in result.stderr
        assert not (tmp_path / name).exists()
    one, two = office.copy_map(tmp_path / "a.aion"), office.copy_map(tmp_path / "b.aion")
    result = run("merge", one, two, "-o", tmp_path / "m.json")
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "cannot write map", "m.json")
    assert not (tmp_path / "m.json").exists()
    result = run("build", log, "-o", tmp_path / "x.map")
    assert result.exit_code == 0, result.stderr
    assert is_aion_map(tmp_path / "x.map")


def test_write_map_refuses_special_and_foreign_targets(tmp_path: Path) -> None:
    from aion_cli.formats.mapfile import MapWriteError, is_aion_map, read_map, write_map

    arrays = {"a": np.arange(4)}
    with pytest.raises(MapWriteError, match="character device"):
        write_map("/dev/null", arrays, {})
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert not Path("/dev/null.lock").exists()
    fifo = tmp_path / "f.aion"
    os.mkfifo(fifo)
    with pytest.raises(MapWriteError, match="FIFO"):
        write_map(fifo, arrays, {})
    csv = tracks_csv(tmp_path / "t.csv")
    before = csv.read_bytes()
    with pytest.raises(MapWriteError, match="not an aion map"):
        write_map(csv, arrays, {})
    assert csv.read_bytes() == before
    empty = tmp_path / "empty.aion"
    empty.touch()  # nothing to lose
    write_map(empty, arrays, {})
    assert is_aion_map(empty)
    write_map(empty, {"a": np.arange(7)}, {})  # a map replaces a map
    np.testing.assert_array_equal(read_map(empty)[0]["a"], np.arange(7))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.aion", "f.aion", "t.csv"]


# -- export -----------------------------------------------------------------------------------


def test_a_failing_export_leaves_no_partial_folder(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import aion_cli.exports as export

    real = export._export_one
    calls = {"n": 0}

    def second_fails(*a: Any, **k: Any) -> Any:
        calls["n"] += 1
        if calls["n"] == 2:
            raise OSError(28, "No space left on device")
        return real(*a, **k)

    monkeypatch.setattr(export, "_export_one", second_fails)
    out = tmp_path / "series"
    args = ("export", office.map, "--from", "2026-11-23 08:00", "--to", "2026-11-23 10:00",
            "--step", "1h")  # fmt: skip
    result = run(*args, "-o", out)
    assert result.exit_code == 2  # a full disk is the machine's to fix, as build says too
    assert_one_error(result.stderr, "No space left on device")
    assert "free some disk space" in result.stderr
    assert not out.exists()  # not even the first frame
    # into an existing folder: its files stay as they were, nothing half-written is added
    out.mkdir()
    (out / "readme.txt").write_text("mine\n")
    calls["n"] = 0
    assert run(*args, "-o", out).exit_code == 2
    assert sorted(p.name for p in out.iterdir()) == ["readme.txt"]
    monkeypatch.undo()
    result = run(*args, "-o", out)
    assert result.exit_code == 0, result.stderr
    frames = sorted(p.name for p in out.iterdir() if p.name != ".aion-export.json")
    assert frames == ["20261123T080000Z", "20261123T090000Z", "20261123T100000Z", "readme.txt"]
    assert (out / "readme.txt").read_text() == "mine\n"
    assert hidden(out) == []
    assert hidden(tmp_path) == []


def test_export_into_the_current_folder_still_works(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "keep.txt").write_text("keep\n")
    monkeypatch.chdir(tmp_path)
    result = run("export", office.map, "--historical", "-o", ".")
    assert result.exit_code == 0, result.stderr
    names = sorted(p.name for p in tmp_path.iterdir())
    assert {"entries.csv", "scene.ply", "keep.txt"} <= set(names)
    assert hidden(tmp_path) == []



def test_only_a_folder_exactly_as_aion_writes_it_counts_as_its_rosbag2(tmp_path: Path) -> None:
    from aion_cli.formats.writers import is_own_log, is_own_rosbag2

    bag = write_log(tmp_path / "bag", walk(3), "rosbag2-mcap")
    assert is_own_rosbag2(bag)
    assert is_own_log(bag, "rosbag2-sqlite3")  # either storage: it is a bag aion wrote
    assert not is_own_log(bag, "mcap")  # a folder is not an MCAP file
    meta = (bag / "metadata.yaml").read_text()
    cases = {
        "subfolder": lambda d: (d / "photos").mkdir(),
        "symlink": lambda d: (d / "link").symlink_to(tmp_path),
        "other file": lambda d: (d / "notes.txt").write_text("x"),
        "no metadata": lambda d: (d / "metadata.yaml").unlink(),
        "garbage metadata": lambda d: (d / "metadata.yaml").write_text("{{{ not yaml"),
        "path in metadata": lambda d: (d / "metadata.yaml").write_text(
            meta.replace("- bag.mcap", "- ../bag.mcap")
        ),
        "metadata is a link": lambda d: (
            (d / "metadata.yaml").unlink(),
            (d / "metadata.yaml").symlink_to(tmp_path / "m.yaml"),
        ),
    }
    (tmp_path / "m.yaml").write_text(meta)
    for name, damage in cases.items():
        copy = tmp_path / name.replace(" ", "_")
        copy.mkdir()
        for p in bag.iterdir():
            (copy / p.name).write_bytes(p.read_bytes())
        assert is_own_rosbag2(copy)
        damage(copy)
        assert not is_own_rosbag2(copy), name


def test_a_file_where_a_folder_should_be_is_named(office: Office, tmp_path: Path) -> None:
    """``-o afile/x`` where ``afile`` is a file: the file is named as not a folder (it said
    "File exists: afile"), and an unwritable output is named as given, never by its hidden
    temporary name."""
    blocker = tmp_path / "afile"
    blocker.write_text("keep\n")
    for args in (
        ("export", office.map, "--historical", "-o", blocker / "scene"),
        ("report", office.map, "-o", blocker / "report"),
        ("plan", office.map, "--from", "p1", "--to", "p2", "--export", blocker / "x.ply"),
    ):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_error(result.stderr, f"{blocker} is a file, not a folder")
    assert blocker.read_text() == "keep\n"
    result = run("export", office.map, "--historical", "-o", "/proc/aion-test.ply")
    assert result.exit_code == 2, result.stderr
    assert ".tmp" not in result.stderr
    assert "/proc/aion-test.ply" in result.stderr
