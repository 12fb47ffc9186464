"""``aion predict --layer places|rooms|buildings`` on a map whose places hold no detection (the
real leg_tracker recording: with ``--derive-graph`` its places were never stable, with the
apartment's Hydra graph they lie elsewhere) printed a table of zeros without a word on why:
every detection is on hash cells. It now says so (the words of ``plan``'s note, see
test_plan_flowless_places.py), in the command's notes and in ``Map.predict``'s (its series',
``historical=True``'s) ``notes``; rows that include a cell, or a map whose places hold people,
say nothing of it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from tests.cli.conftest import Office, run, run_json
from tests.shared_data import real

SAID = "places holds a detection"
AT = ("--time", "2015-03-16 03:16")


@pytest.fixture(scope="module")
def legs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict[str, Any]]:
    """(derived-graph map, apartment-graph map, the derived build's JSON) of the leg bag."""
    log = real("logs", "leg_tracker", "positive_2_extracted.bag")
    folder = tmp_path_factory.mktemp("legs")
    derived, apartment = folder / "derived.aion", folder / "apartment.aion"
    common = ("--map-frame", "right_laser", "--workers", "1", "--format", "json")
    built = run_json("build", log, *common, "--derive-graph", "-o", derived)
    other = run_json("build", log, *common, "--graph", real("dsg", "apartment_dsg.json"),
                     "-o", apartment)  # fmt: skip
    for made in (built, other):
        assert made["nodes"] > 1, made
        assert made["nodes_with_flow"] == 0, made
    return derived, apartment, built


def _notes(result: Any) -> list[str]:
    assert result.exit_code == 0, result.stderr
    return [n for n in result.stderr.splitlines() if SAID in n]


def test_places_without_detections_say_where_the_detections_are(
    legs: tuple[Path, Path, dict[str, Any]],
) -> None:
    derived, _, built = legs
    result = run("predict", derived, *AT, "--layer", "places", "--format", "json")
    (said,) = _notes(result)
    used = built["detections"]["used"]
    assert said.startswith(
        f"none of the scene graph's {built['nodes']:,} places holds a detection (the map's "
        f"{used:,} lie on hash cells"
    ), said
    assert said.endswith("--layer cells lists the cells that hold them"), said
    doc = json.loads(result.stdout)
    assert len(doc["entries"]) == built["nodes"]
    assert {e["flow"] for e in doc["entries"]} == {0.0}  # what the note explains
    cells = json.loads(run("predict", derived, *AT, "--layer", "cells", "--format",
                           "json").stdout)  # fmt: skip
    assert sum(e["flow"] for e in cells["entries"]) > 0  # where it points: the flow is there
    for rows in (("--layer", "cells"), ("--layer", "all")):  # a row is a cell: nothing to say
        assert _notes(run("predict", derived, *AT, *rows)) == []
    assert len(_notes(run("predict", derived, *AT, "--node", "p0"))) == 1
    assert len(_notes(run("predict", derived, "--historical", "--layer", "places"))) == 1


def test_rooms_buildings_and_series_say_it_and_the_api_carries_it(
    legs: tuple[Path, Path, dict[str, Any]],
) -> None:
    import aion_cli as aion

    _, apartment, _ = legs
    for layer in ("rooms", "buildings"):
        assert len(_notes(run("predict", apartment, *AT, "--layer", layer))) == 1
    series = ("--from", "2015-03-16 03:00", "--to", "2015-03-16 05:00", "--layer", "rooms")
    assert len(_notes(run("predict", apartment, *series))) == 1
    assert len(_notes(run("predict", apartment, *series, "--format", "json"))) == 1
    shown = run("predict", apartment, *AT, "--layer", "rooms").stderr.splitlines()
    cli = [n for n in shown if SAID in n]
    loaded = aion.Map.load(apartment)
    api = [n for n in loaded.predict(AT[1], layer="rooms").notes if SAID in n]
    assert api == [cli[0].replace("--layer cells", 'layer="cells"')]
    assert [n for n in loaded.predict(historical=True, layer="buildings").notes if SAID in n] == api
    made = loaded.predict_series("2015-03-16 03:00", "2015-03-16 05:00", layer="places")
    assert [n for n in made.notes if SAID in n] == api
    assert not any(SAID in n for n in loaded.predict(AT[1], layer="cells").notes)


def test_places_with_people_say_nothing_of_it(office: Office) -> None:
    assert office.build["nodes_with_flow"] > 0
    result = run("predict", office.map, "--time", "2026-01-12 08:40", "--layer", "places")
    assert _notes(result) == []
