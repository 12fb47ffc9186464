"""``predict --node`` with a room or building of the map beside a place, a cell or the other
layer is refused for what it is (one table cannot hold both layers), not as "not in the map":
R1 and B0 are in it. An id the graph does not have is "not in the map", with a hint that does
not claim it would be answered alone."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import aion_cli as aion
from tests.cli.conftest import Office, assert_one_line_error, run, run_json

AT = ("--time", "2026-11-23 08:30")


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--node", "R1", "--node", "p4"], "R1"),
        (["--node", "p4", "--node", "room1"], "R1"),  # by name
        (["--node", "B0", "--node", "R1"], "B0, R1"),
        (["--layer", "places", "--node", "R1"], "R1"),
        (["--layer", "cells", "--node", "B0"], "B0"),
    ],
)
def test_a_room_or_building_in_a_mix_is_named_as_such(
    office: Office, args: list[str], named: str
) -> None:
    for when in (AT, ("--from", "2026-11-23 08:00", "--to", "2026-11-23 09:00")):
        result = run("predict", office.map, *when, *args)
        assert result.exit_code == 2, result.stdout
        assert_one_line_error(result.stderr, f"{named}: rooms and buildings are answered")
        assert "not in the map" not in result.stderr
        assert "asked for alone" in result.stderr


def test_alone_they_are_answered_and_unknown_ones_are_not_in_the_map(office: Office) -> None:
    assert [e["id"] for e in run_json("predict", office.map, *AT, "--node", "R1", "--format",
                                      "json")["entries"]] == ["R1"]
    for args in (["--node", "R9"], ["--node", "p4", "--node", "R9"]):
        result = run("predict", office.map, *AT, *args)
        assert result.exit_code == 2
        assert_one_line_error(result.stderr, "R9 is not in the map")
        assert "no such room or building" in result.stderr
        assert "asked for alone" not in result.stderr


def test_the_api_says_the_same(office: Office) -> None:
    m = aion.Map.load(office.map)
    with pytest.raises(aion.InputError, match="R1: rooms and buildings are answered"):
        m.predict(AT[1], nodes=["p4", "R1"])
    with pytest.raises(aion.InputError, match="R1: rooms and buildings are answered"):
        m.predict_series(AT[1], "2026-11-23 09:30", nodes=["R1", "p4"])


def test_a_room_beside_a_hash_cell_is_named_as_such(sample_map: Path) -> None:
    """A hash cell's id (``c<key>``, a key larger than a node index) beside a room: the room is
    refused for its layer, as beside a place (the cell's id could not be read as a node id, so
    the room was called 'not in the map', with the hint that the map has no such room)."""
    def first(layer: str) -> dict[str, Any]:
        entries = run_json("predict", sample_map, *AT, "--layer", layer, "--top", "1",
                           "--format", "json")["entries"]
        assert entries, f"the sample's map has {layer}"
        return dict(entries[0])

    cell, room = first("cells"), first("rooms")
    for asked in ([cell["id"], room["id"]], [room["name"] or room["id"], cell["id"]]):
        result = run("predict", sample_map, *AT, *[a for n in asked for a in ("--node", n)])
        assert result.exit_code == 2, result.stdout
        assert_one_line_error(result.stderr, f"{room['id']}: rooms and buildings are answered")
        assert "not in the map" not in result.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--layer", "rooms", "--node", "p4"], "--layer rooms answers rooms only: p4 is no room"),
        (["--layer", "buildings", "--node", "R1"],
         "--layer buildings answers buildings only: R1 is no building"),
        (["--layer", "rooms", "--node", "p4", "--node", "B0"],
         "--layer rooms answers rooms only: p4, B0 are no rooms"),
    ],
)
def test_a_place_asked_for_on_the_rooms_layer_is_named_as_such(
    office: Office, args: list[str], message: str
) -> None:
    """``--layer rooms --node p4`` said "node p4 is not in the map", of a place that is: the
    rooms layer answers rooms only, and the hint says how to ask for the place."""
    result = run("predict", office.map, *AT, *args)
    assert result.exit_code == 2, result.stdout
    assert_one_line_error(result.stderr, message)
    assert "not in the map" not in result.stderr
    assert "without --layer" in result.stderr
    # a room the map lacks is still "not in the map" on its own layer
    result = run("predict", office.map, *AT, "--layer", "rooms", "--node", "R9")
    assert_one_line_error(result.stderr, "R9 is not in the map")


@pytest.mark.parametrize(
    "args",
    [
        ["--layer", "rooms", "--node", "p9999"],
        ["--layer", "rooms", "--node", "c12"],
        ["--layer", "buildings", "--node", "R99"],
    ],
)
def test_an_id_on_no_layer_of_the_map_is_not_sent_to_ask_without_layer(
    office: Office, args: list[str]
) -> None:
    """``--layer rooms --node p9999`` (a place the map does not have) said "--layer rooms
    answers rooms only: p9999 is no room" with the hint to ask for it without --layer, where
    the answer is "not in the map"."""
    result = run("predict", office.map, *AT, *args)
    assert result.exit_code == 2, result.stdout
    assert_one_line_error(result.stderr, f"node {args[-1]} is not in the map")
    assert "without --layer" not in result.stderr


def test_a_place_of_a_category_that_is_no_letter_is_asked_for_as_printed(
    office: Office, tmp_path: Path
) -> None:
    """A graph whose places are in category ``#`` (spark_dsg takes any character; predict
    prints them ``#3``): ``predict --node '#3'`` answered it, then said "not a node id or
    room name: '#3'" once a word that is neither a name nor an id became an error."""
    import numpy as np
    import spark_dsg

    from tests.cli.logdata import EDGES, PLACES

    graph = spark_dsg.DynamicSceneGraph()
    for i, xyz in PLACES.items():
        attrs = spark_dsg.PlaceNodeAttributes()
        attrs.position = np.array(xyz)
        attrs.real_place = True
        graph.add_node(spark_dsg.DsgLayers.PLACES, spark_dsg.NodeSymbol("#", i), attrs)
    for a, b in EDGES:
        graph.insert_edge(spark_dsg.NodeSymbol("#", a), spark_dsg.NodeSymbol("#", b))
    room = spark_dsg.RoomNodeAttributes()
    room.position = np.array(PLACES[0])
    room.name = "lab"  # a name, so unknown words list the graph's names
    graph.add_node(spark_dsg.DsgLayers.ROOMS, spark_dsg.NodeSymbol("R", 0), room)
    graph_file = tmp_path / "hash.json"
    graph.save(str(graph_file), False)
    site = tmp_path / "hash.aion"
    assert run("build", office.log, "--graph", graph_file, "-o", site, "-q").exit_code == 0
    listed = run_json("predict", site, *AT, "--format", "json")
    ids = [e["id"] for e in listed["entries"] if e["id"].startswith("#")]
    assert ids
    picked = run_json("predict", site, *AT, "--node", ids[0], "--format", "json")
    assert [e["id"] for e in picked["entries"]] == [ids[0]]
    result = run("predict", site, *AT, "--node", "lba")  # a misspelt name: the names listed
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "not a node id or room name: 'lba'")
