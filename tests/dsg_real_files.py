"""What the real Hydra graphs of ``../shared/data/dsg`` hold, read with :mod:`json` alone.

Every value here comes from a file's JSON (:func:`from_json`), never from spark_dsg or aion:
the real places (layer 3, not frontiers) and their positions, the place-place edges, each
place's room and each room's building (the interlayer edges), the room and building ids, and
the robot poses of the agent layer with their stamps. :func:`assert_reads_the_file` checks an
aion snapshot against them (``tests/formats/test_dsg_real_json.py`` for files,
``tests/test_dsg_real_logs.py`` for the same graphs in DsgUpdate logs).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

#: the four graph files of ``../shared/data/dsg``
FILES = [
    "apartment_dsg.json",
    "apartment_igx_dsg.json",
    "mp3d_x8F5xyUWy9e_dsg.json",
    "mp3d_x8F5xyUWy9e_partial_600_dsg.json",
]


@dataclass(frozen=True)
class FromJson:
    """What a legacy spark_dsg JSON file holds, read with :mod:`json` only."""

    places: dict[int, tuple[float, float, float]]
    place_edges: set[tuple[int, int]]
    place_room: dict[int, int]  # 0: no room
    rooms: dict[int, int]  # room -> building (0: none)
    buildings: set[int]
    agent_ns: np.ndarray  # sorted stamps as the file gives them
    agent_xyz: np.ndarray  # in the order of agent_ns
    #: nodes per layer key as spark_dsg names keys (``"2"``, ``"2[97]"``: a legacy node with a
    #: ``timestamp`` is in the partition of its symbol's category, the robot's prefix)
    layer_counts: dict[str, int]


def from_json(path: Path) -> FromJson:
    doc = json.loads(path.read_text())
    nodes = {n["id"]: n for n in doc["nodes"]}
    layer = {i: n["layer"] for i, n in nodes.items()}
    places = {
        i: tuple(n["attributes"]["position"])
        for i, n in nodes.items()
        if n["layer"] == 3 and n["attributes"].get("real_place", True)
    }
    rooms = {i for i, n in nodes.items() if n["layer"] == 4}
    buildings = {i for i, n in nodes.items() if n["layer"] == 5}
    place_edges: set[tuple[int, int]] = set()
    parent: dict[int, int] = {}
    for edge in doc["edges"]:
        s, t = edge["source"], edge["target"]
        if s not in nodes or t not in nodes:
            continue  # the igx file's dangling edges (objects to places not in the file)
        if s in places and t in places:
            place_edges.add((min(s, t), max(s, t)))
        elif layer[s] != layer[t]:
            child, up = (s, t) if layer[s] < layer[t] else (t, s)
            if layer[up] == layer[child] + 1 and layer[child] in (3, 4):
                assert child not in parent, "a place or room with two parents"
                parent[child] = up
    layer_counts: dict[str, int] = {}
    for i, n in nodes.items():
        key = f"{n['layer']}[{i >> 56}]" if "timestamp" in n else str(n["layer"])
        layer_counts[key] = layer_counts.get(key, 0) + 1
    agents = [n for n in nodes.values() if n["layer"] == 2 and "timestamp" in n]
    order = sorted(range(len(agents)), key=lambda k: agents[k]["timestamp"])
    return FromJson(
        places=places,
        place_edges=place_edges,
        place_room={i: parent.get(i, 0) for i in places},
        rooms={i: parent.get(i, 0) for i in rooms},
        buildings=buildings,
        agent_ns=np.array([agents[k]["timestamp"] for k in order], np.int64),
        agent_xyz=np.array([agents[k]["attributes"]["position"] for k in order], np.float64),
        layer_counts=layer_counts,
    )


def assert_reads_the_file(snap: Any, want: FromJson, agents: bool = True) -> None:
    """aion's snapshot holds exactly the file's navigational graph (and robot poses)."""
    ids = snap.places.ids.tolist()
    assert sorted(ids) == sorted(want.places)
    np.testing.assert_array_equal(snap.places.xyz, [want.places[i] for i in ids])
    got_edges = {(min(a, b), max(a, b)) for a, b in snap.places.ids[snap.edges].tolist()}
    assert got_edges == want.place_edges
    assert dict(zip(ids, snap.places.parent.tolist(), strict=True)) == want.place_room
    assert dict(zip(snap.rooms.ids.tolist(), snap.rooms.parent.tolist(), strict=True)) == want.rooms
    assert set(snap.buildings.ids.tolist()) == want.buildings
    # rooms are labelled by their ids: the files name them "R(0)", spark_dsg's long form
    assert sorted(snap.rooms.labels) == sorted(f"R{i & ((1 << 56) - 1)}" for i in want.rooms)
    if not agents:
        assert snap.agents is None
        return
    # spark_dsg holds an agent's stamp as a timedelta: whole microseconds
    np.testing.assert_array_equal(snap.agents.t_ns, want.agent_ns // 1000 * 1000)
    np.testing.assert_array_equal(snap.agents.xyz, want.agent_xyz)


def dangling_edge_copy(folder: Path, name: str) -> Path:
    """The shared apartment graph (spark_dsg's legacy JSON) with one edge to a place it does
    not hold, written as ``folder / name``: spark_dsg refuses it, aion reads it leniently
    (one ``dangling_edges`` skipped)."""
    from tests.shared_data import real

    doc = json.loads(real("dsg", "apartment_dsg.json").read_text())
    info = {"type": "EdgeAttributes", "weight": 1.0, "weighted": True}
    doc["edges"].append(
        {"source": (ord("p") << 56) | 99_999, "target": doc["nodes"][0]["id"], "info": info}
    )
    path = folder / name
    path.write_text(json.dumps(doc))
    return path
