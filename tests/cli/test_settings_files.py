"""A ``--config`` or ``--detections-mapping`` file that is not TOML text (a log or a map
given by mistake) is a user mistake: one ``error:`` line naming the file, exit 2, in every
command that reads one (it was ``internal error: UnicodeDecodeError``, exit 1)."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.formats.toml_files import MAX_TOML_BYTES
from tests.cli.conftest import SAMPLE, assert_one_line_error, run

NOT_TEXT = b"PK\x03\x04\x14\x00\x00\x00\xff\xfe binary, as a map or a log starts"


def _commands(settings: Path, tmp_path: Path) -> list[list[str | Path]]:
    """Every command that reads a config or a mapping, with ``settings`` as that file (a
    config is read before any log or data file; a mapping once the log is found)."""
    out = tmp_path / "x.aion"
    return [
        ["build", "x.mcap", "-o", out, "--config", settings],
        ["evaluate", "office", "--scenes", "1", "--config", settings],
        ["evaluate", "atc", "--data", tmp_path, "--config", settings],
        ["evaluate", "lincoln", "--data", tmp_path, "--config", settings],
        ["build", SAMPLE, "-o", out, "--detections-mapping", settings],
        ["info", SAMPLE, "--detections-mapping", settings],
    ]


@pytest.mark.parametrize("index", range(6))
def test_a_binary_settings_file_is_refused_as_a_user_mistake(tmp_path: Path, index: int) -> None:
    settings = tmp_path / "model.toml"
    settings.write_bytes(NOT_TEXT)
    args = _commands(settings, tmp_path)[index]
    result = run(*args)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, str(settings), "is not TOML text", "byte 8")
    assert not (tmp_path / "x.aion").exists()


def test_a_settings_file_too_large_to_be_one_is_refused_unread(tmp_path: Path) -> None:
    big = tmp_path / "run.toml"
    big.write_text("# " + "x" * MAX_TOML_BYTES + "\n")  # valid TOML, but no file of settings
    for args in (_commands(big, tmp_path)[0], _commands(big, tmp_path)[4]):
        result = run(*args)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, str(big), "larger than 1 MiB")


def test_a_config_file_of_text_is_still_read(tmp_path: Path) -> None:
    config = tmp_path / "model.toml"
    config.write_text(ModelConfig(cell_size=0.25).to_toml())
    result = run("build", "--config", config, "--print-config")
    assert result.exit_code == 0, result.stderr
    assert ModelConfig.from_toml_text(result.stdout).cell_size == 0.25


@pytest.mark.parametrize("index", [0, 5])
def test_a_fifo_as_the_settings_file_is_refused_unopened(tmp_path: Path, index: int) -> None:
    """``--config pipe`` (a named pipe no one writes to) hung the build for ever: opening a
    FIFO blocks until a writer comes. It is refused before it is opened, like a FIFO given as
    a log (in a subprocess: a hang fails the test at the timeout instead of stopping it)."""
    import os

    from tests.cli.conftest import run_process

    fifo = tmp_path / "model.toml"
    os.mkfifo(fifo)
    result = run_process(*_commands(fifo, tmp_path)[index])
    assert result.returncode == 2, result.stderr
    assert_one_line_error(result.stderr, f"{fifo} is a FIFO (named pipe), not a regular file")
    assert "hint: pass the TOML file itself" in result.stderr
    assert not (tmp_path / "x.aion").exists()
