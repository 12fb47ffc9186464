"""Data on stdout, messages on stderr, as a demanding user meets them: a reader that stops
early, a narrow or dumb terminal, a log file that keeps stderr."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from tests.cli.conftest import AION


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    return {**env, "TZ": "UTC", "AION_DEBUG": "", **extra}


def _closed_stdout(*args: str | Path) -> subprocess.CompletedProcess[str]:
    """``aion ARGS`` whose stdout is a pipe nobody reads any more (``| head`` gone)."""
    read, write = os.pipe()
    os.close(read)
    try:
        return subprocess.run(
            [str(AION), *map(str, args)],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            env=_env(),
            timeout=120,
            check=False,
        )
    finally:
        os.close(write)


@pytest.mark.parametrize(
    "args",
    [
        ("predict", "{map}", "--time", "2026-01-12 08:40", "--top", "3"),
        ("plan", "{map}", "--from", "p12", "--to", "p87", "--time", "2026-01-12 08:40"),
        ("info", "{map}"),
        ("build", "--print-config"),
        ("--help",),
    ],
)
def test_a_table_whose_reader_stopped_is_not_a_failure(
    sample_map: Path, args: tuple[str, ...]
) -> None:
    """``aion predict MAP | head``: a table (rich) or text (click) written to a closed pipe
    ended the command with exit 1 (rich's and click's reaction to a broken pipe); stdout
    closed early is not a failure: exit 0, no message."""
    proc = _closed_stdout(*(a.format(map=sample_map) for a in args))
    assert proc.returncode == 0, proc.stderr
    assert "error" not in proc.stderr
