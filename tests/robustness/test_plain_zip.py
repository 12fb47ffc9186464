"""A zip archive that holds no aion manifest (``a.txt`` only) is said to be one, with the same
line wherever a map or a log belongs. Before, ``aion info`` said it could not tell the log
format (hinting at log formats), and ``predict`` / ``export`` / ``report`` / ``merge`` /
``build --map`` named its first member "unsafe or unexpected"."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

from tests.cli.conftest import assert_one_line_error, run

S = 1_000_000_000
T0 = 1_700_000_000 * S
SAID = "is a zip archive without an aion map manifest (no manifest.json inside)"


@pytest.fixture
def plain(tmp_path: Path) -> Path:
    path = tmp_path / "plain.zip"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("a.txt", "x")
    return path


@pytest.mark.parametrize(
    "command",
    [
        ["info", "{zip}"],
        ["predict", "{zip}"],
        ["export", "{zip}", "-o", "{tmp}/x.json"],
        ["report", "{zip}", "-o", "{tmp}/r"],
        ["merge", "{zip}", "{tmp}/other.zip", "-o", "{tmp}/m.aion"],
        ["build", "{log}", "--map", "{zip}", "-o", "{tmp}/b.aion"],
        ["build", "{zip}", "-o", "{tmp}/c.aion"],
    ],
    ids=lambda c: " ".join(c[:3]),
)
def test_a_plain_zip_is_said_to_be_one(command: list[str], plain: Path, tmp_path: Path) -> None:
    from aion_cli.formats.writers import LogWriter

    (tmp_path / "other.zip").write_bytes(plain.read_bytes())
    log = tmp_path / "small.mcap"
    with LogWriter(log, "mcap") as w:
        for k in range(5):
            w.write("/chatter", "std_msgs/msg/String", {"data": f"m{k}"}, T0 + k * S)
    args = [a.format(zip=plain, tmp=tmp_path, log=log) for a in command]
    result = run(*args)
    assert result.exit_code == 2, result.output
    assert_one_line_error(result.stderr, f"{plain} {SAID}", "neither an aion map nor a log")
    assert "unsafe" not in result.stderr
    assert "cannot tell the log format" not in result.stderr
    assert not list(tmp_path.glob("*.aion")), "nothing is written"


def test_a_plain_zip_read_as_mcap_says_it_is_no_map(plain: Path) -> None:
    result = run("info", plain, "--log-format", "mcap")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "looks like a zip archive without an aion map manifest")


def test_a_map_that_lost_its_manifest_is_told_the_same(tmp_path: Path) -> None:
    """A real map with manifest.json removed: the same words, the hint says it is damaged."""
    from tests.cli.logdata import write_office_log

    write_office_log(tmp_path / "office.mcap")
    built = tmp_path / "office.aion"
    assert run("build", tmp_path / "office.mcap", "-o", built).exit_code == 0
    damaged = tmp_path / "lost.aion"
    with zipfile.ZipFile(built) as src, zipfile.ZipFile(damaged, "w") as dst:
        for info in src.infolist():
            if info.filename != "manifest.json":
                dst.writestr(info, src.read(info))
    result = run("predict", damaged)
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, SAID)
    assert "rebuild it from the logs" in result.stderr
