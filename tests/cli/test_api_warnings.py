"""What the CLI prints as ``warning: ...`` a script sees too: ``aion.build`` and ``aion.merge``
issue their report's warnings as :class:`aion.AionWarning`. Before, a map built
from a truncated log came back from the API as if nothing was wrong (the warning only in
``report.warnings``), while ``aion build`` printed it."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

import aion_cli as aion
from tests.cli.conftest import SAMPLE, Office, run_json


def test_a_build_from_a_truncated_log_warns(tmp_path: Path) -> None:
    log = tmp_path / "cut.mcap"
    log.write_bytes(SAMPLE.read_bytes()[:300_000])  # the log stops mid-chunk
    cli = run_json("build", log, "-o", tmp_path / "cli.aion", "--format", "json")
    assert any("truncated" in w for w in cli["warnings"])
    with pytest.warns(aion.AionWarning) as caught:
        built = aion.build(log, tmp_path / "api.aion")
    assert [str(w.message) for w in caught] == cli["warnings"] == built.report.warnings
    assert all(w.filename == __file__ for w in caught)  # pointing at the caller's line


def test_a_clean_build_does_not_warn(office: Office, tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", aion.AionWarning)
        built = aion.build(office.log, tmp_path / "clean.aion")
    assert built.report.warnings == []
