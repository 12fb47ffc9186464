"""``aion export --format dsg`` (formats/dsg_export.py): the map's scene graph as a spark_dsg
file whose places and rooms carry ``aion predict``'s records in their metadata, read back with
spark_dsg itself and with aion's own graph reader."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import pytest
import spark_dsg

import aion_cli as aion
from aion_cli.mapquery import load_map
from tests.cli.conftest import Office, assert_one_line_error, run, run_json
from tests.cli.logdata import save_graph_file

AT = "2026-11-23 08:30"


def _graph(path: Path) -> Any:
    return spark_dsg.DynamicSceneGraph.load(str(path))


def _record(graph: Any, label: str) -> dict[str, Any] | None:
    node = graph.get_node(spark_dsg.NodeSymbol(label[0], int(label[1:])))
    return node.attributes.metadata.get().get("aion")


def test_the_formats_the_no_path_hint_names_draw_the_path(office: Office, tmp_path: Path) -> None:
    """Map.export(..., format="dsg", path=...) is refused with a hint naming the formats that
    draw a path: it said "format='ply', 'png' or 'mcap'", but export(format="png") is
    "unknown export format 'png'" (a PNG is Map.picture's). Every format it names draws it."""
    import re

    m = aion.Map.load(office.map)
    with pytest.raises(aion.InputError) as caught:
        m.export(tmp_path / "p.json", time=AT, format="dsg", path=("p0", "p2"))
    named = re.findall(r"'(\w+)'", (caught.value.hint or "").split("draws the path")[0])
    assert named
    for fmt in named:
        target = tmp_path / (f"drawn.{fmt}" if fmt == "mcap" else f"drawn-{fmt}")
        written = m.export(target, time=AT, tz="UTC", format=fmt, path=("p0", "p2"))
        assert written, fmt
    assert "Map.picture(" in (caught.value.hint or "")
    assert m.picture(tmp_path / "drawn.png", time=AT, tz="UTC", path=("p0", "p2")).exists()


@pytest.mark.parametrize("name", ["dsg.json", "dsg.sparkdsg"])
def test_every_place_and_room_carries_predict_records(
    office: Office, tmp_path: Path, name: str
) -> None:
    out = tmp_path / name
    result = run("export", office.map, "--time", AT, "--tz", "UTC", "--format", "dsg", "-o", out)
    assert result.exit_code == 0, result.stderr
    graph = _graph(out)
    snapshot = load_map(office.map).graph
    assert snapshot is not None
    assert graph.get_layer(spark_dsg.DsgLayers.PLACES).num_nodes() == len(snapshot.places)
    assert graph.get_layer(spark_dsg.DsgLayers.ROOMS).num_nodes() == len(snapshot.rooms)
    assert graph.get_layer(spark_dsg.DsgLayers.PLACES).num_edges() == len(snapshot.edges)
    places = run_json(
        "predict", office.map, "--time", AT, "--tz", "UTC", "--layer", "places", "--format", "json"
    )
    assert places["entries"]
    for row in places["entries"]:
        record = _record(graph, row["id"])
        assert record is not None, row["id"]
        assert record == {k: v for k, v in row.items() if k not in ("x", "y", "z")}
    rooms = run_json(
        "predict", office.map, "--time", AT, "--tz", "UTC", "--layer", "rooms", "--format", "json"
    )
    for row in rooms["entries"]:
        record = _record(graph, row["id"])
        assert record is not None
        assert record["flow"] == row["flow"]
    meta = graph.metadata.get()["aion"]
    assert (meta["mode"], meta["time"], meta["zone"]) == ("predicted", places["time"], "UTC")
    assert meta["bins"] == places["bins"]
    assert meta["written_by"] == "aion export"


def test_historical_and_read_back_as_a_scene_graph(office: Office, tmp_path: Path) -> None:
    """The exported file is a scene graph aion builds with: the same places bind the same
    detections as the map's own graph did."""
    out = tmp_path / "observed.json"
    assert run("export", office.map, "--historical", "--format", "dsg", "-o", out).exit_code == 0
    graph = _graph(out)
    assert graph.metadata.get()["aion"]["mode"] == "historical"
    observed = run_json("predict", office.map, "--historical", "--layer", "places", "--format",
                        "json")
    for row in observed["entries"]:
        record = _record(graph, row["id"])
        assert record is not None
        assert record["flow"] == row["flow"]
    info = run_json("info", out, "--format", "json")
    assert info["places"] == len(observed["entries"])
    assert info["aion"]["mode"] == "historical"
    assert info["aion"]["map"] == office.map.name
    shown = run("info", out)
    assert "flows as observed from" in shown.stdout
    plain = save_graph_file(tmp_path / "plain.json")  # a graph aion did not export
    assert run_json("info", plain, "--format", "json")["aion"] is None
    rebuilt = run_json(
        "build", office.log, "--graph", out, "-o", tmp_path / "again.aion", "--format", "json"
    )
    assert rebuilt["nodes"] == office.build["nodes"]
    assert rebuilt["detections"]["used"] == office.build["detections"]["used"]


def test_the_api_writes_it_too(office: Office, tmp_path: Path) -> None:
    m = aion.Map.load(office.map)
    (written,) = m.export(tmp_path / "api.json", time=AT, tz="UTC", format="dsg")
    assert written == tmp_path / "api.json"
    assert _graph(written).metadata.get()["aion"]["time"].startswith("2026-11-23 08:30")
    with pytest.raises(aion.InputError, match="no path"):
        m.export(tmp_path / "p.json", time=AT, format="dsg", path=("p0", "p2"))
    # without format, the suffix chooses as in aion export
    (guessed,) = m.export(tmp_path / "guessed.sparkdsg", time=AT, tz="UTC")
    about = _graph(guessed).metadata.get()["aion"]
    assert about["time"].startswith("2026-11-23 08:30")
    assert about["hour_observed"] is True  # the office log observed 08:00-08:20
    with pytest.raises(aion.InputError, match="picture"):
        m.export(tmp_path / "m.png", time=AT)
    assert not (tmp_path / "m.png").exists()
    # a .ply name: the whole scene in that one file, as the CLI writes it
    (scene,) = m.export(tmp_path / "scene.ply", time=AT, tz="UTC")
    assert scene == tmp_path / "scene.ply"
    assert scene.read_bytes().startswith(b"ply")
    with pytest.raises(aion.InputError, match=r"disagree: \.pcd is the suffix of format pcd"):
        m.export(tmp_path / "scene.pcd", time=AT, format="ply")


def test_bad_targets_and_options(office: Office, tmp_path: Path) -> None:
    other = tmp_path / "mine.json"
    other.write_text('{"mine": true}')
    folder = tmp_path / "folder"
    folder.mkdir()
    cases = [
        (["--time", AT, "-o", tmp_path / "dsg.ply"], "disagree: .ply is the suffix of format ply"),
        # spark_dsg saves no .JSON: it was an internal error (exit 1) after the computation
        (["--time", AT, "-o", tmp_path / "dsg.JSON"], "writes a .json file in lower case"),
        (["--time", AT, "-o", tmp_path / "dsg.SparkDSG"], "a .sparkdsg file in lower case"),
        (["--time", AT, "-o", folder], "is a folder"),
        (["--time", AT, "-o", other], "not a scene-graph file aion wrote"),
        (["--from", "2026-11-23", "--to", "2026-11-24", "-o", tmp_path / "s.json"], "one time"),
        (["--time", AT, "--path-from", "p0", "--path-to", "p2", "-o", tmp_path / "p.json"],
         "no path"),
    ]
    for extra, fragment in cases:
        result = run("export", office.map, "--format", "dsg", *map(str, extra))
        assert result.exit_code == 2, (extra, result.stderr)
        assert_one_line_error(result.stderr, fragment)
    assert "hint: name it dsg.json" in run(
        "export", office.map, "--time", AT, "-o", tmp_path / "dsg.JSON"
    ).stderr  # the suffix alone chose the format
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder", "mine.json"]
    assert other.read_text() == '{"mine": true}'
    again = tmp_path / "again.json"
    for _ in range(2):  # an exported file is replaced by the next export
        done = run("export", office.map, "--time", AT, "--format", "dsg", "-o", again)
        assert done.exit_code == 0, done.stderr


@pytest.mark.parametrize("name", ["tasks.json", "notes.sparkdsg"])
def test_a_file_that_only_names_the_command_is_not_replaced(
    office: Office, tmp_path: Path, name: str
) -> None:
    """A file of the user's that holds the words "aion export" (a task list naming the
    command) was taken for a graph aion exported and overwritten without a word. Only a
    graph whose metadata says aion wrote it is replaced: the user's file is refused and kept;
    an exported graph, JSON or binary, is replaced."""
    mine = tmp_path / name
    text = '{"tasks": {"map": "aion export office.aion -o office-4d.json"}}\n'
    mine.write_text(text)
    result = run("export", office.map, "--time", AT, "-o", mine)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, "not a scene-graph file aion wrote")
    assert mine.read_text() == text
    ours = tmp_path / f"ours{mine.suffix}"
    for _ in range(2):
        done = run("export", office.map, "--time", AT, "-o", ours)
        assert done.exit_code == 0, done.stderr
    assert _record(_graph(ours), "p0") is not None


def test_a_map_without_a_graph_is_refused(tmp_path: Path) -> None:
    from tests.cli.logdata import write_office_log

    log = tmp_path / "bare.mcap"
    write_office_log(log, graph=False)
    bare = tmp_path / "bare.aion"
    assert run("build", log, "-o", bare).exit_code == 0
    result = run("export", bare, "--historical", "--format", "dsg", "-o", tmp_path / "g.json")
    assert result.exit_code == 2
    assert_one_line_error(result.stderr, "no scene graph")
    assert not (tmp_path / "g.json").exists()


def test_room_names_are_written_and_read_back(sample_map: Path, tmp_path: Path) -> None:
    """The sample's rooms keep their names (Hydra's labels) in the file, as node names and in
    the records, and a map built with the file as its graph plans from a room by its name."""
    out = tmp_path / "named.json"
    assert run("export", sample_map, "--historical", "--format", "dsg", "-o", out).exit_code == 0
    graph = _graph(out)
    rooms = run_json("predict", sample_map, "--historical", "--layer", "rooms", "--format",
                     "json")["entries"]
    named = {row["id"]: row["name"] for row in rooms}
    assert named["R2"] == "kitchen"  # the sample's kitchen (samples/README.md)
    for node_id, name in named.items():
        node = graph.get_node(spark_dsg.NodeSymbol(node_id[0], int(node_id[1:])))
        assert node.attributes.name == name
        assert _record(graph, node_id)["name"] == name  # type: ignore[index]
    rebuilt = tmp_path / "again.aion"
    from tests.cli.conftest import SAMPLE

    assert run("build", SAMPLE, "--graph", out, "-o", rebuilt, "-q").exit_code == 0
    assert run("plan", rebuilt, "--from", "kitchen", "--to", "p2").exit_code == 0
    again = run_json("predict", rebuilt, "--historical", "--layer", "rooms", "--format", "json")
    assert {row["id"]: row["name"] for row in again["entries"]} == named


def test_detections_the_graph_file_cannot_hold_are_said_to_be_left_out(
    office: Office, tmp_path: Path
) -> None:
    """A map whose detections all lie on hash cells (built with the graph of another site:
    its places 100 m away) exported as a scene graph wrote "2 places (2 with dynamics)" and
    nothing else: a file of zero flows, every detection left out without a word."""
    far = save_graph_file(tmp_path / "far.json", {0: (100.0, 0.0, 0.0), 1: (101.0, 0.0, 0.0)},
                          [(0, 1)])
    site = tmp_path / "far.aion"
    assert run("build", office.log, "--graph", far, "-o", site, "-q").exit_code == 0
    out = tmp_path / "far-4d.json"
    result = run("export", site, "--historical", "--format", "dsg", "-o", out)
    assert result.exit_code == 0, result.stderr
    assert "wrote" in result.stderr
    used = office.build["detections"]["used"]
    assert (
        f"warning: 100% of the map's detections ({used:,} of {used:,}) lie on "
    ) in " ".join(result.stderr.split())
    assert "the file leaves them out" in " ".join(result.stderr.split())
    # a map whose places hold every detection says nothing of the kind
    result = run("export", office.map, "--historical", "--format", "dsg", "-o",
                 tmp_path / "office-4d.json")
    assert result.exit_code == 0, result.stderr
    assert "leaves them out" not in " ".join(result.stderr.split())


@pytest.mark.parametrize(
    ("on_cells", "on_nodes", "said"),
    [(2.0, 3634.0, "under 1%"), (4321.0, 1.0, "over 99%"), (1.0, 1.0, "50%"), (5.0, 0.0, "100%")],
)
def test_the_left_out_share_is_never_rounded_to_none_or_all(
    on_cells: float, on_nodes: float, said: str
) -> None:
    """The office sample's 2 of 3,636 detections on cells read "0% of the map's detections
    (2 of 3,636) ... the file leaves them out"; 4,321 of 4,322 read "100%"."""
    from types import SimpleNamespace

    import numpy as np

    from aion_cli.graph_export import cells_left_out

    class Entries:
        counts = np.array([[on_cells, 0.0], [on_nodes, 0.0]])
        nodir = np.zeros(2)

        def cell_rows(self) -> np.ndarray:
            return np.array([0])

        def node_rows(self) -> np.ndarray:
            return np.array([1])

    got = cells_left_out(SimpleNamespace(state=SimpleNamespace(entries=Entries())))
    assert got is not None
    assert got[0].startswith(f"{said} of the map's detections "), got[0]


def test_the_api_warns_of_the_detections_a_graph_file_leaves_out(
    office: Office, tmp_path: Path
) -> None:
    """aion export --format dsg warns when most of the map's detections lie on hash cells,
    which the spark_dsg file leaves out; Map.export(..., format="dsg") wrote the same file of
    zero flows without a word. It issues the warning as an AionWarning, in the API's words."""
    far = save_graph_file(tmp_path / "far.json", {0: (100.0, 0.0, 0.0), 1: (101.0, 0.0, 0.0)},
                          [(0, 1)])
    site = tmp_path / "far.aion"
    assert run("build", office.log, "--graph", far, "-o", site, "-q").exit_code == 0
    cli = run("export", site, "--historical", "--format", "dsg", "-o", tmp_path / "cli.json")
    said = " ".join(cli.stderr.split()).split("warning: ")[1]
    with pytest.warns(aion.AionWarning) as caught:
        aion.Map.load(site).export(tmp_path / "api.json", historical=True, format="dsg")
    (warned,) = [str(w.message) for w in caught]
    assert warned.startswith("100% of the map's detections")
    assert warned == said.replace("(--format ply or png shows them)",
                                  "(format='ply' or Map.picture shows them)")
    assert all(w.filename == __file__ for w in caught)
    with warnings.catch_warnings():  # a map whose places hold its detections: no warning
        warnings.simplefilter("error", aion.AionWarning)
        aion.Map.load(office.map).export(tmp_path / "ok.json", historical=True, format="dsg")


def test_the_api_gives_the_notes_the_cli_prints(sample_map: Path, tmp_path: Path) -> None:
    """aion export --format dsg notes what a map does not store of the source graph (and the
    few detections the file leaves out); Map.export(..., format="dsg") returned the file alone.
    Its list of files now carries the same notes, in the API's words, as notes (no warning)."""
    cli = run("export", sample_map, "--historical", "--format", "dsg", "-o", tmp_path / "c.json")
    assert cli.exit_code == 0, cli.stderr
    printed = " ".join(cli.stderr.split())
    m = aion.Map.load(sample_map)
    with warnings.catch_warnings():
        warnings.simplefilter("error", aion.AionWarning)
        files = m.export(tmp_path / "a.json", historical=True, format="dsg")
    assert files == [tmp_path / "a.json"]  # still the list of the files written
    assert len(files.notes) == 2, files.notes
    stored, left_out = files.notes
    assert stored.startswith("a map does not store a scene graph's objects")
    # the sample's 2 of 3,636 detections on hash cells: a note, not a warning
    assert left_out.startswith("under 1% of the map's detections (2 of 3,636)")
    assert left_out.endswith("(format='ply' or Map.picture shows them)")
    assert stored in printed
    assert left_out.replace("format='ply' or Map.picture", "--format ply or png") in printed
    assert m.export(tmp_path / "s.ply", historical=True).notes == ()  # a scene file: none
