"""``-o -`` is no standard output for aion: ``aion compact MAP -o - > robot.aion`` wrote the
query-only map to a file named ``-`` in the current folder, printed its summary, exited 0 and
left ``robot.aion`` empty; ``aion export`` and ``aion report`` made a folder named ``-``. A
path of ``-`` is now refused (exit 2, one line) before anything is read or written."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run


@pytest.mark.parametrize(
    "args",
    [
        ["compact", "{map}", "-o", "-"],
        ["export", "{map}", "--historical", "-o", "-"],
        ["report", "{map}", "-o", "-"],
        ["predict", "-", "--historical"],
    ],
    ids=["compact", "export", "report", "a map read from '-'"],
)
def test_a_dash_path_is_refused_and_nothing_is_written(
    args: list[str], sample_map: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    result = run(*(a.format(map=sample_map) for a in args))
    assert result.exit_code == 2
    assert result.stdout == ""
    assert_one_line_error(result.stderr, "'-' is not standard input or output here")
    assert list(tmp_path.iterdir()) == []  # no file or folder named '-', no lock


def test_a_file_called_dash_is_named_as_such(
    sample_map: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The way out the error names: ``./-`` is a file called ``-``."""
    monkeypatch.chdir(tmp_path)
    result = run("compact", sample_map, "-o", "./-", "-q")
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "-").read_bytes()[:2] == b"PK"  # a map: a zip container
