"""A compressed tracks file (as datasets are often downloaded: atc.csv.gz) is refused as what
it is, with the command that unpacks it, for every layout.
(Before: "line 1: expected 6 columns (...), got 1 (the file ends inside this line)" with the
hint "the file looks cut short (a copy or an export that did not finish)".)"""

from __future__ import annotations

import bz2
import gzip
import lzma
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run

ATC = b"1351038020.0,1,0.0,0.0,1.0,0.0\n1351038021.0,1,1.0,0.0,1.0,0.0\n"
LAYOUTS = [("atc",), ("eth",), ("canonical",), ("lincoln",), ("thor-magni",),
           ("edinburgh", "--date", "2010-07-01")]


def _zip(data: bytes) -> bytes:
    import io

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("atc.csv", data)
    return buffer.getvalue()


PACKED = [
    ("atc.csv.gz", gzip.compress, "gzip", "gunzip -k atc.csv.gz"),
    ("atc.csv.bz2", bz2.compress, "bzip2", "bunzip2 -k atc.csv.bz2"),
    ("atc.csv.xz", lzma.compress, "xz", "unxz -k atc.csv.xz"),
    ("atc.zip", _zip, "zip", "unzip atc.zip"),
]


@pytest.mark.parametrize("layout", LAYOUTS, ids=lambda x: x[0])
@pytest.mark.parametrize(("name", "pack", "kind", "command"), PACKED, ids=lambda x: str(x)[:6])
def test_a_compressed_file_says_how_to_unpack_it(
    tmp_path: Path,
    layout: tuple[str, ...],
    name: str,
    pack: Callable[[bytes], bytes],
    kind: str,
    command: str,
) -> None:
    src = tmp_path / name
    src.write_bytes(pack(ATC))
    out = tmp_path / "t.mcap"
    result = run("convert", src, "--layout", *layout, "-o", out)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, f"{name}: the file is {kind}-compressed")
    assert f"hint: unpack it first: {command}" in result.stderr
    assert not out.exists()


def test_the_unpacked_file_converts(tmp_path: Path) -> None:
    src = tmp_path / "atc.csv"
    src.write_bytes(gzip.decompress(gzip.compress(ATC)))
    result = run("convert", src, "--layout", "atc", "-o", tmp_path / "t.mcap")
    assert result.exit_code == 0, result.stderr
