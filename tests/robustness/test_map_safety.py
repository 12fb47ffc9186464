"""Map safety end to end: interrupted and failed builds leave the previous map intact, a lock
keeps two writers apart, checksums catch corruption, and loading a map never executes code or
trusts oversized, path-traversing or invalid content.

``formats/mapfile.py`` has unit tests for the container; these go through ``aion build`` /
``aion predict`` (subprocesses for signals) and ``aion_cli.mapquery.load_map``.
"""

from __future__ import annotations

import errno
import io
import os
import random
import signal
import subprocess
import time
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.formats.map_damage import declare_member
from tests.robustness.conftest import (
    AION,
    T0,
    TRACKED,
    Message,
    Office,
    S,
    aion_env,
    assert_one_error,
    map_arrays,
    rewrite_map,
    run,
    run_process,
    stamp,
    walk,
    write_log,
)


def crowd(k: int) -> Message:
    """Message ``k``: eight people on a 40 x 50 m grid of 4000 cells (~8 KB per cell), from
    T0 + 1200 s on (after the office log's windows: logs join a map in time order)."""
    t = T0 + (1200 + k) * S
    tracks = []
    for j in range(8):
        c = (k * 8 + j) % 4000
        x, y = 0.5 * (c % 80), 0.5 * (c // 80)
        tracks.append(
            {
                "track_id": j,
                "is_matched": True,
                "pose": {
                    "pose": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": {"w": 1.0}}
                },
                "twist": {"twist": {"linear": {"x": 1.0}}},
            }
        )
    return (
        "/tracks",
        TRACKED,
        {"header": {"stamp": stamp(t), "frame_id": "map"}, "tracks": tracks},
        t,
    )


@pytest.fixture(scope="module")
def crowd_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A log whose map takes a while to write (many cells)."""
    return write_log(
        tmp_path_factory.mktemp("crowd") / "crowd.mcap", [crowd(k) for k in range(1000)]
    )


def leftovers(folder: Path, name: str) -> list[str]:
    """Temporary files and locks of map ``name`` in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if p.name != name and name in p.name)


def interrupt_build(
    log: Path, target: Path, sig: int, when: str, rng: random.Random, nohup: bool = False
) -> tuple[int, str]:
    """Start ``aion build LOG -o TARGET`` and send ``sig``: at a random moment, or as soon as
    the temporary map file appears (``when="writing"``). Returns the exit code and stderr.
    ``nohup``: the build starts with SIGHUP ignored, as ``nohup aion build ...`` starts it."""
    proc = subprocess.Popen(
        [str(AION), "build", str(log), "-o", str(target), "-q"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=aion_env(),
        preexec_fn=(lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN)) if nohup else None,
    )
    try:
        if when == "writing":
            deadline = time.monotonic() + 120
            while proc.poll() is None and time.monotonic() < deadline:
                if any(p.name.startswith(f".{target.name}.") for p in target.parent.iterdir()):
                    break
                time.sleep(0.002)
        else:
            time.sleep(rng.uniform(0.3, 4.0))
        if proc.poll() is None:
            proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    code = proc.returncode
    if code == 130:
        assert_one_error(err, "interrupted")
    return code, err


@pytest.mark.parametrize(
    ("sig", "when"),
    [
        (signal.SIGINT, "writing"),
        (signal.SIGTERM, "writing"),
        (signal.SIGINT, "random"),
        (signal.SIGTERM, "random"),
        # the terminal or ssh session closed: its default action killed the build and left
        # the lock and the temporary map behind
        (signal.SIGHUP, "writing"),
        (signal.SIGHUP, "random"),
    ],
)
def test_interrupted_build_leaves_the_old_map_or_a_complete_new_one(
    sig: int, when: str, crowd_log: Path, office: Office, tmp_path: Path
) -> None:
    target = office.copy_map(tmp_path / "existing.aion")
    old = target.read_bytes()
    code, err = interrupt_build(crowd_log, target, sig, when, random.Random(f"{sig}{when}"))
    arrays = map_arrays(target)  # loads, every checksum verified
    if target.read_bytes() == old:
        assert code != 0, err
    else:  # the signal came after the rename: the new map is complete (the process may still
        # have been killed on its way out, after the map was in place)
        assert code in (0, 130, -sig), err
        assert len(arrays["entry_key"]) > len(map_arrays(office.map)["entry_key"])
    # Ctrl-C and SIGTERM unwind: no temporary file, no lock left (a SIGTERM during start-up,
    # before any file exists, is the default kill)
    assert leftovers(tmp_path, "existing.aion") == []
    if when == "writing":
        assert code in (0, 130), err  # stderr names the fault when it is not an interrupt


def test_a_build_under_nohup_goes_on_after_a_hangup(
    crowd_log: Path, office: Office, tmp_path: Path
) -> None:
    """SIGHUP unwinds a build like Ctrl-C, but not one started with it ignored (``nohup``):
    that build finishes its map."""
    target = office.copy_map(tmp_path / "existing.aion")
    code, err = interrupt_build(
        crowd_log, target, signal.SIGHUP, "writing", random.Random(0), nohup=True
    )
    assert code == 0, err
    assert len(map_arrays(target)["entry_key"]) > len(map_arrays(office.map)["entry_key"])
    assert leftovers(tmp_path, "existing.aion") == []

def test_a_build_after_a_killed_one_recovers_its_stale_lock(office: Office, tmp_path: Path) -> None:
    """A build killed with SIGKILL (no cleanup possible) leaves its lock; the next build sees
    the lock's process is gone and proceeds."""
    target = office.copy_map(tmp_path / "m.aion")
    dead = subprocess.Popen(["true"])
    dead.wait()
    import socket

    target.with_name("m.aion.lock").write_text(f"{dead.pid} {socket.gethostname()}\n")
    log = write_log(tmp_path / "w.mcap", walk(30))
    result = run("build", log, "-o", target)
    assert result.exit_code == 0, result.stderr
    assert leftovers(tmp_path, "m.aion") == []


@pytest.mark.parametrize("err", [errno.ENOSPC, errno.EIO, errno.EDQUOT])
def test_write_failure_mid_map_leaves_the_old_map(
    err: int, office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The disk fills up while the map is written: one error line (exit 2), the previous map
    byte for byte, no temporary file or lock left."""
    from aion_cli.formats import mapfile_write

    target = office.copy_map(tmp_path / "m.aion")
    old = target.read_bytes()
    written = {"n": 0}
    real_write = mapfile_write._HashingWriter.write

    def failing_write(self: Any, data: Any) -> int:
        written["n"] += len(data)
        if written["n"] > 4_000:
            raise OSError(err, os.strerror(err))
        return real_write(self, data)

    monkeypatch.setattr(mapfile_write._HashingWriter, "write", failing_write)
    log = write_log(tmp_path / "w.mcap", walk(30))
    result = run("build", log, "-o", target)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "cannot write map", os.strerror(err))
    assert "unchanged" in result.stderr
    assert written["n"] > 4_000  # the failure happened mid-write
    assert target.read_bytes() == old
    assert leftovers(tmp_path, "m.aion") == []


def test_failing_rename_leaves_the_old_map(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = office.copy_map(tmp_path / "m.aion")
    old = target.read_bytes()

    def no_rename(src: Any, dst: Any) -> None:
        raise PermissionError(errno.EPERM, "Operation not permitted", str(dst))

    log = write_log(tmp_path / "w.mcap", walk(30))  # before os.replace fails for everyone
    monkeypatch.setattr("aion_cli.formats.mapfile_write.os.replace", no_rename)
    result = run("build", log, "-o", target)
    assert result.exit_code == 2
    assert_one_error(result.stderr, "cannot write map")
    assert target.read_bytes() == old
    assert leftovers(tmp_path, "m.aion") == []


def test_a_held_lock_stops_a_second_build(office: Office, tmp_path: Path) -> None:
    """While this process holds the map's lock (as a build writing it would), a build in a
    subprocess refuses with one error line and leaves the map alone."""
    from aion_cli.formats.mapfile import map_lock

    target = office.copy_map(tmp_path / "m.aion")
    old = target.read_bytes()
    log = write_log(tmp_path / "w.mcap", walk(30))
    with map_lock(target):
        proc = run_process("build", log, "-o", target)
    assert proc.returncode == 2, proc.stderr
    assert_one_error(proc.stderr, "being written by another process", str(os.getpid()))
    assert target.read_bytes() == old
    assert leftovers(tmp_path, "m.aion") == []  # ours is released, theirs never taken


def test_two_builds_extending_one_map_never_lose_a_log(
    crowd_log: Path, office: Office, tmp_path: Path
) -> None:
    """Build A (a long log) extends the map in a subprocess; build B starts meanwhile: B is
    refused (it would have started from the old map and its write, or A's, would silently
    drop the other's log). Once A is done, B runs and the map holds all three logs."""
    from aion_cli.formats.mapfile import read_manifest

    target = office.copy_map(tmp_path / "m.aion")
    lock = target.with_name("m.aion.lock")
    small = write_log(tmp_path / "small.mcap", walk(30, start_s=2400))
    proc = subprocess.Popen(
        [str(AION), "build", str(crowd_log), "--map", str(target), "-q"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=aion_env(),
    )
    try:
        # A takes the lock first thing (its build lasts longer); its start-up (imports) takes
        # longer than 3 s on a busy machine, so the wait is for the lock, not for a time
        deadline = time.monotonic() + 120
        while not lock.exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.005)
        assert lock.exists(), "build A took no lock"
        second = run("build", small, "--map", target)  # while A is still busy
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    names = [i["name"] for i in read_manifest(target)["inputs"]]
    if second.exit_code == 0:  # whatever happened, a build that succeeded kept its log
        assert "small.mcap" in names, names
    assert second.exit_code == 2, second.stderr
    assert_one_error(second.stderr, "being written by another process")
    assert names == ["office.mcap", "crowd.mcap"]
    third = run("build", small, "--map", target)
    assert third.exit_code == 0, third.stderr
    names = [i["name"] for i in read_manifest(target)["inputs"]]
    assert names == ["office.mcap", "crowd.mcap", "small.mcap"]


# -- reading: checksums, no code execution, hostile containers -------------------------------


def _member(path: Path) -> str:
    with zipfile.ZipFile(path) as zf:
        return next(n for n in zf.namelist() if n.endswith(".npy"))


def refused(path: Path, *fragments: str) -> None:
    """``load_map`` raises a MapFileError and ``aion predict`` prints one error line, exit 2."""
    from aion_cli.errors import MapFileError
    from aion_cli.mapquery import load_map

    with pytest.raises(MapFileError) as info:
        load_map(path)
    for fragment in fragments:
        assert fragment in info.value.message
    result = run("predict", path, "--time", "now")
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, *fragments)


def test_checksums_catch_a_changed_array(office: Office, tmp_path: Path) -> None:
    """An array changed inside a well-formed zip (fresh zip CRC): the manifest's CRC-32
    catches it and names the member."""
    name = _member(office.map)
    with zipfile.ZipFile(office.map) as zf:
        data = bytearray(zf.read(name))
    data[-1] ^= 0x01
    bad = rewrite_map(office.map, tmp_path / "bad.aion", {name: bytes(data)})
    refused(bad, "corrupted", name[: -len(".npy")], "crc32")


def _without_crc32(manifest: dict[str, Any]) -> None:
    """A manifest as aion wrote it before members had a CRC-32 (sha256 only)."""
    for rec in manifest["members"].values():
        rec.pop("crc32")


def test_maps_without_crc32_are_checked_by_sha256(office: Office, tmp_path: Path) -> None:
    """Maps written before the CRC-32 (their members have a sha256 only) load and predict
    alike, and a changed array is still caught, by its sha256."""
    from aion_cli.mapquery import load_map

    old = rewrite_map(office.map, tmp_path / "old.aion", manifest_edit=_without_crc32)
    now = run("predict", office.map, "--time", "2024-01-01 12:00", "--format", "csv")
    before = run("predict", old, "--time", "2024-01-01 12:00", "--format", "csv")
    assert now.exit_code == before.exit_code == 0, before.stderr
    assert before.stdout == now.stdout
    assert load_map(old).state.entries.n == load_map(office.map).state.entries.n
    name = _member(office.map)
    with zipfile.ZipFile(office.map) as zf:
        data = bytearray(zf.read(name))
    data[-1] ^= 0x01
    bad = rewrite_map(office.map, tmp_path / "bad.aion", {name: bytes(data)}, _without_crc32)
    refused(bad, "corrupted", name[: -len(".npy")], "sha256")


def test_a_flipped_byte_on_disk_is_caught(office: Office, tmp_path: Path) -> None:
    bad = office.copy_map(tmp_path / "flip.aion")
    data = bytearray(bad.read_bytes())
    data[len(data) // 2] ^= 0x40
    bad.write_bytes(bytes(data))
    refused(bad, "flip.aion")


class _Evil:
    """Unpickling this creates a marker folder: proof that code ran."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, tuple[str]]:
        return (os.mkdir, (str(self.marker),))


def test_a_pickled_member_is_refused_and_never_runs(office: Office, tmp_path: Path) -> None:
    marker = tmp_path / "pwned"
    buf = io.BytesIO()
    np.save(buf, np.array([_Evil(marker)], dtype=object), allow_pickle=True)
    data = buf.getvalue()
    # the payload is live: loading it with pickle allowed would run it
    np.load(io.BytesIO(data), allow_pickle=True)
    assert marker.is_dir()
    marker.rmdir()

    name = _member(office.map)

    def declare(manifest: dict[str, Any]) -> None:
        rec = manifest["members"][name[: -len(".npy")]]
        declare_member(rec, data, dtype="|O")

    bad = rewrite_map(office.map, tmp_path / "pickle.aion", {name: data}, declare)
    refused(bad, "not a valid .npy")
    assert not marker.exists()


def test_a_path_traversing_member_is_refused(office: Office, tmp_path: Path) -> None:
    bad = rewrite_map(office.map, tmp_path / "trav.aion", {"../../evil.npy": b"x"})
    refused(bad, "unsafe or unexpected member name")
    assert not (tmp_path.parent / "evil.npy").exists()


def test_an_oversized_member_is_refused_before_reading(office: Office, tmp_path: Path) -> None:
    name = _member(office.map)

    def huge(manifest: dict[str, Any]) -> None:
        manifest["members"][name[: -len(".npy")]]["size"] = 5 * 1024**3

    refused(rewrite_map(office.map, tmp_path / "huge.aion", manifest_edit=huge), "limit")


def test_a_zip_bomb_member_is_refused(office: Office, tmp_path: Path) -> None:
    name = _member(office.map)
    bomb = tmp_path / "bomb.aion"
    with zipfile.ZipFile(office.map) as zin:
        contents = {n: zin.read(n) for n in zin.namelist()}
    zeros = np.zeros(8 * 1024**2 // 8)
    buf = io.BytesIO()
    np.save(buf, zeros)
    contents[name] = buf.getvalue()
    with zipfile.ZipFile(bomb, "w", compression=zipfile.ZIP_DEFLATED) as zout:
        for n, data in contents.items():
            zout.writestr(n, data)
    refused(bomb, "zip bomb")


@pytest.mark.parametrize(
    ("edit", "fragment"),
    [
        (lambda m: m.update(format="not-aion"), "invalid manifest"),
        (lambda m: m.update(members=[]), "invalid manifest"),
        (lambda m: next(iter(m["members"].values())).update(sha256="xyz"), "sha256"),
        (lambda m: next(iter(m["members"].values())).update(crc32="12345"), "crc32"),
        (lambda m: next(iter(m["members"].values())).update(crc32=123), "crc32"),
        (lambda m: m.update(version="1"), "invalid version"),
        (lambda m: m.pop("state"), "no model state"),
        (lambda m: m["state"].update(open_window="soon"), "invalid"),
    ],
)
def test_a_manifest_that_does_not_validate_is_refused(
    edit: Any, fragment: str, office: Office, tmp_path: Path
) -> None:
    refused(rewrite_map(office.map, tmp_path / "bad.aion", manifest_edit=edit), fragment)
