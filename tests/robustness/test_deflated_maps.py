"""A real map re-zipped by another tool (Python's zipfile, ZIP_DEFLATED) end to end.

aion writes members stored; ``formats/MAPFILE.md`` says readers accept deflated members other
tools write. The office map (``tests/cli/logdata.py``) re-zipped deflated must read to the very
arrays and give the very predictions of the original through ``aion predict``; damaged, it
must be one ``error:`` line and exit code 2 like any damaged map, never an internal error.
The container's limits for deflated members are tested at their boundaries in
``tests/formats/test_mapfile_deflated.py``.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.formats.mapfile import open_map, read_map
from tests.cli.logdata import T0, S
from tests.formats.map_damage import lie_about_sizes, member_data_offset, rezip
from tests.robustness.conftest import Office, fails, run

MEMBER = "entry_counts.npy"
"""The member damaged below: every prediction reads the entries' counts."""


def _deflated(office: Office, tmp_path: Path) -> Path:
    path = rezip(office.map, tmp_path / "deflated.aion")
    with zipfile.ZipFile(path) as zf:
        assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in zf.infolist())
    assert path.stat().st_size < office.map.stat().st_size  # it did compress
    return path


def _predict_json(path: Path, *args: str) -> dict[str, Any]:
    result = run("predict", path, *args, "--format", "json", "-q")
    assert result.exit_code == 0, result.stderr
    out: dict[str, Any] = json.loads(result.stdout)
    out.pop("map")  # the file's name
    return out


def test_a_map_rezipped_deflated_reads_the_same_arrays(office: Office, tmp_path: Path) -> None:
    """Every array equal, dtype and shape included, read whole and read in place (the
    query path: stored members are mapped, deflated ones inflated)."""
    path = _deflated(office, tmp_path)
    original, manifest = read_map(office.map)
    arrays, again = read_map(path)
    assert again == manifest
    assert sorted(arrays) == sorted(original)
    with open_map(path, in_place=True) as lazy:
        for name, arr in original.items():
            for other in (arrays[name], lazy[name]):
                assert other.dtype == arr.dtype, name
                np.testing.assert_array_equal(other, arr, err_msg=name)


def test_a_map_rezipped_deflated_predicts_the_same(office: Office, tmp_path: Path) -> None:
    """``aion predict`` (historical, and a forecast for the day after the log) gives the same
    JSON, byte for byte but for the map's name, on the original and on the re-zipped map."""
    path = _deflated(office, tmp_path)
    when = str(T0 // S + 86_400)
    for args in (("--historical",), ("--time", when)):
        want, got = _predict_json(office.map, *args), _predict_json(path, *args)
        assert want["entries"], args  # something to compare
        assert any(e["flow"] > 0 for e in want["entries"]), args
        assert got == want, args


def test_a_damaged_deflate_stream_is_one_error_line(office: Office, tmp_path: Path) -> None:
    """Eight bytes inverted at the start of a member's deflate stream: one ``error:`` line
    naming it, exit code 2 (it was "internal error: Error -3 while decompressing data",
    exit 1: zlib's error escaped the reader)."""
    path = _deflated(office, tmp_path)
    raw = bytearray(path.read_bytes())
    start = member_data_offset(path, MEMBER)
    raw[start : start + 8] = bytes(b ^ 0xA5 for b in raw[start : start + 8])
    path.write_bytes(bytes(raw))
    fails(run("predict", path, "--historical"), f"member {MEMBER} cannot be read")


def test_a_member_inflating_past_its_declared_size_is_one_error_line(
    office: Office, tmp_path: Path
) -> None:
    """A member's zip headers declaring 100 bytes less than it holds: the read stops at
    what they declare and the zip CRC fails; one ``error:`` line, exit code 2."""
    path = _deflated(office, tmp_path)
    with zipfile.ZipFile(path) as zf:
        size = zf.getinfo(MEMBER).file_size
    lie_about_sizes(path, MEMBER, file_size=size - 100)
    fails(run("predict", path, "--historical"), f"member {MEMBER} cannot be read", "CRC")
