"""A map's members as the zip records them: ``write_map`` writes each member's bytes to the
file itself and hands zipfile their CRC-32 and size (stop 70: zipfile computed every byte's
CRC a second time). The zip's own records must still be right (``ZipFile.testzip``, and
each record against ``zlib.crc32`` of the bytes read back), streamed members included, and
a zipfile without what the writer hands over gets the same map through the member."""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.engine.types import RowTake
from aion_cli.formats import mapfile_write
from aion_cli.formats.mapfile import read_map, write_map


def _members() -> dict[str, Any]:
    rng = np.random.default_rng(11)
    counts = rng.integers(0, 200, (300, 9)).astype(np.float64)
    rows = rng.permutation(300)[:250]
    return {
        "plain": rng.normal(size=(40, 3)),
        "words": np.array(["a", "bcd", ""]),
        "c": RowTake(rng.normal(size=(300, 5)) + 1j, rows, block_rows=64),
        "narrow": RowTake(counts, rows, block_rows=7, cast=np.dtype(np.uint8)),
        "empty": RowTake(counts, rows[:0]),
    }


def _zip_records(path: Path) -> dict[str, tuple[int, int, bytes]]:
    with zipfile.ZipFile(path) as zf:
        assert zf.testzip() is None  # every member read back against its recorded CRC
        return {i.filename: (i.CRC, i.file_size, zf.read(i)) for i in zf.infolist()}


def test_each_member_s_zip_record_is_its_bytes(tmp_path: Path) -> None:
    with zipfile.ZipFile(tmp_path / "probe.zip", "w") as zf, zf.open("a", "w") as member:
        assert mapfile_write._HashingWriter(member).direct  # this zipfile: the bytes direct
    members = _members()
    write_map(tmp_path / "m.aion", members, {"x": 1})
    records = _zip_records(tmp_path / "m.aion")
    arrays, manifest = read_map(tmp_path / "m.aion")
    for name, value in members.items():
        crc, size, raw = records[name + ".npy"]
        assert crc == zlib.crc32(raw)
        assert size == len(raw) == manifest["members"][name]["size"]
        assert manifest["members"][name]["crc32"] == f"{crc:08x}"
        np.testing.assert_array_equal(arrays[name], np.asarray(value))
    assert arrays["narrow"].dtype == np.uint8


def test_a_zipfile_without_the_handed_state_writes_through_the_member(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    write_map(tmp_path / "direct.aion", _members(), {"x": 1})
    monkeypatch.setattr(mapfile_write, "_MEMBER_STATE", ("_not_in_any_zipfile",))
    write_map(tmp_path / "through.aion", _members(), {"x": 1})
    direct = _zip_records(tmp_path / "direct.aion")
    through = _zip_records(tmp_path / "through.aion")
    assert direct.keys() == through.keys()
    for name, (crc, size, raw) in direct.items():
        if name != "manifest.json":  # its ``created`` may differ by a second
            assert (crc, size, raw) == through[name]
    assert read_map(tmp_path / "direct.aion")[1]["members"] == read_map(
        tmp_path / "through.aion"
    )[1]["members"]
