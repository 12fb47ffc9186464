"""A file refused by the THÖR-MAGNI, Lincoln or Edinburgh reader names the layout it looks
like, as the table readers' refusals do. (Before: a THÖR file given as thor-magni got "THÖR-
MAGNI CSVs start `Time,frame_id,...`", Edinburgh's tracks.01Jul.txt given as lincoln "Lincoln
rows are `t x y`, ...", an ATC file given as edinburgh the Edinburgh entry syntax: each the
refusing layout's own form, never the layout the file is.)"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run

FILES = {  # the first lines of the real files (../shared/data)
    "thor": "0.02,12001,-0.046,-3.443,0.141,2.356\n0.43,12001,-0.077,-3.491,0.1,-1.571\n",
    "atc": "1351038020.969,9190802,-22.311,1.883,0.324,-0.45\n"
    "1351038021.993,9190802,-22.168,2.009,0.601,-0.161\n",
    "edinburgh": "Properties.R1=[3 0 0 0 0 0 0 0];\nTRACK.R1=[[100 240 0];[109 240 9]];\n",
    "lincoln": "1495706022.77 2.54 -0.89 7.90 1.10 WP4\n"
    "1495706023.31 -0.34 5.16 11.53 -4.52 WP11\n",
    "eth": "0.0\t1.0\t9.05\t6.04\n10.0\t1.0\t9.47\t6.24\n",
}


@pytest.mark.parametrize(
    ("given", "actual", "options"),
    [
        ("thor-magni", "thor", ()),
        ("thor-magni", "eth", ()),
        ("lincoln", "edinburgh", ()),
        ("edinburgh", "atc", ("--date", "2010-07-01")),
        ("edinburgh", "lincoln", ("--date", "2010-07-01")),
    ],
)
def test_a_refusal_names_the_layout_the_file_looks_like(
    tmp_path: Path, given: str, actual: str, options: tuple[str, ...]
) -> None:
    src = tmp_path / "tracks.txt"
    src.write_text(FILES[actual])
    result = run("convert", src, "--layout", given, *options, "-o", tmp_path / "t.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr)
    assert result.stderr.splitlines()[-1].endswith(f": pass --layout {actual}"), result.stderr


def test_a_file_like_no_layout_keeps_the_readers_own_hint(tmp_path: Path) -> None:
    src = tmp_path / "tracks.txt"
    src.write_text("a b c d e f g h i\n")
    result = run("convert", src, "--layout", "lincoln", "-o", tmp_path / "t.mcap")
    assert result.exit_code == 2
    assert "hint: Lincoln rows are `t x y`" in result.stderr
