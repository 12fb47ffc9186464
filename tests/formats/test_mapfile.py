"""The .aion map container: round trips, integrity checks, atomic writes, locking, hostile zips."""

from __future__ import annotations

import errno
import hashlib
import io
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from aion_cli import __version__
from aion_cli.errors import (
    InputError,
    MapCorruptError,
    MapFileError,
    MapLockedError,
    MapVersionError,
)
from aion_cli.formats import mapfile, mapfile_write
from aion_cli.formats.mapfile import (
    MapContentError,
    MapWriteError,
    lock_path,
    read_manifest,
    read_map,
    write_map,
)


def sample_arrays() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    return {
        "f64": rng.normal(size=(5, 3)),
        "c128": rng.normal(size=(4, 2)) + 1j * rng.normal(size=(4, 2)),
        "u64": np.array([0, 1, 2**64 - 1, 2**63], dtype=np.uint64),
        "i8": np.array([-128, 0, 127], dtype=np.int8),
        "flags": np.array([True, False, True]),
        "empty": np.zeros(0, dtype=np.float64),
        "empty2d": np.zeros((0, 8), dtype=np.int64),
        "cube": np.arange(24, dtype=np.int32).reshape(2, 3, 4),
        "fortran": np.asfortranarray(np.arange(12.0).reshape(3, 4)),
        "fremen/sum_se": np.ones((2, 3), dtype=np.complex128),
        "scalar": np.array(3.5),
        "labels": np.array(["kitchen", "hall"]),
    }


def assert_same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert set(a) == set(b)
    for name in a:
        assert b[name].dtype == a[name].dtype, name
        assert b[name].shape == a[name].shape, name
        np.testing.assert_array_equal(b[name], a[name])


def rewrite(
    src: Path,
    dst: Path,
    members: dict[str, bytes | None] | None = None,
    manifest_edit: Any = None,
    compression: int = zipfile.ZIP_STORED,
) -> None:
    """Copy a map zip member by member, replacing/adding (bytes) or dropping (None) members."""
    members = members or {}
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", compression) as zout:
        for info in zin.infolist():
            name = info.filename
            if name in members:
                continue
            data = zin.read(name)
            if name == "manifest.json" and manifest_edit is not None:
                manifest = json.loads(data)
                manifest_edit(manifest)
                data = json.dumps(manifest).encode()
            zout.writestr(name, data)
        for name, replacement in members.items():
            if replacement is not None:
                zout.writestr(name, replacement)


def npy_bytes(arr: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=False)
    return buf.getvalue()


@pytest.fixture
def written(tmp_path: Path) -> Path:
    path = tmp_path / "office.aion"
    write_map(path, sample_arrays(), {"config": {"bins": 8}, "counts": {"entries": 5}})
    return path


# -- round trip ------------------------------------------------------------------------------


def test_round_trip_preserves_values_dtypes_shapes(written: Path) -> None:
    arrays, _manifest = read_map(written)
    assert_same(sample_arrays(), arrays)
    assert arrays["fremen/sum_se"].flags.writeable


def test_manifest_carries_container_and_caller_fields(written: Path) -> None:
    _, manifest = read_map(written)
    assert manifest["format"] == "aion-map"
    assert manifest["version"] == "2.0"  # format 2: the temporal model's state
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


# -- damaged files ----------------------------------------------------------------------------


def test_flipped_byte_in_member_is_corruption_naming_it(tmp_path: Path) -> None:
    path = tmp_path / "m.aion"
    payload = np.arange(1000, dtype=np.int64)
    write_map(path, {"other": np.zeros(3), "counts": payload}, {})
    raw = bytearray(path.read_bytes())
    at = raw.find(payload.tobytes()[800:864])
    assert at > 0
    raw[at + 5] ^= 0x40
    path.write_bytes(bytes(raw))
    with pytest.raises(MapCorruptError, match="counts"):
        read_map(path)


def test_checksum_mismatch_with_valid_zip_crc_names_member(written: Path, tmp_path: Path) -> None:
    forged = tmp_path / "forged.aion"
    rewrite(written, forged, {"i8.npy": npy_bytes(np.array([1, 2, 3], dtype=np.int8))})
    with pytest.raises(MapCorruptError, match="i8 fails its sha256"):
        read_map(forged)


def test_truncated_file_is_a_map_file_error_with_hint(written: Path) -> None:
    raw = written.read_bytes()
    written.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(MapFileError) as err:
        read_map(written)
    assert err.value.hint


def test_not_a_zip_missing_file_and_missing_manifest(tmp_path: Path, written: Path) -> None:
    junk = tmp_path / "junk.aion"
    junk.write_text("hello, not a zip")
    with pytest.raises(MapFileError, match="not a zip") as err:
        read_map(junk)
    assert err.value.hint
    assert "aion build" in err.value.hint
    with pytest.raises(MapFileError, match="does not exist"):
        read_map(tmp_path / "absent.aion")
    no_manifest = tmp_path / "nm.aion"
    rewrite(written, no_manifest, {"manifest.json": None})
    with pytest.raises(MapFileError, match=r"no manifest\.json"):
        read_map(no_manifest)


def test_newer_major_is_a_version_error_newer_minor_reads(written: Path, tmp_path: Path) -> None:
    newer = tmp_path / "v3.aion"
    rewrite(written, newer, manifest_edit=lambda m: m.update(version="3.0"))
    with pytest.raises(MapVersionError) as err:
        read_map(newer)
    assert str(err.value) == ("map format 3.0 is newer than this aion supports (2.x); upgrade aion")
    minor = tmp_path / "v2_7.aion"
    rewrite(written, minor, manifest_edit=lambda m: m.update(version="2.7", extra=True))
    arrays, manifest = read_map(minor)
    assert manifest["extra"] is True
    assert_same(sample_arrays(), arrays)
    for old in ("1.0", "1.9", "0.3"):  # format 1 held the old FreMEn state: rebuild
        older = tmp_path / f"v{old}.aion"
        rewrite(written, older, manifest_edit=lambda m, v=old: m.update(version=v))
        with pytest.raises(MapVersionError, match="older") as err:
            read_map(older)
        assert f"map format {old} is older" in str(err.value)
        assert err.value.hint is not None
        assert "rebuild" in err.value.hint
        with pytest.raises(MapVersionError, match="older"):
            read_manifest(older)


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda m: m.pop("members"), "members"),
        (lambda m: m.update(format="other"), "format"),
        (lambda m: m.update(version="one"), "version"),
        (lambda m: m.update(creator=5), "creator"),
        (lambda m: m["members"]["i8"].update(size=-1), "size"),
        (lambda m: m["members"]["i8"].update(size=True), "size"),
        (lambda m: m["members"]["i8"].update(sha256="xyz"), "sha256"),
        (lambda m: m["members"]["i8"].update(shape=[3.0]), "shape"),
        (lambda m: m["members"].update(i8=[1, 2]), "not an object"),
    ],
)
def test_manifest_schema_is_checked(written: Path, tmp_path: Path, edit: Any, match: str) -> None:
    bad = tmp_path / "bad.aion"
    rewrite(written, bad, manifest_edit=edit)
    with pytest.raises(MapFileError, match=match):
        read_map(bad)


def test_manifest_not_json_or_not_object(written: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.aion"
    rewrite(written, bad, {"manifest.json": b"{not json"})
    with pytest.raises(MapFileError, match="not valid JSON"):
        read_map(bad)
    rewrite(written, bad, {"manifest.json": b"[" * 100_000 + b"]" * 100_000})
    with pytest.raises(MapFileError, match="not valid JSON"):
        read_map(bad)
    rewrite(written, bad, {"manifest.json": b"[1, 2]"})
    with pytest.raises(MapFileError, match="not a JSON object"):
        read_map(bad)


def test_dtype_or_shape_disagreeing_with_manifest_is_corruption(
    written: Path, tmp_path: Path
) -> None:
    data = npy_bytes(np.array([1, 2, 3], dtype=np.int16))

    def declare(m: dict[str, Any]) -> None:
        m["members"]["i8"].update(size=len(data), sha256=hashlib.sha256(data).hexdigest())

    bad = tmp_path / "bad.aion"
    rewrite(written, bad, {"i8.npy": data}, manifest_edit=declare)
    with pytest.raises(MapCorruptError, match="i8 has dtype int16"):
        read_map(bad)


# -- hostile zips -----------------------------------------------------------------------------


@pytest.mark.parametrize("evil", ["../evil.npy", "/etc/evil.npy", "a/../../b.npy", "run.py"])
def test_unsafe_zip_member_names_are_rejected(written: Path, tmp_path: Path, evil: str) -> None:
    bad = tmp_path / "bad.aion"
    rewrite(written, bad, {evil: npy_bytes(np.zeros(1))})
    with pytest.raises(MapFileError, match="unsafe or unexpected member"):
        read_map(bad)


def test_traversal_name_declared_in_manifest_is_rejected(written: Path, tmp_path: Path) -> None:
    data = npy_bytes(np.zeros(1))

    def declare(m: dict[str, Any]) -> None:
        m["members"]["../evil"] = {
            "sha256": hashlib.sha256(data).hexdigest(),
            "size": len(data),
            "dtype": "<f8",
            "shape": [1],
        }

    bad = tmp_path / "bad.aion"
    rewrite(written, bad, manifest_edit=declare)
    with pytest.raises(MapFileError, match="unsafe member name"):
        read_map(bad)


def test_unlisted_and_missing_members(written: Path, tmp_path: Path) -> None:
    extra = tmp_path / "extra.aion"
    rewrite(written, extra, {"sneaky.npy": npy_bytes(np.zeros(1))})
    with pytest.raises(MapFileError, match="not listed"):
        read_map(extra)
    missing = tmp_path / "missing.aion"
    rewrite(written, missing, {"cube.npy": None})
    with pytest.raises(MapCorruptError, match="cube is missing"):
        read_map(missing)


def test_oversized_members_are_rejected(written: Path, tmp_path: Path) -> None:
    with pytest.raises(MapFileError, match="over the 64-byte limit"):
        read_map(written, max_member_bytes=64)
    # A manifest declaring an enormous member is refused before anything is read.
    huge = tmp_path / "huge.aion"
    rewrite(written, huge, manifest_edit=lambda m: m["members"]["i8"].update(size=5 * 1024**3))
    with pytest.raises(MapFileError, match="over the"):
        read_map(huge)


def test_zip_bomb_ratio_is_rejected(tmp_path: Path) -> None:
    zeros = npy_bytes(np.zeros(4 * 1024**2 // 8))
    bomb = tmp_path / "bomb.aion"
    manifest = {
        "format": "aion-map",
        "version": "2.0",
        "creator": "x",
        "created": "now",
        "members": {
            "z": {
                "sha256": hashlib.sha256(zeros).hexdigest(),
                "size": len(zeros),
                "dtype": "<f8",
                "shape": [4 * 1024**2 // 8],
            }
        },
    }
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("manifest.json", json.dumps(manifest))
        zf.writestr("z.npy", zeros)
    assert bomb.stat().st_size < 64 * 1024
    with pytest.raises(MapFileError, match="zip bomb"):
        read_map(bomb)
    # The same member within the ratio limit (caller-raised) reads back.
    arrays, _ = read_map(bomb, max_ratio=10_000)
    assert arrays["z"].shape == (4 * 1024**2 // 8,)


def test_deflated_small_map_written_by_another_tool_reads(written: Path, tmp_path: Path) -> None:
    deflated = tmp_path / "deflated.aion"
    rewrite(written, deflated, compression=zipfile.ZIP_DEFLATED)
    assert_same(sample_arrays(), read_map(deflated)[0])


def test_pickled_member_never_loads(written: Path, tmp_path: Path) -> None:
    buf = io.BytesIO()
    np.save(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    data = buf.getvalue()

    def declare(m: dict[str, Any]) -> None:
        m["members"]["i8"].update(size=len(data), sha256=hashlib.sha256(data).hexdigest())

    bad = tmp_path / "bad.aion"
    rewrite(written, bad, {"i8.npy": data}, manifest_edit=declare)
    with pytest.raises(MapCorruptError, match=r"not a valid \.npy"):
        read_map(bad)


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
