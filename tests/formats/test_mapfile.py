"""The .aion map container, written: round trips (values, dtypes, shapes, the manifest,
streamed row takes), what ``write_map`` refuses, atomic writes, locking."""

from __future__ import annotations

import errno
import hashlib
import os
import subprocess
import sys
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from aion_cli import __version__
from aion_cli.errors import InputError, MapLockedError
from aion_cli.formats import mapfile, mapfile_write
from aion_cli.formats.mapfile import (
    MapContentError,
    MapWriteError,
    lock_path,
    read_manifest,
    read_map,
    write_map,
)
from tests.formats.conftest import assert_same, sample_arrays

# -- round trip ------------------------------------------------------------------------------


def test_round_trip_preserves_values_dtypes_shapes(written: Path) -> None:
    arrays, _manifest = read_map(written)
    assert_same(sample_arrays(), arrays)
    assert arrays["fremen/sum_se"].flags.writeable


def test_manifest_carries_container_and_caller_fields(written: Path) -> None:
    _, manifest = read_map(written)
    assert manifest["format"] == "aion-map"
    # format 2: the temporal model's state; .1: day levels; .2: week sums
    assert manifest["version"] == "2.3"
    assert manifest["creator"] == f"aion {__version__}"
    assert manifest["created"].endswith("Z")
    assert manifest["config"] == {"bins": 8}
    assert manifest["counts"] == {"entries": 5}
    rec = manifest["members"]["u64"]
    assert rec["dtype"] == "<u8"
    assert rec["shape"] == [4]
    with zipfile.ZipFile(written) as zf:
        raw = zf.read("u64.npy")
        assert sorted(zf.namelist()) == sorted(
            ["manifest.json", *(n + ".npy" for n in sample_arrays())]
        )
    assert rec["size"] == len(raw)
    assert rec["sha256"] == hashlib.sha256(raw).hexdigest()
    assert rec["crc32"] == f"{zlib.crc32(raw):08x}"
    assert read_manifest(written) == manifest


def test_rewrite_replaces_previous_map_and_leaves_no_temp_or_lock(written: Path) -> None:
    write_map(written, {"only": np.arange(3)}, {})
    arrays, _ = read_map(written)
    assert list(arrays) == ["only"]
    assert sorted(p.name for p in written.parent.iterdir()) == ["office.aion"]


def test_new_map_gets_umask_permissions_rewrite_keeps_them(tmp_path: Path) -> None:
    path = tmp_path / "m.aion"
    old = os.umask(0o022)
    try:
        write_map(path, {"a": np.zeros(1)}, {})
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == 0o644
    path.chmod(0o640)
    write_map(path, {"a": np.ones(1)}, {})
    assert path.stat().st_mode & 0o777 == 0o640


@settings(max_examples=40, deadline=None)
@given(
    arr=hnp.arrays(
        dtype=st.one_of(
            hnp.integer_dtypes(),
            hnp.unsigned_integer_dtypes(),
            hnp.floating_dtypes(),
            hnp.complex_number_dtypes(),
            hnp.boolean_dtypes(),
        ),
        shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4),
    )
)
def test_round_trip_property(tmp_path_factory: pytest.TempPathFactory, arr: np.ndarray) -> None:
    path = tmp_path_factory.mktemp("prop") / "m.aion"
    write_map(path, {"a": arr}, {})
    back = read_map(path)[0]["a"]
    assert back.dtype == arr.dtype
    assert back.shape == arr.shape
    np.testing.assert_array_equal(back, arr)


def test_streamed_row_takes_write_the_bytes_np_save_writes(tmp_path: Path) -> None:
    """A RowTake member (gathered block by block while writing) is stored exactly like the
    array it stands for: same checksums, dtypes, shapes and values after reading."""
    from aion_cli.engine.types import RowTake

    rng = np.random.default_rng(3)
    sources = {
        "c": rng.normal(size=(50, 7)) + 1j * rng.normal(size=(50, 7)),
        "i": rng.integers(-5, 5, (50, 4)).astype(np.int16),
        "f": rng.normal(size=50),
        "none": rng.normal(size=(50, 0)),
    }
    rows = rng.permutation(50)[:37]
    lazy = {k: RowTake(v, rows, block_rows=3) for k, v in sources.items()}
    lazy["empty"] = RowTake(sources["f"], rows[:0])
    eager = {k: np.asarray(v) for k, v in lazy.items()}
    write_map(tmp_path / "lazy.aion", lazy, {"x": 1})
    write_map(tmp_path / "eager.aion", eager, {"x": 1})
    a_arrays, a_manifest = read_map(tmp_path / "lazy.aion")
    b_arrays, b_manifest = read_map(tmp_path / "eager.aion")
    assert sorted(b_arrays) == sorted(a_arrays)
    assert a_manifest["members"] == b_manifest["members"]
    for name, value in eager.items():
        assert a_arrays[name].dtype == value.dtype
        np.testing.assert_array_equal(a_arrays[name], value)
    np.testing.assert_array_equal(a_arrays["c"], sources["c"][rows])


# -- refused on write -------------------------------------------------------------------------


def test_object_arrays_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "m.aion"
    with pytest.raises(MapContentError, match="objects"):
        write_map(path, {"bad": np.array([{"a": 1}, None], dtype=object)}, {})
    assert not path.exists()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["../evil", "/abs", "a//b", "a/../b", "", "x\\y", "c:d"])
def test_unsafe_array_names_are_refused(tmp_path: Path, name: str) -> None:
    with pytest.raises(MapContentError, match="invalid array name"):
        write_map(tmp_path / "m.aion", {name: np.zeros(1)}, {})


def test_reserved_and_non_json_manifest_fields_are_refused(tmp_path: Path) -> None:
    with pytest.raises(MapContentError, match="reserved"):
        write_map(tmp_path / "m.aion", {}, {"version": "9.9"})
    with pytest.raises(MapContentError, match="JSON"):
        write_map(tmp_path / "m.aion", {}, {"span": float("nan")})
    with pytest.raises(MapContentError, match="JSON"):
        write_map(tmp_path / "m.aion", {}, {"when": object()})
    assert list(tmp_path.iterdir()) == []


def test_missing_folder_is_a_write_error(tmp_path: Path) -> None:
    with pytest.raises(MapWriteError, match="does not exist"):
        write_map(tmp_path / "nope" / "m.aion", {}, {})


# -- atomicity --------------------------------------------------------------------------------


def test_old_map_survives_oserror_during_write(
    written: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    before = written.read_bytes()

    def disk_full(fd: int) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(mapfile_write.os, "fsync", disk_full)
    with pytest.raises(MapWriteError, match="No space left") as err:
        write_map(written, {"new": np.arange(10)}, {})
    assert isinstance(err.value, InputError)
    monkeypatch.undo()
    assert written.read_bytes() == before
    assert sorted(p.name for p in written.parent.iterdir()) == ["office.aion"]
    assert_same(sample_arrays(), read_map(written)[0])


def test_old_map_survives_keyboard_interrupt_mid_member(
    written: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    before = written.read_bytes()
    real_save = np.save
    calls = {"n": 0}

    def interrupted_save(fh: Any, arr: Any, allow_pickle: bool = False) -> None:
        calls["n"] += 1
        if calls["n"] == 2:
            fh.write(b"\x93NUMPY partial")
            raise KeyboardInterrupt
        real_save(fh, arr, allow_pickle=allow_pickle)

    monkeypatch.setattr(mapfile_write.np, "save", interrupted_save)
    with pytest.raises(KeyboardInterrupt):
        write_map(written, {"a": np.arange(5), "b": np.arange(6)}, {})
    monkeypatch.undo()
    assert calls["n"] == 2
    assert written.read_bytes() == before
    assert sorted(p.name for p in written.parent.iterdir()) == ["office.aion"]


# -- locking ----------------------------------------------------------------------------------


def dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_live_lock_blocks_a_second_writer(written: Path) -> None:
    import socket

    lock = lock_path(written)
    assert lock.name == "office.aion.lock"
    lock.write_text(f"{os.getppid()} {socket.gethostname()}\n")
    before = written.read_bytes()
    with pytest.raises(MapLockedError, match="another process") as err:
        write_map(written, {"x": np.zeros(2)}, {})
    assert err.value.hint is not None
    assert str(lock) in err.value.hint
    assert lock.exists()
    assert written.read_bytes() == before


def test_lock_is_held_during_write_and_nested_writer_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "m.aion"
    with mapfile.map_lock(path) as lock:
        assert lock.read_text().split()[0] == str(os.getpid())
        with pytest.raises(MapLockedError):
            write_map(path, {}, {})
    assert not lock.exists()
    write_map(path, {}, {})


def test_stale_lock_of_dead_process_is_recovered(written: Path) -> None:
    import socket

    lock = lock_path(written)
    lock.write_text(f"{dead_pid()} {socket.gethostname()}\n")
    write_map(written, {"x": np.arange(4)}, {})
    assert not lock.exists()
    np.testing.assert_array_equal(read_map(written)[0]["x"], np.arange(4))


def test_a_lock_of_this_pid_that_this_process_does_not_hold_is_stale(written: Path) -> None:
    """A container restarted after its aion was killed runs aion as the same pid on the same
    host: the lock it left names the new process itself, which was "another process" to the
    liveness check (the pid is alive: it is us) and blocked every build until deleted by hand.
    A lock of this very pid that this process does not hold is recovered; one it holds still
    refuses a nested writer (test above)."""
    import socket

    lock = lock_path(written)
    lock.write_text(f"{os.getpid()} {socket.gethostname()}\n")
    write_map(written, {"x": np.arange(3)}, {})
    assert not lock.exists()
    np.testing.assert_array_equal(read_map(written)[0]["x"], np.arange(3))


def test_lock_from_another_host_is_respected(written: Path) -> None:
    lock_path(written).write_text(f"{dead_pid()} some-other-host.example\n")
    with pytest.raises(MapLockedError):
        write_map(written, {}, {})


def test_unreadable_lock_is_stale_only_when_old(written: Path) -> None:
    lock = lock_path(written)
    lock.write_text("")
    with pytest.raises(MapLockedError):
        write_map(written, {}, {})
    old = lock.stat().st_mtime - 3600
    os.utime(lock, (old, old))
    write_map(written, {}, {})
    assert not lock.exists()


def test_a_file_of_the_locks_name_that_is_not_a_lock_is_never_removed(written: Path) -> None:
    """A file of the lock's name holding other text than aion's "<pid> <host>" (someone's
    own ``office.aion.lock``) was removed as a stale lock once 10 s old; it is kept and
    the write refused, naming it."""
    lock = lock_path(written)
    lock.write_text("my notes on the office map\n")
    old = lock.stat().st_mtime - 3600
    os.utime(lock, (old, old))
    before = written.read_bytes()
    with pytest.raises(MapLockedError, match="is in the way, a file that is not aion's lock"
                       ) as err:
        write_map(written, {}, {})
    assert str(lock) in (err.value.hint or "")
    assert lock.read_text() == "my notes on the office map\n"
    assert written.read_bytes() == before
