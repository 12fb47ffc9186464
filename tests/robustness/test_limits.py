"""Values outside what aion can represent are input errors with a message, never an internal
error or a hang: times outside the int64-nanosecond range, series steps below a second, maps
whose stored model config is out of range; and strings from a log cannot drive the terminal.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import pytest

from tests.robustness.conftest import (
    Office,
    assert_one_error,
    rewrite_map,
    run,
    walk,
    write_log,
)

ESC = "\x1b"

# -- times ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "when",
    [
        "2300-01-01",  # past 2262: int64 nanoseconds overflow
        "1800-06-01 12:00",
        "99999999999999999999ns",
        "@-9999999999",  # 1653, as UNIX seconds (a bare negative number needs a unit or @)
        "+100000000w",
        "now+9999999999999999999999s",
    ],
)
def test_times_outside_the_representable_range_are_exit_2(
    office: Office, tmp_path: Path, when: str
) -> None:
    out = tmp_path / "out"
    for command in ("predict", "export", "plan"):
        args: tuple[Any, ...] = (command, office.map, "--time", when)
        if command == "export":
            args = (*args, "-o", out)
        if command == "plan":
            args = (*args, "--from", "p0", "--to", "p3")
        result = run(*args)
        assert result.exit_code == 2, (command, when, result.stderr)
        assert_one_error(result.stderr, "outside the range aion handles", "1900-01-01")
    assert not out.exists()


def test_the_edges_of_the_time_range_are_accepted(office: Office) -> None:
    for when in ("2261-01-01", "1900-01-01", "1969-12-31 23:59"):
        result = run("predict", office.map, "--time", when, "--format", "json")
        assert result.exit_code == 0, (when, result.stderr)


@pytest.mark.parametrize(
    ("step", "fragment"),
    [
        ("0.0000000001s", "--step must be at least 1 s"),  # was a ZeroDivisionError
        ("0.5", "--step must be at least 1 s"),
        ("9" * 400, "longer than the time range"),  # float inf: was an OverflowError
    ],
)
def test_bad_series_steps_are_exit_2_and_write_nothing(
    office: Office, tmp_path: Path, step: str, fragment: str
) -> None:
    out = tmp_path / "series"
    result = run("export", office.map, "--from", "2026-11-23 08:00", "--to",
                 "2026-11-23 09:00", "--step", step, "-o", out)  # fmt: skip
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, fragment)
    assert not out.exists()


# -- a map's stored config --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("key", "value", "fragment"),
    [
        ("window_s", 1e-6, "window_s must be at least 1 s"),
        ("profile_bin_s", 1.0, "must be at least window_s"),
        ("cell_size", 1e-9, "cell_size must be in"),
        ("bins", "8", "bins must be an integer"),
    ],
)
def test_a_map_with_an_invalid_stored_config_is_a_clear_error(
    office: Office, tmp_path: Path, key: str, value: Any, fragment: str
) -> None:
    def edit(manifest: dict[str, Any]) -> None:
        manifest["state"]["config"][key] = value

    bad = rewrite_map(office.map, tmp_path / "bad.aion", manifest_edit=edit)
    for args in (("predict", bad, "--historical"), ("build", "--map", bad, office.log)):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_error(result.stderr, "stored model configuration is invalid", fragment)


# -- terminal safety --------------------------------------------------------------------------


def test_printable_makes_every_control_sequence_visible() -> None:
    from aion_cli.cli.output import markup_safe, printable

    assert printable("/people\x1b[2J\x1b]0;owned\x07") == "/people\\x1b[2J\\x1b]0;owned\\x07"
    assert printable("a\nb\tc\rd\x00\x7f\x9b") == "a\\nb\\tc\\rd\\x00\\x7f\\x9b"
    assert printable("file\u202egnp.exe") == "file\\u202egnp.exe"  # right-to-left override
    assert printable("Café /ロボット [1]") == "Café /ロボット [1]"  # text is kept
    assert printable(42) == "42"
    assert markup_safe("[red]x[/red]\x1b") == "\\[red]x\\[/red]\\x1b"


def test_table_cells_are_escaped_and_never_read_as_markup(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from rich.console import Console

    import aion_cli.cli.console as console_module
    from aion_cli.cli.output import Column, render_table

    buf = io.StringIO()
    monkeypatch.setattr(console_module, "_OUT", Console(file=buf, width=200, force_terminal=True))
    rows = [{"id": "p1\x1b[31mred\x1b[0m", "label": "[bold]lobby[/bold] [/oops]"}]
    render_table(rows, [Column("id", "id\x07"), Column("label", "label")], title="t\x1b[2J")
    text = buf.getvalue()
    assert "p1\\x1b[31mred\\x1b[0m" in text
    assert "[bold]lobby[/bold] [/oops]" in text  # shown as typed, no MarkupError
    assert "\\x1b[2J" in text
    assert "\\x07" in text
    # the only escape sequences are rich's own styling (SGR "...m"), none from the data
    import re

    assert not re.search(r"\x1b\[(?![0-9;]*m)", text)
    assert "\x1b[31mred" not in text
    assert "\x07" not in text


def test_a_topic_name_with_escape_sequences_reaches_stderr_escaped(tmp_path: Path) -> None:
    """A log whose only detection topic is named ``/tr<ESC>[2Jacks<BEL>`` (clears the screen
    when printed raw): the build's error line names it as ``/tr\\x1b[2Jacks\\x07``."""
    topic = "/tr" + ESC + "[2Jacks\x07"
    log = write_log(tmp_path / "esc.mcap", [(topic, m[1], m[2], m[3]) for m in walk(5)])
    result = run("build", log, "--detections-topic", "/people", "-o", tmp_path / "x.aion")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "/people")
    assert "--detections-topic /tr\\x1b[2Jacks\\x07" in result.stderr
    assert ESC not in result.stderr
    assert "\x07" not in result.stderr


def test_notes_and_warnings_are_plain_text(capsys: pytest.CaptureFixture[str]) -> None:
    from aion_cli.cli.console import note, warn

    note("read /cam\x1b[2J [red]done[/red]")
    warn("topic /x\x1b]0;t\x07 [/bad]")
    err = capsys.readouterr().err
    assert "read /cam\\x1b[2J [red]done[/red]" in err
    assert "topic /x\\x1b]0;t\\x07 [/bad]" in err
    assert ESC not in err
