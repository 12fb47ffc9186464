"""What the CLI prints as ``warning: ...`` a script sees too: ``aion.build``, ``aion.merge`` and
``Map.holdout`` issue their warnings as :class:`aion.AionWarning`. Before, a map built from a
truncated log came back from the API as if nothing was wrong (the warning only in
``report.warnings``), while ``aion build`` printed it; and ``aion evaluate holdout`` (and
``Map.holdout``) scored a truncated test log without a word, in any form."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest

import aion_cli as aion
from tests.cli.conftest import SAMPLE, Office, run, run_json


def _cut(folder: Path) -> Path:
    log = folder / "cut.mcap"
    log.write_bytes(SAMPLE.read_bytes()[:300_000])  # the log stops mid-chunk
    return log


def test_a_build_from_a_truncated_log_warns(tmp_path: Path) -> None:
    log = _cut(tmp_path)
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


def test_a_holdout_on_a_truncated_log_warns(sample_map: Path, tmp_path: Path) -> None:
    log = _cut(tmp_path)
    built = run_json("build", log, "-o", tmp_path / "cli.aion", "--format", "json")
    said = run("evaluate", "holdout", sample_map, log, "-q", "--format", "json")
    assert said.exit_code == 0, said.stderr
    doc = json.loads(said.stdout)
    # read as aion build reads it; the sample map was built from this log: in-sample
    reading, in_sample = doc["warnings"][:-1], doc["warnings"][-1]
    assert reading == built["warnings"]
    assert "test detections lie within the map's own time span" in in_sample
    assert [f"warning: {w}" for w in doc["warnings"]] == said.stderr.splitlines()
    with pytest.warns(aion.AionWarning) as caught:
        result = aion.Map.load(sample_map).holdout([log])
    assert [str(w.message) for w in caught] == result.warnings == doc["warnings"]
    assert all(w.filename == __file__ for w in caught)
