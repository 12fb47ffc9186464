"""Which scene graph ``aion merge`` keeps for maps whose time spans overlap
(:mod:`aion_cli.merge_graph`), held to one build of the maps' logs where one build takes them.

Robot 2 drives inside robot 1's time (it starts later and stops first). Of one scene-graph
session, one build joins both robots' graphs (:mod:`aion_cli.session_graphs`); the merge kept
the graph of whichever map ended later and released the other robot's places to hash cells
(and its report named the later-starting map's graph). Of two sessions, one build refuses the
logs and the merge binds every flow to the newest graph: robot 1's, whose latest graph is the
newer, where the later-starting robot 2's was taken."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import tests.test_fleet_graphs as graphs
from aion_cli.mapquery import load_map
from aion_cli.merging import merge_map_files
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import PLACES
from tests.test_fleet_session_graphs import PART, live_entries

#: robot 2's seconds: 2 to 9 minutes into robot 1's 20 (ending in the first of its two windows)
INSIDE = range(120, 540)


def _maps(folder: Path, logs: tuple[Path, Path]) -> dict[str, Path]:
    out = {name: folder / f"{name}.aion" for name in ("m1", "m2", "merged")}
    build_map(BuildOptions(logs=(logs[0],), output=out["m1"], workers=1))
    build_map(BuildOptions(logs=(logs[1],), output=out["m2"], workers=1))
    return out


def test_one_sessions_robots_at_once_merge_into_one_builds_graph(tmp_path: Path) -> None:
    """Robot 1 maps p0..p4 for 20 minutes; robot 2, of its session, maps p0..p6 for 7
    minutes inside them, its person standing at p5. The merge holds the one build's graph
    (the union: seven places, at the same positions, with the same edges) and its entries
    (the person's 420 detections on p5, not on a hash cell)."""
    one = graphs.write_robot(tmp_path / "robot1.mcap", PART, PLACES[4][:2], track=1)
    two = graphs.write_robot(tmp_path / "robot2.mcap", PLACES, PLACES[5][:2], track=1,
                             offset_s=30, seconds=INSIDE)
    maps = _maps(tmp_path, (one, two))
    both = tmp_path / "both.aion"
    build_map(BuildOptions(logs=(one, two), output=both, workers=1))
    report = merge_map_files([maps["m1"], maps["m2"]], maps["merged"])
    assert report.lineage == "same"
    assert report.graph_source == "the union of m2.aion and m1.aion's latest graphs (maps at once)"
    want, got = load_map(both).state.graph, load_map(maps["merged"]).state.graph
    assert want is not None
    assert got is not None
    assert len(want.places) == len(PLACES)  # the one build's union
    np.testing.assert_array_equal(got.places.ids, want.places.ids)
    np.testing.assert_allclose(got.places.xyz, want.places.xyz, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.sort(got.edges, axis=1), np.sort(want.edges, axis=1))
    w, g = live_entries(both), live_entries(maps["merged"])
    np.testing.assert_array_equal(g["node_id"], w["node_id"])
    np.testing.assert_allclose(g["counts"], w["counts"], rtol=0, atol=1e-9)
    on_p5 = g["counts"].sum(axis=1)[g["node_id"] == np.asarray(want.places.ids)[5]]
    assert on_p5.sum() == len(INSIDE)


def test_two_sessions_at_once_bind_to_the_newest_graph(tmp_path: Path) -> None:
    """Robot 2 in a Hydra session of its own (the same ids 0.7 m and 3 m away) inside robot
    1's time: its latest graph (at 8:30 min) is older than robot 1's (19:00), so every flow
    binds to robot 1's places, and the report says so."""
    one = graphs.write_robot(tmp_path / "robot1.mcap", PLACES, PLACES[5][:2], track=1)
    two = graphs.write_robot(tmp_path / "robot2.mcap", graphs.PLACES2,
                             graphs.PLACES2[3][:2], track=2, offset_s=30, seconds=INSIDE)
    maps = _maps(tmp_path, (one, two))
    report = merge_map_files([maps["m1"], maps["m2"]], maps["merged"])
    assert report.lineage == "different"
    assert report.graph_source == "m1.aion's latest graph"
    graph = load_map(maps["merged"]).state.graph
    assert graph is not None
    np.testing.assert_allclose(graph.places.xyz, [PLACES[k] for k in sorted(PLACES)], atol=1e-9)
