"""The .aion map container, read back damaged or hostile: integrity checks (flipped bytes,
forged checksums, truncation, not a zip), format versions, the manifest schema, and hostile
zips (unsafe or unlisted member names, oversized members, zip bombs, pickles)."""

from __future__ import annotations

import hashlib
import io
import json
import shlex
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.errors import MapCorruptError, MapFileError, MapVersionError
from aion_cli.formats.mapfile import read_manifest, read_map, write_map
from tests.formats.conftest import assert_same, sample_arrays
from tests.formats.map_damage import declare_member


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
    with pytest.raises(MapCorruptError, match="i8 fails its crc32"):
        read_map(forged)


def test_truncated_file_is_a_map_file_error_with_hint(written: Path) -> None:
    raw = written.read_bytes()
    written.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(MapFileError) as err:
        read_map(written)
    assert err.value.hint


def test_a_damaged_zip_version_field_is_a_map_file_error(written: Path) -> None:
    """The "version needed to extract" field of the first member's central directory record
    damaged (zipfile raises NotImplementedError: "zip file version 20.9"; found by the long
    fuzz run): a map that cannot be read, exit 2 through the CLI, and no kind of input to
    :func:`input_kind`. It was an internal error (exit 1): the detector that names what a
    file is let zipfile's NotImplementedError through."""
    from aion_cli.formats.input_kind import bare_zip, input_kind
    from tests.cli.conftest import run

    raw = bytearray(written.read_bytes())
    at = raw.find(b"PK\x01\x02") + 6
    raw[at : at + 2] = (209).to_bytes(2, "little")
    written.write_bytes(bytes(raw))
    with pytest.raises(MapFileError, match="is not a readable aion map") as err:
        read_manifest(written)
    assert "zip file version 20.9" in str(err.value)
    assert input_kind(written) is None
    assert bare_zip(written) is None
    result = run("predict", written, "--time", "2026-01-05 09:30")
    assert result.exit_code == 2, result.stderr
    assert "internal error" not in result.stderr


def test_an_empty_file_is_said_to_be_empty(tmp_path: Path) -> None:
    """A map file of 0 bytes (an interrupted copy, a `touch`) is named empty, with the hint
    of a damaged map; it had been 'not a zip container (File is not a zip file)'."""
    empty = tmp_path / "empty.aion"
    empty.write_bytes(b"")
    for read in (read_map, read_manifest):
        with pytest.raises(MapFileError) as err:
            read(empty)
        assert err.value.message == (
            f"{empty} is not a readable aion map: the file is empty (0 bytes)"
        )
        assert "aion build" in (err.value.hint or "")


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
        (lambda m: m["members"]["i8"].update(crc32="0x12345678"), "crc32"),
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
        declare_member(m["members"]["i8"], data)

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


def test_size_limits_accept_a_map_exactly_at_them(written: Path) -> None:
    """The limits are the largest sizes accepted: a map whose largest member, whose total
    and whose number of members are exactly at them reads whole; one less refuses it."""
    with zipfile.ZipFile(written) as zf:
        sizes = [info.file_size for info in zf.infolist()]
        largest = max(i.file_size for i in zf.infolist() if i.filename.endswith(".npy"))
    assert_same(read_map(written, max_member_bytes=largest)[0], sample_arrays())
    with pytest.raises(MapFileError, match="over the"):
        read_map(written, max_member_bytes=largest - 1)
    assert_same(read_map(written, max_total_bytes=sum(sizes))[0], sample_arrays())
    with pytest.raises(MapFileError, match="over the"):
        read_map(written, max_total_bytes=sum(sizes) - 1)
    assert_same(read_map(written, max_members=len(sizes))[0], sample_arrays())
    with pytest.raises(MapFileError, match="entry limit"):
        read_map(written, max_members=len(sizes) - 1)


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
        declare_member(m["members"]["i8"], data)

    bad = tmp_path / "bad.aion"
    rewrite(written, bad, {"i8.npy": data}, manifest_edit=declare)
    with pytest.raises(MapCorruptError, match=r"not a valid \.npy"):
        read_map(bad)


def test_a_log_or_a_graph_given_as_a_map_is_named(tmp_path: Path) -> None:
    """Where a map belongs, a log says to build a map from it and a scene-graph file says
    where it goes; other bytes keep the 'damaged' hint."""
    from tests.formats.log_builders import _write_plain_mcap

    log = tmp_path / "run.mcap"
    _write_plain_mcap(log, "NONE")
    graph = tmp_path / "dsg.json"
    graph.write_text('{"directed": false, "edges": [], "nodes": []}')
    other = tmp_path / "notes.txt"
    other.write_text("a shopping list\n")
    for path, hint in (
        (log, "run.mcap is a log: build a map from it first, "
              f"`aion build {shlex.quote(str(log))} -o MAP.aion`"),
        (graph, f"`aion build LOG --graph {shlex.quote(str(graph))} -o MAP.aion`"),
        (other, "truncated or damaged"),
    ):
        with pytest.raises(MapFileError, match="is not a readable aion map") as info:
            read_manifest(path)
        assert hint in (info.value.hint or ""), info.value.hint
