"""A map of no entry (``Map.from_state`` of a state fed nothing: ``aion build`` refuses logs
without a usable detection, the API can still make one): ``predict`` printed an empty table
and ``export`` wrote empty ``entries.csv`` / ``entries.json`` with no word on why. Both
succeed (the query is valid; the map has nothing), with a note on stderr saying the map holds
no entries, and the API's ``Table.notes`` carry it; a map with entries gets no such note."""

from __future__ import annotations

import json
from pathlib import Path

import aion_cli as aion
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.state import MapState
from tests.cli.conftest import Office, run

NOTE = "the map holds no entries"


def test_an_empty_map_says_it_holds_no_entries(tmp_path: Path, office: Office) -> None:
    empty = tmp_path / "empty.aion"
    aion.Map.from_state(MapState.empty(ModelConfig())).save(empty)
    for args in (
        ["predict", empty, "--time", "2026-01-12 08:00"],
        ["predict", empty, "--historical"],
        ["predict", empty, "--time", "2026-01-12 08:00", "--format", "json"],
        ["predict", empty, "--from", "2026-01-12 08:00", "--to", "2026-01-12 10:00"],
        ["export", empty, "--time", "2026-01-12 08:00", "-o", tmp_path / "at"],
        ["export", empty, "--historical", "-o", tmp_path / "seen"],
    ):
        result = run(*args)
        assert result.exit_code == 0, result.stderr
        assert result.stderr.count(NOTE) == 1, (args, result.stderr)
    doc = json.loads(run("predict", empty, "--historical", "--format", "json").stdout)
    assert doc["entries"] == []
    assert json.loads((tmp_path / "seen" / "entries.json").read_text())["entries"] == []
    notes = aion.Map.load(empty).predict("2026-01-12 08:00").notes
    assert any(NOTE in n for n in notes)
    # a map with entries: no such note, whether forecast or as observed
    for args in (["predict", office.map, "--time", "2026-01-12 08:00"],
                 ["predict", office.map, "--historical"]):
        result = run(*args)
        assert result.exit_code == 0, result.stderr
        assert NOTE not in result.stderr
