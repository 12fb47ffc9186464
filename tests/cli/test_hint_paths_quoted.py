"""A hint that gives a command to type quotes the paths in it as a shell needs them: a folder
or a file named with a space (``my logs/day 1.mcap``) was pasted unquoted, as two words
(``mkdir -p /data/my logs`` made the folders ``/data/my`` and ``./logs``)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

from tests.cli.conftest import SAMPLE, assert_one_line_error, run, run_json
from tests.cli.logdata import write_office_log

THOR_ROWS = "0.02,12001,-0.046,-3.443,0.141,2.356\n0.42,12001,-0.1,-3.4,0.1,2.3\n"


def _words(said: str, command: str) -> list[str]:
    """The shell words of the command in ``said`` that starts with ``command`` and ends at a
    backtick, a closing parenthesis or the end of its line (how the hints set one off)."""
    found = re.search(rf"{re.escape(command)}(?:'[^']*'|[^`)\n'])*", said)
    assert found is not None, (command, said)
    return shlex.split(found.group(0))


def test_the_mkdir_hint_quotes_a_folder_with_a_space(tmp_path: Path) -> None:
    folder = tmp_path / "no such"
    result = run("build", SAMPLE, "-o", folder / "m.aion")
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "does not exist")
    assert _words(result.stderr, "mkdir -p") == ["mkdir", "-p", str(folder)]


def test_a_log_given_as_a_map_and_a_map_as_a_log_are_named_as_one_word(tmp_path: Path) -> None:
    log = tmp_path / "my log.mcap"
    log.write_bytes(SAMPLE.read_bytes())
    given_as_map = run("predict", log, "--time", "2026-01-05 10:00")
    assert given_as_map.exit_code == 2, given_as_map.stderr
    assert _words(given_as_map.stderr, "aion build") == [
        "aion", "build", str(log), "-o", "MAP.aion"
    ]
    as_tracks = run("convert", log, "--layout", "thor", "-o", tmp_path / "x.mcap")
    assert as_tracks.exit_code == 2, as_tracks.stderr
    assert _words(as_tracks.stderr, "aion build") == [
        "aion", "build", str(log), "-o", "MAP.aion"
    ]
    built = tmp_path / "my map.aion"
    run_json("build", log, "-o", built, "--format", "json")
    given_as_log = run("build", built, "-o", tmp_path / "other.aion")
    assert given_as_log.exit_code == 2, given_as_log.stderr
    assert _words(given_as_log.stderr, "aion build LOG") == [
        "aion", "build", "LOG", "--map", str(built)
    ]
    assert _words(given_as_log.stderr, "aion predict") == ["aion", "predict", str(built)]


def test_converts_build_hint_names_an_output_with_a_space_as_one_word(tmp_path: Path) -> None:
    """Convert's note on the dataset's zone (a ``--start`` read in UTC): ``aion build c d.mcap
    --tz Europe/Stockholm`` built two logs, ``c`` and ``d.mcap``."""
    tracks = tmp_path / "thor.csv"
    tracks.write_text(THOR_ROWS)
    result = run("convert", tracks, "--layout", "thor", "--start", "2017-06-01 10:00", "-o",
                 tmp_path / "c d.mcap")  # a start read in UTC: the note's build gives local hours
    assert result.exit_code == 0, result.stderr
    said = " ".join(result.stderr.split())
    assert _words(said.split("if it is UTC, ")[1], "aion build")[:5] == [
        "aion", "build", str(tmp_path / "c d.mcap"), "--tz", "Europe/Stockholm"
    ]


def test_the_rebuild_hint_of_an_older_log_quotes_its_path(tmp_path: Path) -> None:
    """A log older than the map's closed windows: the hint's ``aion build`` lists the map's
    logs and the new one, each as one word."""
    folder = tmp_path / "two days"
    folder.mkdir()
    old, new = folder / "day 0.mcap", folder / "day 1.mcap"
    write_office_log(old)
    write_office_log(new, shift_s=86400)
    run_json("build", new, "-o", tmp_path / "m.aion", "--format", "json")
    result = run("build", old, "--map", tmp_path / "m.aion", "-o", tmp_path / "m2.aion")
    assert result.exit_code == 2, result.stderr
    said = " ".join(result.stderr.split())
    words = _words(said, "aion build")
    assert words[-2:] == ["-o", "NEW.aion"], said
    assert "day 1.mcap" in words, said  # the map's log, by the name the map keeps
    assert str(old) in words, said
    assert not (tmp_path / "m2.aion").exists()
