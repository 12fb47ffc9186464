"""The ``aion`` group: help, version, and the one-line error contract."""

from __future__ import annotations

from pathlib import Path

from aion_cli import __version__
from tests.cli.conftest import assert_one_line_error, run, run_process

COMMANDS = ("info", "build", "predict", "plan", "export", "convert", "simulate")


def test_help_lists_every_command_with_examples() -> None:
    result = run("--help")
    assert result.exit_code == 0
    for name in COMMANDS:
        assert f"  {name}" in result.stdout
    assert 'aion predict office.aion --time "2026-11-23 08:30"' in result.stdout


def test_every_command_has_a_worked_example_in_its_help() -> None:
    for name in COMMANDS:
        result = run(name, "--help")
        assert result.exit_code == 0, name
        assert "Examples:" in result.stdout, name
        assert f"aion {name} " in result.stdout.split("Examples:")[1], name


def test_version() -> None:
    result = run("--version")
    assert result.exit_code == 0
    assert __version__ in result.stdout


def test_unknown_command_and_option_are_usage_errors() -> None:
    result = run("frobnicate")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "No such command 'frobnicate'")
    result = run("predict", "x.aion", "--colour", "red")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "--colour")


def test_missing_required_option() -> None:
    result = run("plan", "x.aion", "--from", "p1")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "--to")


def test_internal_errors_exit_1_and_debug_shows_the_traceback(tmp_path: Path) -> None:
    """A fault that is not the user's (here: a map whose state was tampered with into an
    inconsistent shape is reported by the engine as corrupt, exit 2) — and an unexpected
    exception from a library is exit 1 with a hint to use --debug."""
    from click.testing import CliRunner

    import aion_cli.cli.main as main_module
    from aion_cli.cli.errors import report

    class Boom(RuntimeError):
        pass

    assert report(Boom("kaput"), debug=False) == 1
    runner = CliRunner()
    result = runner.invoke(main_module.cli, ["--debug", "frobnicate"])
    assert result.exit_code == 2
    assert "Traceback" in result.stderr


def test_subprocess_missing_map_is_one_line_exit_2(tmp_path: Path) -> None:
    proc = run_process("predict", tmp_path / "nope.aion", "--time", "now")
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "nope.aion")
    assert proc.stdout == ""
