"""Scene-graph files named ``.bson``, a suffix spark_dsg saves and aion accepts: spark_dsg
writes them as JSON text and reads them back as JSON. aion read them as binary graphs: the
JSON version header was missed ("spark_dsg binary (legacy, no version header)" for a 1.1.3
file), a file spark_dsg refuses was an error instead of being read leniently, and a legacy
file gave its robot's agent poses all time 0. Each ``.bson`` here must read as its ``.json``
twin; a binary graph named ``.bson`` reads as ``.sparkdsg``, with a note saying so."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.formats import dsg as fdsg
from aion_cli.formats.dsg_files import read_dsg_file
from tests.dsg_real_files import dangling_edge_copy
from tests.formats.dsg_builders import MESH_EDGES, MESH_PLACES, hydra_graph
from tests.robustness.conftest import run
from tests.shared_data import real

#: the apartment robot's first agent stamps (ns), as its JSON holds them
#: (tests/formats/test_dsg_real_json.py)
APARTMENT_FIRST_STAMPS = [3_647_910_000, 3_747_910_000, 3_997_910_000]


def _same_places(a: fdsg.LoadedGraph, b: fdsg.LoadedGraph) -> None:
    assert np.array_equal(a.snapshot.places.ids, b.snapshot.places.ids)
    assert np.array_equal(a.snapshot.places.xyz, b.snapshot.places.xyz)
    assert np.array_equal(a.snapshot.edges, b.snapshot.edges)
    assert str(a.nav.layer) == str(b.nav.layer)


def test_a_bson_file_spark_dsg_saved_reads_as_its_json_twin(tmp_path: Path) -> None:
    G = hydra_graph()
    G.save(str(tmp_path / "g.json"), True)
    G.save(str(tmp_path / "g.bson"), True)
    assert (tmp_path / "g.bson").read_bytes()[:1] == b"{"  # spark_dsg wrote JSON text
    want, got = fdsg.load_graph(tmp_path / "g.json"), fdsg.load_graph(tmp_path / "g.bson")
    assert want.file.format == f"spark_dsg JSON {fdsg.installed_version()}"
    assert got.file.format == want.file.format
    assert got.file.version == fdsg.installed_version()
    assert got.notes() == []  # spark_dsg's own .bson: no "holds a JSON graph" note
    _same_places(want, got)
    assert len(got.snapshot.places) == MESH_PLACES
    assert len(got.snapshot.edges) == MESH_EDGES
    result = run("info", tmp_path / "g.bson")
    assert result.exit_code == 0, result.stderr
    assert f"spark_dsg JSON {fdsg.installed_version()}" in result.stdout
    assert "binary" not in result.stdout
    assert "note:" not in result.stderr


def test_a_legacy_bson_file_keeps_its_agent_stamps(tmp_path: Path) -> None:
    """The legacy apartment graph under a ``.bson`` name: its 102 agent poses keep the
    stamps its JSON holds (spark_dsg leaves them 0; aion restores them for JSON files)."""
    path = tmp_path / "apartment.bson"
    path.write_bytes(real("dsg", "apartment_dsg.json").read_bytes())
    want = fdsg.load_graph(real("dsg", "apartment_dsg.json"))
    got = fdsg.load_graph(path)
    assert got.file.format == "spark_dsg JSON (legacy, no version header)"
    assert got.snapshot.agents is not None
    assert want.snapshot.agents is not None
    assert len(got.snapshot.agents) == 102
    assert got.snapshot.agents.t_ns[:3].tolist() == APARTMENT_FIRST_STAMPS
    assert np.array_equal(got.snapshot.agents.t_ns, want.snapshot.agents.t_ns)
    _same_places(want, got)


def test_a_bson_file_spark_dsg_refuses_is_read_leniently(tmp_path: Path) -> None:
    """One edge to a place the file does not hold: spark_dsg refuses the file; as ``.json``
    aion read it leniently, as ``.bson`` it was "cannot read ... (damaged?)", exit 2."""
    path = dangling_edge_copy(tmp_path, "dangling.bson")
    got = fdsg.load_graph(path)
    assert got.file.reader == "lenient"
    assert got.file.skipped == {"dangling_edges": 1}
    assert len(got.snapshot.places) == 185
    assert got.snapshot.agents is not None
    assert got.snapshot.agents.t_ns[:3].tolist() == APARTMENT_FIRST_STAMPS
    result = run("info", path)
    assert result.exit_code == 0, result.stderr
    assert "read leniently: 1 dangling edge skipped" in result.stderr


def test_a_binary_graph_named_bson_reads_as_sparkdsg_with_a_note(tmp_path: Path) -> None:
    G = hydra_graph()
    G.save(str(tmp_path / "g.sparkdsg"), True)
    path = tmp_path / "g.bson"
    path.write_bytes((tmp_path / "g.sparkdsg").read_bytes())
    want, got = read_dsg_file(tmp_path / "g.sparkdsg"), read_dsg_file(path)
    assert got.reader == want.reader == "spark_dsg"
    assert got.format == want.format == f"spark_dsg binary {fdsg.installed_version()}"
    assert got.notes() == [
        "g.bson holds a binary graph: read as a .sparkdsg file (spark_dsg reads a graph by "
        "its suffix)"
    ]
    _same_places(fdsg.load_graph(tmp_path / "g.sparkdsg"), fdsg.load_graph(path))
