"""THÖR-MAGNI files cut short, with a short row, or not UTF-8: refused by line number with
one error line, exit 2, as the other layouts refuse them. (Before: a file cut inside its last
row's ``ag_id`` -- ``Helmet_1`` cut to ``Hel`` -- was converted, exit 0, with the note "not
people, skipped: Hel"; cut to ``Helmet_`` it renumbered every agent by rank; a short row was
numpy's "invalid column index 5 at row 4 with 3 columns"; a Latin-1 byte was Python's
"'utf-8' codec can't decode byte 0xe9 in position 56".) And an excerpt of such a file (``head
-n``) is read in the unit the file means."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run
from tests.formats.dataset_files import MAGNI_HEADER

ROWS = [f"{k / 10:.1f},{k},{1000 + 100 * k},2000,0,Helmet_3,a,m,1" for k in range(5)]


def _convert(path: Path, out: Path) -> tuple[int, str]:
    result = run("convert", path, "--layout", "thor-magni", "--start", "2022-05-12 10:00",
                 "-o", out)
    return result.exit_code, result.stderr


@pytest.mark.parametrize("cut", ["Hel", "Helmet_", "Helmet_3", "Helmet_3,a", ""])
def test_a_last_row_cut_short_is_refused_by_its_line(tmp_path: Path, cut: str) -> None:
    last = f"0.5,5,1500,2000,0,{cut}"
    path = tmp_path / "cut.csv"
    path.write_text("\n".join([MAGNI_HEADER, *ROWS, last]))  # no line end: a copy cut short
    out = tmp_path / "cut.mcap"
    code, stderr = _convert(path, out)
    assert code == 2, stderr
    got = last.count(",") + 1
    assert_one_line_error(
        stderr, f"line 7: expected the header's 9 columns, got {got} (the file ends inside"
    )
    assert "without its last line, line 7, the lines before it can be read" in stderr
    assert not out.exists()
    # the lines before it are whole: with the cut line gone, all five rows are written
    path.write_text("\n".join([MAGNI_HEADER, *ROWS]))
    code, stderr = _convert(path, out)
    assert code == 0, stderr
    assert f"wrote {out}: 5 detections of 1 track" in stderr


def test_a_short_row_inside_the_file_is_named_by_its_line(tmp_path: Path) -> None:
    path = tmp_path / "short.csv"
    path.write_text("\n".join([MAGNI_HEADER, *ROWS[:2], "0.2,2,1200", *ROWS[3:]]) + "\n")
    code, stderr = _convert(path, tmp_path / "s.mcap")
    assert code == 2
    assert_one_line_error(stderr, "line 4: expected the header's 9 columns, got 3")


def test_a_latin1_agent_name_is_named_by_its_line(tmp_path: Path) -> None:
    path = tmp_path / "latin1.csv"
    text = "\n".join([MAGNI_HEADER, *ROWS[:2], ROWS[2].replace("Helmet_3", "Helmet_\xe9")])
    path.write_bytes((text + "\n").encode("latin-1"))
    code, stderr = _convert(path, tmp_path / "l.mcap")
    assert code == 2
    assert_one_line_error(stderr, "line 4 is not UTF-8 text")
    assert "iconv" in stderr


def test_an_excerpt_of_people_standing_in_millimetres_is_read_as_millimetres(
    tmp_path: Path,
) -> None:
    """``head -n 4`` of a THÖR-MAGNI file (100 Hz): a helmet at (2,500 mm, 3,000 mm) moving 24
    mm. By the span alone (24 units < 200) it was read as metres: the person 3.9 km from the
    origin. By the reach too it is millimetres: 2.5 m, 3.0 m, as the file means."""
    from aion_cli.formats.tracks import read_track_data

    path = tmp_path / "excerpt.csv"
    rows = [f"0.0{k},{k},{2500 + 12 * k},3000,1700,Helmet_1,a,m,1" for k in range(3)]
    path.write_text("\n".join([MAGNI_HEADER, *rows]) + "\n")
    data = read_track_data(path, "thor-magni")
    assert data.batch.xyz[0].tolist() == pytest.approx([2.5, 3.0, 1.7])
    assert "read as millimetres (they span 0.0 m and reach 3.0 m from the origin)" in data.notes[0]
    # a file in metres stays in metres
    metres = tmp_path / "metres.csv"
    in_m = [f"0.0{k},{k},{2.5 + 0.012 * k},3.0,1.7,Helmet_1,a,m,1" for k in range(3)]
    metres.write_text("\n".join([MAGNI_HEADER, *in_m]) + "\n")
    assert read_track_data(metres, "thor-magni").batch.xyz[0, 1] == pytest.approx(3.0)
