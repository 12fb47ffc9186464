"""Tracks files refused: bad lines named by number and column, empty and missing files, a
file of another layout named by the layout it looks like (``formats.track_csv``,
``formats.track_sniff``)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from aion_cli.errors import InputError
from aion_cli.formats import track_csv, track_types
from aion_cli.formats import tracks as ft


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_bad_files_name_the_line(tmp_path: Path) -> None:
    good = "1.0,5,0.1,0.2,0.3,0.4\n"
    cols = _write(tmp_path, "cols.csv", good * 3 + "2.0,5,0.1,0.2,0.3\n")
    with pytest.raises(track_types.TracksFormatError, match=r"line 4: expected 6 columns .* got 5"):
        ft.read_tracks(cols, "atc")
    text = _write(tmp_path, "text.csv", good + "\n" + "2.0,5,abc,0.2,0.3,0.4\n")
    with pytest.raises(track_types.TracksFormatError, match=r"line 3, column 3 \(x_m\): 'abc'"):
        ft.read_tracks(text, "atc")
    frac = _write(tmp_path, "frac.csv", good + "2.0,5.5,0,0,0,0\n")
    with pytest.raises(
        track_types.TracksFormatError, match=r"line 2, column 2 \(person_id\).*integer"
    ):
        ft.read_tracks(frac, "thor")
    nan_t = _write(tmp_path, "nan.csv", "nan,5,0,0,0,0\n")
    with pytest.raises(track_types.TracksFormatError, match=r"line 1, column 1 \(time_s\).*finite"):
        ft.read_tracks(nan_t, "atc")
    eth = _write(tmp_path, "eth.txt", "10 1 0.5 0.5\n20 1 0.5\n")
    with pytest.raises(track_types.TracksFormatError, match=r"line 2: expected 4 columns"):
        ft.read_tracks(eth, "eth")


def test_empty_missing_and_wrong_layout(tmp_path: Path) -> None:
    with pytest.raises(track_types.TracksFormatError, match="no track rows"):
        ft.read_tracks(_write(tmp_path, "empty.csv", ""), "atc")
    with pytest.raises(track_types.TracksFormatError, match="no track rows"):
        ft.read_tracks(_write(tmp_path, "empty2.csv", ""))
    with pytest.raises(track_types.TracksFormatError, match="no track rows"):
        ft.read_tracks(_write(tmp_path, "hdr.csv", track_csv.CANONICAL_HEADER + "\n"))
    with pytest.raises(track_types.TracksFormatError, match="no track rows"):
        ft.read_tracks(_write(tmp_path, "blank.csv", "\n\n# comment only\n"), "atc")
    one_col = _write(tmp_path, "one.csv", "1\n2\n3\n4\n5\n6\n")
    with pytest.raises(track_types.TracksFormatError, match=r"line 1: expected 6 columns .* got 1"):
        ft.read_tracks(one_col, "atc")
    single = ft.read_tracks(_write(tmp_path, "single.csv", "1.5,3,0.1,0.2,0.3,0.4\n"), "atc")
    assert single.t_ns.tolist() == [1_500_000_000]
    assert single.track_id.tolist() == [3]
    with pytest.raises(track_types.TracksFormatError, match="not found"):
        ft.read_tracks(tmp_path / "missing.csv", "atc")
    atc_rows = _write(tmp_path, "atc.csv", "1351038020.969,9190802,-22.311,1.883,0.324,-0.45\n")
    with pytest.raises(track_types.TracksFormatError, match="header"):
        ft.read_tracks(atc_rows)  # an ATC file read as canonical
    bad_canon = _write(tmp_path, "c.csv", track_csv.CANONICAL_HEADER + "\n1.5,1,0,0,0,0,0\n")
    with pytest.raises(track_types.TracksFormatError, match=r"line 2, column 1 \(t_ns\).*integer"):
        ft.read_tracks(bad_canon)
    with pytest.raises(track_types.TracksFormatError, match="unknown tracks layout"):
        ft.read_tracks(atc_rows, "csv")
    assert issubclass(track_types.TracksFormatError, InputError)


# ----------------------------------------------------------------------------- logs


def test_a_file_of_another_layout_is_refused_naming_the_one_it_looks_like(
    tmp_path: Path,
) -> None:
    """Read with a layout it does not fit, a file's refusal names the layout it resembles
    (any layout given, not only the default)."""
    eth = _write(tmp_path, "eth.txt", "".join(f"{10 * k}\t{k % 3}\t1.5\t2.5\n" for k in range(8)))
    with pytest.raises(track_types.TracksFormatError) as caught:
        ft.read_tracks(eth, "atc")
    assert caught.value.hint == (
        "it looks like the eth or ucy layout (rows `frame ped_id x y`): pass --layout eth"
    )
    atc = _write(tmp_path, "atc.csv", "1351038020.969,9190802,-22.311,1.883,0.324,-0.45\n" * 3)
    with pytest.raises(track_types.TracksFormatError) as caught:
        ft.read_tracks(atc, "eth")
    assert caught.value.hint is not None
    assert "pass --layout atc" in caught.value.hint
    odd = _write(tmp_path, "odd.csv", "a,b\n")  # like no layout: the columns of the one given
    with pytest.raises(track_types.TracksFormatError) as caught:
        ft.read_tracks(odd, "atc")
    assert caught.value.hint is not None
    assert caught.value.hint.startswith("atc columns: ")


def test_times_beyond_a_containers_header_stamps_are_refused(tmp_path: Path) -> None:
    """ROS 2 stamps hold seconds as int32 (to 2038-01-19), ROS 1 as uint32 (to 2106): a
    later time is a LogTimeError naming the limit, not a struct error, and nothing is
    written; a ROS 1 log takes 2040."""
    import numpy as np

    from aion_cli.engine.types import DetectionBatch
    from aion_cli.formats import tracks_log
    from aion_cli.formats.writers import LogTimeError, max_stamp_ns

    t2040 = 2_208_988_800 * 10**9
    batch = DetectionBatch.from_arrays(
        t2040 + np.arange(3) * 10**9, np.zeros((3, 3)), np.zeros(3), track_id=np.arange(3)
    )
    with pytest.raises(LogTimeError, match="2038-01-19 03:14:07 UTC"):
        tracks_log.tracks_to_log(batch, tmp_path / "late.mcap")
    assert not (tmp_path / "late.mcap").exists()
    summary = tracks_log.tracks_to_log(batch, tmp_path / "late.bag", container="bag")
    assert summary.detection_messages == 3
    assert max_stamp_ns("bag") == (2**32 - 1) * 10**9 + 999_999_999
    assert max_stamp_ns("mcap") == (2**31 - 1) * 10**9 + 999_999_999


def test_observed_spans_of_decades_are_refused_before_anything_is_written() -> None:
    """A 1970 start (a typo) asked for 59 million empty marker messages and ran for minutes."""
    from aion_cli.formats.observed_marks import MOST_OBSERVED_MARKS, observed_stamps

    day = 86_400 * 10**9
    with pytest.raises(InputError, match=r"cover 56\.0 years"):
        observed_stamps([(0, 20_454 * day)])  # 1970-01-01 .. 2026-01-01
    year = observed_stamps([(0, 365 * day)])  # a year is fine
    assert year.size == 365 * 2880 + 1
    assert year.size < MOST_OBSERVED_MARKS


@pytest.mark.parametrize(("layout", "big"), [("thor", "99999999999999999999999"), ("atc", "1e30")])
def test_an_id_beyond_64_bits_names_its_line_not_a_wrapped_value(
    layout: str, big: str, tmp_path: Path
) -> None:
    """A person id no int64 holds, in the first 20 rows of a real THÖR file: ``aion convert``
    said "TrackedPersons needs track ids of 0 or more, a row has -9223372036854775808" (the
    id wrapped around; no line named). The file is refused naming the line and the value."""
    from tests.robustness.conftest import assert_one_error, run
    from tests.shared_data import real

    rows = real("thor", "thor1-exp-1-run-2.csv").read_text().splitlines()[:20]
    fields = rows[10].split(",")
    fields[1] = big
    rows[10] = ",".join(fields)
    path = _write(tmp_path, "big.csv", "\n".join(rows) + "\n")
    where = rf"line 11, column 2 \(person_id\): '{big}' is beyond the 64-bit integers"
    with pytest.raises(track_types.TracksFormatError, match=where):
        ft.read_tracks(path, layout)
    result = run("convert", path, "--layout", layout, "-o", tmp_path / "big.mcap")
    assert result.exit_code == 2
    assert_one_error(result.stderr, f"line 11, column 2 (person_id): '{big}'")
    assert "-9223372036854775808" not in result.stderr


def test_a_zeroed_block_is_named_in_a_short_line(tmp_path: Path) -> None:
    """4 KiB of NUL bytes in a real THÖR file (a disk block zeroed by a crash): the error
    quoted the whole field, a 16 KB "line"; it now quotes its first 40 characters."""
    from tests.robustness.conftest import assert_one_error, run
    from tests.shared_data import real

    rows = real("thor", "thor1-exp-1-run-2.csv").read_text().splitlines()[:20]
    fields = rows[10].split(",")
    fields[2] = "\x00" * 4096
    rows[10] = ",".join(fields)
    path = _write(tmp_path, "zeroed.csv", "\n".join(rows) + "\n")
    result = run("convert", path, "--layout", "thor", "-o", tmp_path / "z.mcap")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "line 11, column 3 (x_m): '" + "\\x00" * 40 + "' is not")
    assert len(result.stderr.splitlines()[0]) < 400


@pytest.mark.parametrize(
    ("layout", "encoding", "name"),
    [
        ("thor", "utf-16", "UTF-16"),  # with its byte-order mark, as Windows saves "Unicode"
        ("atc", "utf-16-le", "UTF-16LE"),  # without one
        ("thor", "utf-16-be", "UTF-16BE"),
        ("thor", "utf-32", "UTF-32"),
    ],
)
def test_a_utf16_file_is_named_as_such(
    layout: str, encoding: str, name: str, tmp_path: Path
) -> None:
    """Real THÖR rows saved as UTF-16 or UTF-32 were refused as "line 1, column 1 (time_s):
    '\\xff\\xfe0\\x00.\\x000\\x00' is not a number"; the error now names the encoding and the
    hint how to convert the file (which, converted, reads as the rows it holds)."""
    from tests.robustness.conftest import assert_one_error, run
    from tests.shared_data import real

    text = "\n".join(real("thor", "thor1-exp-1-run-2.csv").read_text().splitlines()[:20]) + "\n"
    path = tmp_path / "wide.csv"
    path.write_bytes(text.encode(encoding))
    result = run("convert", path, "--layout", layout, "-o", tmp_path / "w.mcap")
    assert result.exit_code == 2
    assert_one_error(result.stderr, f"the file is {name} text")
    assert f"iconv -f {name} -t UTF-8 {shlex.quote(str(path))} > wide-utf8.csv" in (
        result.stderr.splitlines()[1]
    )
    path.write_bytes(path.read_bytes().decode(encoding).encode())  # what iconv makes of it
    assert len(ft.read_tracks(path, layout)) == 20


@pytest.mark.parametrize(
    ("layout", "source", "separator", "says"),
    [
        ("thor", ("thor", "thor1-exp-1-run-2.csv"), ";", "semicolons, not commas"),
        ("atc", ("atc", "atc-1024-9_test.csv"), "\t", "tabs, not commas"),
        ("eth", ("thor", "thor1-exp-1-run-2.csv"), ",", "commas, not white space"),
    ],
)
def test_a_file_with_another_separator_is_named_by_it(
    layout: str, source: tuple[str, str], separator: str, says: str, tmp_path: Path
) -> None:
    """Real rows written with another field separator (a spreadsheet's semicolons or tabs;
    ETH's columns with commas) were refused as "expected 6 columns ..., got 1" and nothing
    more; the error now says which separator the file uses instead."""
    from tests.shared_data import real

    rows = real(*source).read_text().splitlines()[:20]
    if layout == "eth":  # frame, id, x, y of the THÖR rows, comma-separated
        rows = [",".join(str(round(float(v))) for v in r.split(",")[:4]) for r in rows]
    else:
        rows = [r.replace(",", separator) for r in rows]
    path = _write(tmp_path, "other.csv", "\n".join(rows) + "\n")
    with pytest.raises(track_types.TracksFormatError) as caught:
        ft.read_tracks(path, layout)
    assert caught.value.message.endswith(f"got 1: its fields are separated by {says}")


@pytest.mark.parametrize("layout", ["thor", "eth"])
def test_a_file_cut_inside_its_last_line_says_so(layout: str, tmp_path: Path) -> None:
    """A tracks file cut short (a copy that did not finish) ends inside a line: the error named
    the line and the columns, as for any bad line; it now says the file ends inside it, and
    the hint that the lines before it can be read. A bad line followed by a line end keeps
    the columns hint."""
    from tests.shared_data import real

    if layout == "thor":
        text = real("thor", "thor1-exp-1-run-2.csv").read_text()
    else:
        text = real("tracks", "eth_ucy", "biwi_eth.txt").read_text()
    cut = text[: len(text) // 3]
    lines = cut.count("\n") + 1
    assert not cut.endswith("\n")
    path = _write(tmp_path, "cut.csv", cut)
    with pytest.raises(track_types.TracksFormatError) as caught:
        ft.read_tracks(path, layout)
    message, hint = caught.value.message, caught.value.hint or ""
    assert message.startswith(f"{path}: not a valid {layout} tracks file: line {lines}: ")
    assert message.endswith("(the file ends inside this line)")
    assert f"last line, line {lines:,}" in hint
    path.write_text(cut + "\n" + text[len(cut) :])  # the same line, ended, with more after
    with pytest.raises(track_types.TracksFormatError) as whole:
        ft.read_tracks(path, layout)
    assert "ends inside" not in whole.value.message
    assert (whole.value.hint or "").startswith(f"{layout} columns:")


def test_an_edinburgh_file_cut_inside_its_last_entry_says_so(tmp_path: Path) -> None:
    from tests.shared_data import real

    text = real("tracks", "edinburgh", "tracks.01Jul.txt").read_text()
    cut = text[:20000]
    assert not re.search(r"\]\s*\]\s*;\s*$", cut)  # inside an entry
    before = cut.count("TRACK.R") - 1
    path = _write(tmp_path, "cut.txt", cut)
    with pytest.raises(track_types.TracksFormatError) as caught:
        ft.read_tracks(path, "edinburgh")
    assert caught.value.message.endswith("(the file ends inside it)")
    assert f"the {before:,} TRACK entries before it can be read" in (caught.value.hint or "")


@pytest.mark.parametrize(
    ("value", "column", "layout"),
    [("nan", 5, "atc"), ("inf", 5, "thor"), ("nan", 6, "thor"), ("-inf", 6, "atc")],
)
def test_a_speed_or_motion_angle_that_is_not_finite_names_its_line(
    tmp_path: Path, value: str, column: int, layout: str
) -> None:
    """ATC / THÖR speed and motion-angle columns are measured values like x and y: a NaN or
    an infinity there names its line and column, read whole or streamed a few rows at a time
    (the line counted from the file's top, not the chunk's). Before, the file was read
    without a word (an infinite angle with numpy's "invalid value encountered in remainder"
    on stderr) and its rows written with an unknown direction or speed."""
    rows = [f"{1351038020 + k},7,{0.5 * k},1.0,1.2,0.1" for k in range(9)]
    fields = rows[6].split(",")
    fields[column - 1] = value
    rows[6] = ",".join(fields)
    path = _write(tmp_path, "tracks.csv", "\n".join(rows) + "\n")
    name = track_csv.ATC_COLUMNS[column - 1]
    where = rf"line 7, column {column} \({name}\): '{re.escape(value)}' is not finite"
    with pytest.raises(track_types.TracksFormatError, match=where):
        ft.read_tracks(path, layout)
    with pytest.raises(track_types.TracksFormatError, match=where):
        list(track_csv.track_chunks(path, layout, rows=4))


@pytest.mark.parametrize("layout", ["eth", "ucy"])
def test_a_bad_line_names_the_layout_it_was_read_as(tmp_path: Path, layout: str) -> None:
    """``--layout ucy`` reads the same columns as eth; a bad line's refusal names the layout
    the user gave (it said "not a valid eth tracks file" and "eth columns" for ucy)."""
    path = _write(tmp_path, "students.txt", "0 1 0.5 0.5\n10 1 0.9 abc\n")
    with pytest.raises(track_types.TracksFormatError) as caught:
        ft.read_tracks(path, layout)
    assert f"not a valid {layout} tracks file: line 2, column 4 (y)" in caught.value.message
    assert caught.value.hint == f"{layout} columns: frame, ped_id, x, y"


@pytest.mark.parametrize("layout", ["atc", "thor"])
def test_a_negative_speed_names_its_line(tmp_path: Path, layout: str) -> None:
    """An ATC / THÖR speed is a magnitude (the direction is the motion angle): a negative one
    is refused like a NaN, naming line and column, read whole, streamed in chunks and by
    ``aion convert`` (one line, exit 2). Before, ``1351038020,1,0,0,-3,0`` was read without a
    word and the row's velocity pointed 180 degrees away from its angle."""
    from tests.cli.conftest import assert_one_line_error, run

    rows = [f"{1351038020 + k},7,{0.5 * k},1.0,1.2,0.1" for k in range(9)]
    rows[6] = "1351038026,7,3.0,1.0,-3,0"
    rows.append("1351038030,7,4.5,1.0,-0.0,0.1")  # a signed zero is no negative speed
    path = _write(tmp_path, "tracks.csv", "\n".join(rows) + "\n")
    where = r"line 7, column 5 \(speed_mps\): '-3' is negative"
    with pytest.raises(track_types.TracksFormatError, match=where):
        ft.read_tracks(path, layout)
    with pytest.raises(track_types.TracksFormatError, match=where):
        list(track_csv.track_chunks(path, layout, rows=4))
    result = run("convert", path, "--layout", layout, "-o", tmp_path / "x.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "line 7, column 5 (speed_mps): '-3' is negative")
    assert not (tmp_path / "x.mcap").exists()
    del rows[6]
    fixed = _write(tmp_path, "fixed.csv", "\n".join(rows) + "\n")
    assert len(ft.read_tracks(fixed, layout)) == 9
