"""The ``aion`` group: help, version, and the one-line error contract."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli import __version__
from aion_cli.cli.errors import report
from aion_cli.errors import AionError, InputError
from tests.cli.conftest import assert_one_line_error, run, run_process

COMMANDS = ("info", "build", "predict", "plan", "export", "convert", "simulate", "evaluate")


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


def test_internal_faults_exit_1_with_a_debug_hint(capsys: pytest.CaptureFixture[str]) -> None:
    """An unexpected exception (a bug) is one line, exit 1, and points at --debug."""

    class KaputError(RuntimeError):
        pass

    assert report(KaputError("gears stuck"), debug=False) == 1
    err = capsys.readouterr().err
    assert_one_line_error(err, "internal error", "KaputError", "gears stuck")
    assert "--debug" in err
    assert report(AionError("engine fault"), debug=False) == 1
    assert report(InputError("bad value", hint="fix it"), debug=False) == 2
    err = capsys.readouterr().err
    assert "error: bad value\nhint: fix it" in err


def test_debug_prints_the_traceback(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(InputError) as info:
        raise InputError("bad value")
    code = report(info.value, debug=True)
    assert code == 2
    err = capsys.readouterr().err
    assert "Traceback" in err
    assert err.rstrip().endswith("error: bad value")
    result = run("--debug", "frobnicate")
    assert result.exit_code == 2
    assert "Traceback" in result.stderr
    result = run("predict", "missing.aion", "--debug")  # the flag works after the command too
    assert result.exit_code == 2
    assert "Traceback" in result.stderr
    assert result.stderr.rstrip().splitlines()[-2].startswith("error: map file not found")


def test_subprocess_missing_map_is_one_line_exit_2(tmp_path: Path) -> None:
    proc = run_process("predict", tmp_path / "nope.aion", "--time", "now")
    assert proc.returncode == 2
    assert_one_line_error(proc.stderr, "nope.aion")
    assert proc.stdout == ""


def _raised_while_handling(outer: BaseException, inner: BaseException) -> BaseException:
    """``outer`` as Python raises it inside an ``except`` of ``inner`` (``__context__`` set)."""
    try:
        try:
            raise inner
        except BaseException:
            raise outer  # noqa: B904 - the implicit chain is what is under test
    except BaseException as exc:
        return exc


def test_a_fault_raised_while_ctrl_c_unwinds_is_an_interrupt(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """zipfile refusing to close an archive whose member writer Ctrl-C stopped half-way
    (ValueError in the unwinding) is exit 130, not an internal error; a truncated file's
    EOFError behind an input error stays an input error."""
    zip_fault = ValueError("Can't close the ZIP file while there is an open writing handle")
    assert report(_raised_while_handling(zip_fault, KeyboardInterrupt()), debug=True) == 130
    err = capsys.readouterr().err
    assert_one_line_error(err, "interrupted")
    assert "Traceback" not in err
    truncated = _raised_while_handling(InputError("log is truncated"), EOFError("end of stream"))
    assert report(truncated, debug=False) == 2
    assert_one_line_error(capsys.readouterr().err, "truncated")


def test_interrupt_is_exit_130_and_broken_pipe_is_quiet(capsys: pytest.CaptureFixture[str]) -> None:
    assert report(KeyboardInterrupt(), debug=False) == 130
    err = capsys.readouterr().err
    assert_one_line_error(err, "interrupted")
    assert report(EOFError(), debug=False) == 130  # end of input at a prompt
    assert_one_line_error(capsys.readouterr().err, "interrupted")
    assert report(BrokenPipeError(32, "Broken pipe"), debug=False) == 0
    assert capsys.readouterr().err == ""
    assert report(PermissionError(13, "Permission denied", "/root/x.aion"), debug=False) == 2
    assert_one_line_error(capsys.readouterr().err, "Permission denied", "/root/x.aion")


_HALF_BUILT_ZIP_ON_CTRL_C = """
import sys, zipfile

class InterruptedInConstructor(zipfile.ZipFile):
    def __init__(self, file, mode="r", *args, **kwargs):
        if mode == "w":
            self.fp = file  # a signal after __init__ took the file, before it set _writing
            raise KeyboardInterrupt
        super().__init__(file, mode, *args, **kwargs)

zipfile.ZipFile = InterruptedInConstructor
from aion_cli.cli.main import main
sys.argv = ["aion", "build", sys.argv[1], "-o", sys.argv[2], "-q"]
main()
"""


def test_ctrl_c_inside_a_constructor_prints_one_error_and_no_finalizer_traceback(
    tmp_path: Path,
) -> None:
    """A signal that lands inside ``ZipFile.__init__`` (seen in CI: SIGINT while the map was
    being written) leaves an object whose ``__del__`` raises AttributeError when the
    interrupted frames are freed; Python would print that traceback below the error line."""
    import subprocess
    import sys

    sample = Path(__file__).resolve().parents[2] / "samples" / "office.mcap"
    done = subprocess.run(
        [sys.executable, "-c", _HALF_BUILT_ZIP_ON_CTRL_C, str(sample), str(tmp_path / "m.aion")],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=Path(__file__).resolve().parents[2],
    )
    assert done.returncode == 130, done.stderr
    assert "Exception ignored" not in done.stderr
    assert_one_line_error(done.stderr, "interrupted")
    assert not (tmp_path / "m.aion").exists()


_REPORT_A_BROKEN_PIPE = (
    "import sys\n"
    "from aion_cli.cli.errors import report\n"
    "sys.exit(report(BrokenPipeError(32, 'Broken pipe'), False))\n"
)


def test_a_broken_pipe_is_quiet_only_when_stdouts_reader_has_gone() -> None:
    """``| head`` closing stdout is no failure (exit 0, no message); a broken pipe of
    something else (a scheduler's socket) while stdout's reader still reads is one."""
    import os
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    reading = subprocess.run(
        [sys.executable, "-c", _REPORT_A_BROKEN_PIPE], cwd=root, capture_output=True,
        text=True, check=False,
    )
    assert reading.returncode == 1
    assert_one_line_error(reading.stderr, "Broken pipe")
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader has gone before the child reports
    try:
        gone = subprocess.run(
            [sys.executable, "-c", _REPORT_A_BROKEN_PIPE], cwd=root, stdout=write_end,
            stderr=subprocess.PIPE, text=True, check=False,
        )
    finally:
        os.close(write_end)
    assert gone.returncode == 0
    assert gone.stderr == ""
