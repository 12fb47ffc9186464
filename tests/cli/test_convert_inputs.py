"""``aion convert TRACKS`` where TRACKS is no tracks file: each is one error line naming what
it is and where it goes, exit 2, and no log is written. (Before: a folder, a rosbag2 log
folder included, was "tracks file not found: data / hint: check the path" though it exists;
a scene-graph JSON was refused as "not a valid atc tracks file: line 1: expected 6 columns
..., got 111268 (the file ends inside this line)" with the hint that the file looks cut
short.)"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from aion_cli.errors import path_word
from tests.cli.conftest import assert_one_line_error, run


def _refused(tracks: Path, out: Path, *fragments: str, layout: str = "atc") -> None:
    result = run("convert", tracks, "--layout", layout, "-o", out)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, *fragments)
    assert not out.exists()


def test_a_folder_is_named_a_folder(tmp_path: Path) -> None:
    data = tmp_path / "data"
    data.mkdir()
    (data / "atc.csv").write_text("1351038020,1,1,2,0.3,0.1\n")
    _refused(data, tmp_path / "a.mcap", f"{data} is a folder, not a tracks file")


def test_a_rosbag2_folder_is_named_a_log(tmp_path: Path) -> None:
    src = tmp_path / "atc.csv"
    src.write_text("1351038020,1,1,2,0.3,0.1\n1351038021,1,1.5,2,0.3,0.1\n")
    bag = tmp_path / "bag"  # no suffix: a rosbag2 folder (metadata.yaml and a .db3)
    assert run("convert", src, "--layout", "atc", "-o", bag, "-q").exit_code == 0
    assert (bag / "metadata.yaml").is_file()
    _refused(bag, tmp_path / "b.mcap", f"{bag} is a rosbag2 log, not a tracks file")


@pytest.mark.parametrize("layout", ["atc", "canonical", "lincoln", "eth"])
def test_a_scene_graph_is_named_a_scene_graph(tmp_path: Path, layout: str) -> None:
    graph = tmp_path / "dsg.json"
    nodes = [{"id": k, "layer": 3, "attributes": {"position": [k, 0, 0]}} for k in range(50)]
    graph.write_text(json.dumps({"directed": False, "edges": [], "nodes": nodes}))
    out = tmp_path / "g.mcap"
    _refused(graph, out, "dsg.json is a scene graph, not a tracks file", layout=layout)
    stderr = run("convert", graph, "--layout", layout, "-o", out).stderr
    assert f"--graph {path_word(graph)}" in stderr


def test_a_device_or_fifo_is_named_as_it_is(tmp_path: Path) -> None:
    """``aion convert /dev/null`` and ``--graph /dev/null`` (of convert, build and simulate's
    ``--environment``) said "not found" of a path that exists; a FIFO is refused before it is
    opened (reading one without a writer blocks), and a graph that is a folder is named so."""
    import os

    fifo = tmp_path / "tracks.fifo"
    os.mkfifo(fifo)
    _refused(Path("/dev/null"), tmp_path / "a.mcap", "/dev/null is a character device")
    _refused(fifo, tmp_path / "a.mcap", f"{fifo} is a FIFO")
    tracks = tmp_path / "t.csv"
    tracks.write_text("t_ns,track_id,x,y,z,heading_rad,speed_mps\n1780000000000000000,1,0,0,0,0,1\n")
    for command in (
        ("convert", tracks, "-o", tmp_path / "c.mcap", "--graph", "/dev/null"),
        ("simulate", "-o", tmp_path / "s.mcap", "--environment", "/dev/null"),
    ):
        result = run(*command)
        assert result.exit_code == 2, result.stderr
        assert_one_line_error(result.stderr, "/dev/null is a character device, not a regular "
                              "file: aion does not read a scene-graph file from it")  # fmt: skip
    from aion_cli.errors import InputError
    from aion_cli.formats.dsg_files import read_dsg_file

    with pytest.raises(InputError, match="is a folder, not a scene-graph file"):
        read_dsg_file(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.csv", "tracks.fifo"]
