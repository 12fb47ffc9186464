"""A tracks file cut inside its last number, where the cut leaves a number that still parses
(``formats.track_tail``): the line is read, and ``aion convert`` warns that it looks cut."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.formats.track_csv import write_canonical_csv
from aion_cli.formats.track_tail import cut_last_line
from aion_cli.formats.tracks import read_tracks
from tests.cli.conftest import run
from tests.shared_data import real


def _thor_text() -> str:
    text = real("thor", "thor1-exp-1-run-2.csv").read_text()
    assert not text.endswith("\n")  # the public file has no line end after its last line
    return text


def _cut_last_value(text: str, keep: int) -> tuple[str, str]:
    """``text`` without its last line's last value beyond ``keep`` characters, and the value."""
    head, last = text.rsplit(",", 1)
    return f"{head},{last[:keep]}", last


def test_real_files_without_a_last_line_end_are_not_flagged(tmp_path: Path) -> None:
    assert cut_last_line(real("thor", "thor1-exp-1-run-2.csv"), "thor") is None
    canonical = tmp_path / "whole.csv"
    write_canonical_csv(read_tracks(real("thor", "thor1-exp-1-run-2.csv"), "thor"), canonical)
    canonical.write_text(canonical.read_text().rstrip("\n"))
    assert cut_last_line(canonical, "canonical") is None


def test_a_last_value_cut_after_its_decimal_point_is_flagged(tmp_path: Path) -> None:
    """THÖR's last line ends ``...,0.322``; cut to ``0.`` it was read as 0 without a word."""
    text = _thor_text()
    cut, whole = _cut_last_value(text, 2)
    assert whole == "0.322"
    assert cut.endswith(",0.")
    path = tmp_path / "cut.csv"
    path.write_text(cut)
    lines = text.count("\n") + 1
    warning = cut_last_line(path, "thor")
    assert warning is not None
    assert f"ends inside line {lines:,}" in warning
    assert "'0.'" in warning
    path.write_text(cut + "\n")  # the same line, ended: a value written as "0." on purpose
    assert cut_last_line(path, "thor") is None


@pytest.mark.parametrize("keep", [1, 3, 6])
def test_a_canonical_value_with_fewer_decimals_than_its_column_is_flagged(
    keep: int, tmp_path: Path
) -> None:
    """aion's canonical CSV writes every speed with six decimals: a last speed with fewer,
    at the end of a file without a last line end, is a cut one."""
    path = tmp_path / "tracks.csv"
    write_canonical_csv(read_tracks(real("thor", "thor1-exp-1-run-2.csv"), "thor"), path)
    whole = path.read_text().rstrip("\n")
    cut, last = _cut_last_value(whole, keep)
    assert len(last.split(".")[1]) == 6
    path.write_text(cut)
    warning = cut_last_line(path, "canonical")
    assert warning is not None
    decimals = max(0, keep - 2)
    says = f"speed_mps {last[:keep]!r}, has {decimals} decimals where every line before it has 6"
    assert says in warning


def test_convert_warns_of_a_cut_last_value(tmp_path: Path) -> None:
    path = tmp_path / "cut.csv"
    path.write_text(_cut_last_value(_thor_text(), 2)[0])
    result = run("convert", path, "--layout", "thor", "-o", tmp_path / "cut.mcap")
    assert result.exit_code == 0, result.stderr
    assert "warning: cut.csv: the file ends inside line" in result.stderr
    assert "looks cut short" in result.stderr
