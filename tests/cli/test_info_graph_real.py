"""``aion info GRAPH_FILE --format json`` on the real Hydra graphs of ``../shared/data/dsg``:
every count it prints is the count of the file's JSON (:mod:`tests.dsg_real_files`, read with
:mod:`json` alone)."""

from __future__ import annotations

import pytest

from tests.cli.conftest import run_json
from tests.dsg_real_files import FILES, from_json
from tests.shared_data import real


@pytest.mark.parametrize("name", FILES)
def test_info_counts_are_the_files(name: str) -> None:
    path = real("dsg", name)
    want = from_json(path)
    info = run_json("info", path, "--format", "json")
    assert info["format"] == "spark_dsg JSON (legacy, no version header)"
    assert {layer["key"]: layer["nodes"] for layer in info["layers"]} == want.layer_counts
    assert info["nav_layer"] == {"name": "PLACES", "key": "3"}
    assert info["places"] == len(want.places)
    assert info["edges"] == len(want.place_edges)
    assert info["places_with_room"] == sum(map(bool, want.place_room.values()))
    assert info["rooms"] == len(want.rooms)
    assert info["buildings"] == len(want.buildings)
    assert info["agent_poses"] == len(want.agent_ns)
    assert info["frontiers_left_out"] == 0
    assert info["mesh"] is None
