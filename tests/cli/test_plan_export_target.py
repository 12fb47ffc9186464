"""``aion plan --export``: its file is refused before anything is planned."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.cli.conftest import Office, assert_one_line_error, run

AT = "2026-11-23 08:30"


@pytest.mark.parametrize(
    ("name", "fragment"),
    [
        ("theirs.ply", "not a PLY scene aion wrote"),
        ("missing/path.ply", "the folder"),
        ("path.png", "--export writes a .ply file"),
    ],
)
def test_an_export_target_is_refused_before_any_planning(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, fragment: str
) -> None:
    """--export's file is checked before anything is planned, as --png's is: a PLY of someone
    else's, a missing folder or another suffix had been refused only after every departure of
    a --leave was planned. Nothing is planned, and the file of someone else's is unchanged."""
    import aion_cli.routes as routes

    planned: list[str] = []

    def spy(*args: Any, **kwargs: Any) -> Any:
        planned.append("planned")
        raise AssertionError("planned before the --export target was checked")

    monkeypatch.setattr(routes, "plan_routes", spy)
    monkeypatch.setattr(routes, "plan_departures", spy)
    theirs = tmp_path / "theirs.ply"
    theirs.write_bytes(b"ply\nformat ascii 1.0\nelement vertex 0\nend_header\n")
    for when in (["--time", AT], ["--leave", f"{AT}..+2h"]):
        result = run("plan", office.map, "--from", "p0", "--to", "p3", *when,
                     "--export", tmp_path / name)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, fragment)
        assert result.stdout == ""
    assert planned == []
    assert theirs.read_bytes().startswith(b"ply\nformat ascii 1.0\n")
