"""Robots recording at once that log one scene-graph session's graphs on one topic (``aion
build robot1.mcap robot2.mcap``, :mod:`aion_cli.session_graphs`): each robot's graph holds the
places it has mapped so far. Read as one stream, each graph replaced the other's at every
message, so the places one robot's graph held and the other's not (yet) left the map's graph
and came back, and the map kept the graph of whichever robot came last. The map's graph is now
the session's one growing graph: the union of each robot's latest graph.

The logs (``tests.test_fleet_graphs.write_robot``): robot 1 maps the whole office (p0..p6) and
sees a person standing at p5; robot 2, in the same session, has mapped p0..p4 only (the same
positions) and sees a person at p4; graphs every minute, 30 s apart. The answer is known
independently: the union is the whole office, so the map equals the map of the same logs built
on the office's graph given once (``--graph FILE``), entry for entry."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.engine.graph_union import union_graphs
from aion_cli.engine.types import GraphSnapshot, Layer
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import EDGES, PLACES, ROOMS, build_graph, sym
from tests.test_fleet_graphs import DURATION_S, write_robot

#: robot 2's part of the session's graph: the places it mapped
PART = {k: xyz for k, xyz in PLACES.items() if k <= 4}


def _robots(folder: Path) -> tuple[Path, Path]:
    one = write_robot(folder / "robot1.mcap", PLACES, PLACES[5][:2], track=1)
    two = write_robot(folder / "robot2.mcap", PART, PLACES[4][:2], track=1, offset_s=30)
    return one, two


def live_entries(path: Path) -> dict[str, np.ndarray]:
    """The map's live entries: node id, position, counts per direction bin (no-direction
    last), in node-id then position order."""
    entries = load_map(path).state.entries
    rows = entries.live_rows()
    counts = np.column_stack([entries.counts[rows], entries.nodir[rows]])
    order = np.lexsort((entries.xyz[rows][:, 1], entries.xyz[rows][:, 0], entries.node_id[rows]))
    return {
        "node_id": entries.node_id[rows][order],
        "xyz": entries.xyz[rows][order],
        "counts": counts[order],
    }


def test_the_map_holds_the_sessions_growing_graph(tmp_path: Path) -> None:
    """Before: robot 2's graph (p0..p4) came last, so the map's graph lacked p5 and p6, and at
    every one of robot 2's graphs p5 left the graph and robot 1's person's flow went to a hash
    cell (and back into the node at robot 1's next graph). Now the graph holds every place
    either robot mapped, and every detection of both people is on its place's node."""
    one, two = _robots(tmp_path)
    out = tmp_path / "fleet.aion"
    build_map(BuildOptions(logs=(one, two), output=out, workers=1))
    state = load_map(out).state
    assert state.graph is not None
    ids = np.asarray(state.graph.places.ids)
    assert sorted(ids.tolist()) == sorted(sym("p", k) for k in PLACES)
    np.testing.assert_allclose(
        np.asarray(state.graph.places.xyz)[np.argsort(ids)],
        [PLACES[k] for k in sorted(PLACES)],
    )
    got = live_entries(out)
    held = got["counts"].sum(axis=1) > 0
    assert got["node_id"][held].tolist() == [sym("p", 4), sym("p", 5)]
    assert got["counts"][held].sum(axis=1).tolist() == [DURATION_S, DURATION_S]


def test_the_map_equals_the_map_on_the_sessions_whole_graph(tmp_path: Path) -> None:
    """The independent answer: the same logs built on the office's whole graph given once
    (``--graph FILE``) hold the same entries, to the count; either order of the logs."""
    one, two = _robots(tmp_path)
    graph_file = tmp_path / "office.json"
    build_graph(PLACES, EDGES, ROOMS).save(str(graph_file))
    build_map(BuildOptions(logs=(one, two), output=tmp_path / "file.aion", workers=1,
                           graph_file=graph_file))
    want = live_entries(tmp_path / "file.aion")
    for k, logs in enumerate(((one, two), (two, one))):
        out = tmp_path / f"fleet{k}.aion"
        build_map(BuildOptions(logs=logs, output=out, workers=1))
        got = live_entries(out)
        for name in want:
            np.testing.assert_array_equal(got[name], want[name], err_msg=name)


def test_a_parallel_build_joins_the_same_graphs(tmp_path: Path) -> None:
    """``--workers 2``: overlapping logs build in one shard, which joins the graphs as one
    pass does."""
    from tests.graph_stream_logs import assert_same_map

    one, two = _robots(tmp_path)
    build_map(BuildOptions(logs=(one, two), output=tmp_path / "one.aion", workers=1))
    build_map(BuildOptions(logs=(one, two), output=tmp_path / "two.aion", workers=2))
    assert_same_map(tmp_path / "one.aion", tmp_path / "two.aion")


def _layer(ids: list[int], xyz: list[tuple[float, float, float]]) -> Layer:
    return Layer(np.array(ids, np.uint64), np.array(xyz, np.float64).reshape(-1, 3),
                 np.zeros(len(ids), np.uint64))


def _graph(t: int, ids: list[int], xyz: list[tuple[float, float, float]],
           edges: list[tuple[int, int]]) -> GraphSnapshot:
    return GraphSnapshot(t, _layer(ids, xyz), np.array(edges, np.int64).reshape(-1, 2))


def test_union_keeps_every_node_at_its_newest_position() -> None:
    """Two robots' latest graphs of one session: the union holds the nodes of both (the
    newest graph's first, in its order), a node both hold at the newest graph's position,
    and every edge once, as rows of the union's nodes."""
    old = _graph(1, [10, 11, 12], [(0, 0, 0), (1, 0, 0), (2, 0, 0)], [(0, 1), (1, 2)])
    new = _graph(2, [13, 11, 10], [(5, 5, 0), (1.1, 0, 0), (0, 0, 0)], [(2, 1), (0, 1)])
    union = union_graphs([old, new])
    assert union.t_ns == 2
    assert np.asarray(union.places.ids).tolist() == [13, 11, 10, 12]
    np.testing.assert_array_equal(
        union.places.xyz, [(5, 5, 0), (1.1, 0, 0), (0, 0, 0), (2, 0, 0)]
    )
    ids = np.asarray(union.places.ids)
    pairs = {tuple(sorted(ids[e].tolist())) for e in np.asarray(union.edges)}
    assert pairs == {(10, 11), (11, 12), (11, 13)}
    assert len(union.edges) == 3
    assert np.asarray(union.edges)[:2].tolist() == [[2, 1], [0, 1]]  # the newest's first


def test_union_of_graphs_the_newest_holds_whole_is_the_newest() -> None:
    """Graphs the newest holds whole (one shared graph logged twice): the newest graph's own
    layers, so the map sees the graph one robot's log gives."""
    old = _graph(1, [10, 11], [(0, 0, 0), (1, 0, 0)], [(0, 1)])
    new = _graph(2, [10, 11, 12], [(0, 0, 0), (1, 0, 0), (2, 0, 0)], [(0, 1), (1, 2)])
    union = union_graphs([old, new])
    assert union.places is new.places
    np.testing.assert_array_equal(union.edges, new.edges)


def test_a_parallel_build_does_not_cut_the_robots_logs_in_time(tmp_path: Path) -> None:
    """Logs a parallel build could cut at a quiet moment (nobody seen over the 10 s before
    the second window): a time shard starting there would apply robot 1's graph alone (p0..p4)
    until robot 2's next graph, and robot 2's person at p5 would go to a hash cell meanwhile.
    Robots at once logging one session's graphs are built in sequence, as one pass."""
    from tests.graph_stream_logs import assert_same_map

    quiet = range(585, 600)
    one = write_robot(tmp_path / "robot1.mcap", PART, PLACES[4][:2], track=1, quiet=quiet)
    two = write_robot(tmp_path / "robot2.mcap", PLACES, PLACES[5][:2], track=1, offset_s=30,
                      seconds=range(1100), quiet=quiet)
    build_map(BuildOptions(logs=(one, two), output=tmp_path / "one.aion", workers=1))
    report = build_map(BuildOptions(logs=(one, two), output=tmp_path / "two.aion", workers=2))
    assert any(": not cut into time shards" in note for note in report.notes), report.notes
    assert_same_map(tmp_path / "one.aion", tmp_path / "two.aion")
