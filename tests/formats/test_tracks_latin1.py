"""A tracks file with a byte that is not UTF-8 (a Latin-1 ``é``): in a comment it is ignored
as the comment is; in a value, the error names the line and column. (Before: a Latin-1
comment had the file refused as "'utf-8' codec can't decode byte 0xe9 in position 26:
invalid continuation byte", no line, with the layout's columns as the hint -- ATC and THÖR
files streamed in chunks, the ETH / UCY and Lincoln files read whole; a byte in a value was
named by its line already, and still is.)"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run

ROWS = {
    "atc": ["1351038020.0,1,0.0,0.0,1.0,0.0", "1351038021.0,1,1.0,0.0,1.0,0.0"],
    "eth": ["0 1 0.0 0.0", "10 1 0.4 0.0"],
    "lincoln": ["1496999627.0 1.0 2.0", "1496999628.0 1.5 2.0"],
}


@pytest.mark.parametrize("layout", sorted(ROWS))
def test_a_latin1_comment_is_ignored(tmp_path: Path, layout: str) -> None:
    src = tmp_path / "t.csv"
    first, second = ROWS[layout]
    src.write_bytes(f"{first}  # at the café\n{second}\n".encode("latin-1"))
    out = tmp_path / "t.mcap"
    result = run("convert", src, "--layout", layout, "-o", out)
    assert result.exit_code == 0, result.stderr
    assert f"wrote {out}: 2 detections" in result.stderr


@pytest.mark.parametrize("layout", sorted(ROWS))
def test_a_latin1_byte_in_a_value_names_its_line(tmp_path: Path, layout: str) -> None:
    src = tmp_path / "t.csv"
    bad = ROWS[layout][1].replace("1.", "1.é", 1) if layout != "eth" else "10 1 0.é 0.0"
    src.write_bytes("\n".join([ROWS[layout][0], ROWS[layout][0], bad]).encode("latin-1"))
    result = run("convert", src, "--layout", layout, "-o", tmp_path / "t.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "line 3, column", "is not a number")
