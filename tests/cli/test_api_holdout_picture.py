"""docs/API.md's ``aion_cli.evaluation.holdout.hourly_picture(result, path, title)`` for a
``Map.holdout`` result: its ``path`` was typed ``Path`` alone (``mypy`` refused the ``str``
every other path of the API takes), and a bad target was named as the CLI's ``--png``."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.errors import InputError
from aion_cli.evaluation.holdout import HoldoutResult, hourly_picture
from aion_cli.formats.outputs import OutputPathError

HOURS = ["2026-01-12T07:00+00:00", "2026-01-12T08:00+00:00", "2026-01-12T09:00+00:00"]


def _result() -> HoldoutResult:
    """Three test hours, the truth and one model's forecast (as ``Map.holdout`` fills them)."""
    series = {"truth": [0.0, 104.0, 49.0], "aion": [13.8, 100.7, 80.2]}
    return HoldoutResult(hours=HOURS, series=series, test={"timezone": "UTC"})


def test_a_str_path_is_drawn_and_its_path_returned(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    written = hourly_picture(_result(), "hours.png", "title")
    assert written == Path("hours.png")  # a Path, as annotated, for a str given
    data = (tmp_path / "hours.png").read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("name", "error", "message"),
    [
        ("hours.jpg", InputError, "path writes a .png file, got 'hours.jpg'"),
        ("no/such/hours.png", OutputPathError, "cannot write path no/such/hours.png: "),
    ],
)
def test_a_bad_target_is_named_as_the_argument(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, error: type, message: str
) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(error) as caught:
        hourly_picture(_result(), name, "title")
    assert str(caught.value).startswith(message)  # before: "--png writes ...", "--png no/..."
    assert "--png" not in str(caught.value)
    assert list(tmp_path.iterdir()) == []
