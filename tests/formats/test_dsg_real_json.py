"""The real Hydra graphs of ``../shared/data/dsg``, read by aion, against what their JSON holds
(:mod:`tests.dsg_real_files` reads it with :mod:`json` alone, never spark_dsg or aion).
``apartment_dsg.json`` is also in ``tests/data``, so the legacy-stamp checks run from any
clone; the other three files need the shared data and skip without it.
"""

from __future__ import annotations

import datetime
from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats import dsg as fdsg
from aion_cli.formats.dsg_json import restore_agent_stamps, stamps_beside_attributes
from tests.dsg_real_files import FILES, assert_reads_the_file, dangling_edge_copy, from_json
from tests.shared_data import real, real_path


@pytest.mark.parametrize("name", FILES)
def test_real_file_reads_as_its_json(name: str) -> None:
    path = real("dsg", name)
    want = from_json(path)
    loaded = fdsg.load_graph(path)
    assert loaded.file.version is None  # all four are legacy, header-less files
    assert_reads_the_file(loaded.snapshot, want)


def test_real_counts() -> None:
    """The counts, from the JSON (and for two files, the data README's own figures)."""
    counts = {}
    for name in FILES:
        path = real_path("dsg", name)
        if not path.exists():
            continue
        got = from_json(path)
        counts[name] = (
            len(got.places), len(got.place_edges), sum(map(bool, got.place_room.values())),
            len(got.rooms), len(got.buildings), len(got.agent_ns),
        )  # fmt: skip
    if not counts:
        pytest.skip("no real scene graph here (../shared/data/dsg nor tests/data/dsg)")
    expected = {
        "apartment_dsg.json": (185, 396, 135, 1, 1, 102),
        "apartment_igx_dsg.json": (437, 1087, 423, 4, 1, 691),
        "mp3d_x8F5xyUWy9e_dsg.json": (423, 1261, 394, 5, 1, 1445),
        "mp3d_x8F5xyUWy9e_partial_600_dsg.json": (231, 501, 210, 3, 1, 600),
    }
    assert counts == {k: expected[k] for k in counts}


def test_legacy_agent_stamps_are_the_files() -> None:
    """spark_dsg 1.1.x reads a legacy file's agent ``timestamp`` (beside ``attributes``) only
    to choose the node's partition, and leaves every stamp 0: aion read the apartment robot's
    102 poses all at time 0. Its first poses are 3.64791 s, 3.74791 s, 3.99791 s."""
    path = real("dsg", "apartment_dsg.json")
    snap = fdsg.load_graph_file(path)
    assert snap.agents is not None
    assert snap.agents.t_ns[:3].tolist() == [3_647_910_000, 3_747_910_000, 3_997_910_000]
    assert int(snap.agents.t_ns[-1]) == 28_447_910_000
    assert (np.diff(snap.agents.t_ns) > 0).all()


def test_legacy_stamps_of_a_file_read_leniently(tmp_path: Path) -> None:
    """A legacy file spark_dsg refuses (one dangling edge here) keeps its agent stamps too."""
    path = dangling_edge_copy(tmp_path, "dangling.json")
    loaded = fdsg.load_graph(path)
    assert loaded.file.reader == "lenient"
    assert loaded.file.skipped == {"dangling_edges": 1}
    assert loaded.snapshot.agents is not None
    assert loaded.snapshot.agents.t_ns[0] == 3_647_910_000


def test_stamps_beside_attributes_until_spark_dsg_1_1_0() -> None:
    assert stamps_beside_attributes(None)
    assert stamps_beside_attributes("1.0.6")
    assert not stamps_beside_attributes("1.1.0")
    assert not stamps_beside_attributes("1.1.3")


def test_restore_only_agents_and_valid_stamps() -> None:
    """Stamps go to agent nodes only; a negative, fractional or missing stamp is left alone;
    sub-microsecond parts are dropped as spark_dsg drops them."""
    import spark_dsg

    G = spark_dsg.DynamicSceneGraph()
    for k in range(4):
        agent = spark_dsg.AgentNodeAttributes()
        agent.position = np.array([float(k), 0.0, 0.0])
        G.add_node(2, spark_dsg.NodeSymbol("a", k), agent, ord("a"))
    room = spark_dsg.RoomNodeAttributes()
    room.position = np.zeros(3)
    G.add_node(4, spark_dsg.NodeSymbol("R", 0), room)
    a = [spark_dsg.NodeSymbol("a", k).value for k in range(4)]
    doc = {
        "nodes": [
            {"id": a[0], "timestamp": 1_500_000_999},
            {"id": a[1], "timestamp": -5},
            {"id": a[2], "timestamp": 2.5},
            {"id": a[3]},
            {"id": spark_dsg.NodeSymbol("R", 0).value, "timestamp": 7_000},
            {"id": spark_dsg.NodeSymbol("a", 9).value, "timestamp": 7_000},  # not in the graph
        ]
    }
    assert restore_agent_stamps(G, doc) == 1
    stamps = [G.get_node(a[k]).attributes.timestamp for k in range(4)]
    zero = datetime.timedelta(0)
    assert stamps == [datetime.timedelta(seconds=1, microseconds=500_000), zero, zero, zero]


def test_current_format_file_keeps_its_stamps(tmp_path: Path) -> None:
    """A file spark_dsg 1.1.x wrote holds the stamp inside the attributes; it reads as is."""
    import spark_dsg

    G = spark_dsg.DynamicSceneGraph()
    agent = spark_dsg.AgentNodeAttributes()
    agent.position = np.array([1.0, 2.0, 3.0])
    agent.timestamp = datetime.timedelta(seconds=12, microseconds=345_678)
    G.add_node(2, spark_dsg.NodeSymbol("a", 0), agent, ord("a"))
    place = spark_dsg.PlaceNodeAttributes()
    place.position = np.zeros(3)
    G.add_node(3, spark_dsg.NodeSymbol("p", 0), place)
    path = tmp_path / "g.json"
    G.save(str(path), False)
    loaded = fdsg.load_graph(path)
    assert loaded.file.version is not None
    assert loaded.snapshot.agents is not None
    assert loaded.snapshot.agents.t_ns.tolist() == [12_345_678_000]
