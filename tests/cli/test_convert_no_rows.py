"""A tracks file without a detection row (0 bytes, a header only) from a sensor that ran while
nobody came: with ``--observed`` spans ``aion convert`` writes the log that marks them (as
``tracks_to_log`` does for an empty batch), so a night with nobody counts as observed and
empty when built with the other days' logs; without spans it stays an error, whose hint says
what the file holds and that spans make it a log."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run

HEADER = "t_ns,track_id,x,y,z,heading_rad,speed_mps\n"


@pytest.mark.parametrize(
    ("layout", "text"),
    [("canonical", HEADER), ("canonical", ""), ("atc", ""), ("atc", "# nobody\n"),
     ("ucy", ""), ("lincoln", "")],
)
def test_no_rows_with_observed_spans_is_a_log_of_the_spans(
    tmp_path: Path, layout: str, text: str
) -> None:
    src = tmp_path / "night.csv"
    src.write_text(text)
    log = tmp_path / "night.mcap"
    result = run(
        "convert", src, "--layout", layout, "-o", log,
        "--observed", "2026-01-05 20:00..2026-01-05 22:00",
    )
    assert result.exit_code == 0, result.stderr  # before: error: no track rows
    assert "the log marks the --observed spans only" in result.stderr
    assert "marked by 241 empty detection messages" in result.stderr
    assert "fixed sensor over the 12 windows" in run("info", log).stderr


def test_header_only_without_spans_is_an_error_that_says_so(tmp_path: Path) -> None:
    src = tmp_path / "night.csv"
    src.write_text(HEADER)
    result = run("convert", src, "-o", tmp_path / "night.mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "no track rows")
    # before: "hint: the file is empty" for a file of one header line
    assert "hint: the file has only its header line" in result.stderr
    assert "--observed" in result.stderr
    assert not (tmp_path / "night.mcap").exists()


def test_a_lincoln_header_alone_is_a_log_of_its_declared_span(tmp_path: Path) -> None:
    """A Lincoln file of its three header lines only declares the span it recorded
    (``t_start t_end``): nobody came, and that span is as good as --observed. (Before:
    'error: no track rows' with the hint to give --observed spans the file already states.)
    2 h from 20:00 UTC: 240 marks every 30 s and the span's last instant = 241, 12 windows."""
    src = tmp_path / "night.txt"
    start = 1767643200  # 2026-01-05 20:00 UTC
    src.write_text(f"{start} {start + 7200}\n-8 12\n-3 17\n")
    log = tmp_path / "night.mcap"
    result = run("convert", src, "--layout", "lincoln", "-o", log)
    assert result.exit_code == 0, result.stderr
    assert "the log marks its header's declared span only (nobody came)" in result.stderr
    assert "marked by 241 empty detection messages" in result.stderr
    assert "fixed sensor over the 12 windows" in run("info", log).stderr


def test_an_edinburgh_file_of_its_header_comment_alone_is_a_file_without_rows(
    tmp_path: Path,
) -> None:
    """A day of the Edinburgh Forum database on which nobody was tracked holds its header
    comment only ("% Total number of trajectories in file are 0"): like an empty file, it is
    "no track rows", and with --observed a log of the spans. (Before: "no TRACK.Rn=[[x y
    frame];...]; entry" with the hint describing the layout it has, even with --observed.)"""
    src = tmp_path / "tracks.05Jul.txt"
    src.write_text("% Total number of trajectories in file are  0 \n\n")
    log = tmp_path / "night.mcap"
    date = ("--layout", "edinburgh", "--date", "2026-01-05")
    refused = run("convert", src, *date, "-o", log)
    assert refused.exit_code == 2
    assert_one_line_error(refused.stderr, "no track rows")
    assert "--observed" in refused.stderr
    result = run("convert", src, *date, "-o", log,
                 "--observed", "2026-01-05 20:00..2026-01-05 22:00")
    assert result.exit_code == 0, result.stderr
    assert "the log marks the --observed spans only" in result.stderr
    assert "marked by 241 empty detection messages" in result.stderr
    assert "fixed sensor over the 12 windows" in run("info", log).stderr
