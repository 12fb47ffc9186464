"""The navigational graph derived from where people walk (``aion build --derive-graph``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.derive_graph import OccupancyGrid
from tests.robustness.conftest import T0, S, build_json, person, write_log


def test_occupied_cells_become_nodes_joined_to_their_8_neighbours() -> None:
    grid = OccupancyGrid(spacing=1.0)
    # a 2x2 block of busy cells at the origin, one busy cell far away, one cell below threshold
    block = np.array([[0.5, 0.5, 0.0], [1.5, 0.5, 0.0], [0.5, 1.5, 0.0], [1.5, 1.5, 0.0]])
    grid.add(np.repeat(block, 3, axis=0))  # batch 1: 3 each
    grid.add(np.array([[10.2, 10.7, 1.0]] * 3))  # batch 2
    grid.add(np.array([[5.5, 5.5, 0.0]] * 2 + [[np.nan, 0.0, 0.0]]))  # below 3, and a NaN row
    assert grid.total == 12 + 3 + 2
    snap = grid.graph(min_detections=3, t_ns=7)
    assert snap.t_ns == 7
    assert snap.layer_name == "derived"
    assert len(snap.places) == 5
    # ids are p0..p4 (NodeSymbol 'p')
    assert [int(i) >> 56 for i in snap.places.ids] == [ord("p")] * 5
    assert sorted(int(i) & ((1 << 56) - 1) for i in snap.places.ids) == [0, 1, 2, 3, 4]
    # the block is fully connected (4 sides + 2 diagonals = 6 edges); the far cell is isolated
    assert len(snap.edges) == 6
    pairs = {tuple(sorted(e)) for e in snap.edges.tolist()}
    far = int(np.argmin(np.abs(snap.places.xyz[:, 0] - 10.5)))
    assert all(far not in p for p in pairs)
    np.testing.assert_allclose(snap.places.xyz[far], [10.5, 10.5, 1.0])


def test_floors_are_not_connected() -> None:
    grid = OccupancyGrid(spacing=1.0)
    grid.add(np.array([[0.5, 0.5, 0.0], [0.5, 0.5, 3.0]] * 4))
    snap = grid.graph(min_detections=1, t_ns=0)
    assert len(snap.places) == 2
    assert len(snap.edges) == 0


def test_empty_grid_gives_an_empty_graph() -> None:
    snap = OccupancyGrid(0.5).graph(1, 0)
    assert len(snap.places) == 0
    assert snap.edges.shape == (0, 2)


def test_a_log_shorter_than_the_stability_wait_says_why_its_places_hold_nothing(
    tmp_path: Path,
) -> None:
    """10 s of one person walking, places derived from it: no place is stable for 30 s of
    log time before the log ends, so every detection stays on a hash cell. The warning says
    so; it said "are the detections and the graph in the same frame?", of a graph derived
    from those very detections. A log long enough binds its cells (no warning)."""
    msgs = [person(T0 + k * S // 10, (0.1 * k, 0.0, 0.0)) for k in range(100)]
    short = build_json(write_log(tmp_path / "short.mcap", msgs), "--derive-graph",
                       "-o", tmp_path / "short.aion")
    assert short["nodes"] > 0
    assert short["bound_cells"] == 0
    (warning,) = [w for w in short["warnings"] if "hash cells" in w]
    assert warning.startswith("100 of the 100 detections stay on hash cells: none of the "
                              f"scene graph's {short['nodes']} places had been stable for 30 s")
    assert "same frame" not in warning
    slow = [person(T0 + k * S, (0.1 * (k % 100), 0.0, 0.0)) for k in range(300)]
    long = build_json(write_log(tmp_path / "long.mcap", slow), "--derive-graph",
                      "-o", tmp_path / "long.aion")
    assert long["bound_cells"] > 0
    assert not any("hash cells" in w for w in long["warnings"])


def test_continuing_a_derived_map_keeps_its_places_and_says_so(tmp_path: Path) -> None:
    """Places are derived from the logs of one build: a continued map keeps them, so
    --derive-graph with --map has no effect, which a note says (it was silent)."""
    walk_a = [person(T0 + k * S, (0.1 * (k % 100), 0.0, 0.0)) for k in range(300)]
    walk_b = [person(T0 + (3600 + k) * S, (0.1 * (k % 100), 0.0, 0.0)) for k in range(300)]
    first = tmp_path / "a.aion"
    build_json(write_log(tmp_path / "a.mcap", walk_a), "--derive-graph", "-o", first)
    later = build_json(write_log(tmp_path / "b.mcap", walk_b), "--map", first, "--derive-graph")
    assert later["graph"]["source"] == "continued map"
    assert any(n.startswith("--derive-graph ignored: the continued map keeps its places")
               for n in later["notes"])


def test_a_graph_file_with_derive_graph_says_the_derive_graph_is_ignored(tmp_path: Path) -> None:
    """--graph FILE gives the places, so --derive-graph beside it does nothing: the build took
    the file's places without a word about the flag (it now notes it, as it does where the log
    or the continued map holds the places), and learns the same map as --graph alone."""
    from tests.cli.logdata import save_graph_file

    walk = [person(T0 + k * S, (0.1 * (k % 100), 0.0, 0.0)) for k in range(300)]
    log = write_log(tmp_path / "walk.mcap", walk)
    graph = save_graph_file(tmp_path / "dsg.json", {0: (1.0, 0.0, 0.0), 1: (5.0, 0.0, 0.0)},
                            [(0, 1)])
    both = build_json(log, "--graph", graph, "--derive-graph", "-o", tmp_path / "both.aion")
    alone = build_json(log, "--graph", graph, "-o", tmp_path / "alone.aion")
    assert both["graph"]["source"] == alone["graph"]["source"] == "file dsg.json"
    assert "--derive-graph ignored: the places are --graph FILE's" in both["notes"]
    assert not any("--derive-graph" in n for n in alone["notes"])
    assert both["nodes"] == alone["nodes"] == 2  # the file's two places, none derived
    assert (both["bound_cells"], both["cells"]) == (alone["bound_cells"], alone["cells"])
    assert both["bound_cells"] > 0


def test_info_of_a_derived_map_does_not_name_a_layer_it_has_not(tmp_path: Path) -> None:
    """``aion info MAP`` of a map built with --derive-graph (the real leg_tracker bag) read
    "graph: derived from walking people, places from layer derived": the derived graph's
    places are its own, not a layer of a scene graph. JSON keeps ``nav_layer: derived``."""
    from tests.cli.conftest import run, run_json
    from tests.shared_data import real

    out = tmp_path / "legs.aion"
    log = real("logs", "leg_tracker", "positive_2_extracted.bag")
    run_json("build", log, "--map-frame", "right_laser", "--derive-graph", "-o", out,
             "--workers", "1", "--format", "json")  # fmt: skip
    assert run_json("info", out, "--format", "json")["nav_layer"] == "derived"
    shown = run("info", out)
    assert shown.exit_code == 0, shown.stderr
    row = next(line for line in shown.stdout.splitlines() if "│ graph" in line)
    assert " ".join(row.replace("│", " ").split()) == "graph derived from walking people"
