"""A fleet's map three ways: one build of both robots' logs (``aion build A B -o M``), robot
1's map continued with robot 2's log (``aion build A -o M1; aion build B --map M1 -o M2``),
and ``aion merge`` of each robot's own map. The answer each is held to is the one build's
map, which the fleet tests check against known positions (``tests/test_fleet_tf_trees.py``:
TF per robot; ``tests/test_fleet_track_ids.py``: track ids per robot;
``tests/test_fleet_session_graphs.py``: one session's graph).

* Robots one after the other (disjoint times): continuing is the one build, member for member
  (TF, track ids and the scene-graph stream are the one build's: nothing overlaps). The merge
  holds the same entries to the count; its temporal members differ by the merge's documented
  approximations (README *Merging maps*).
* Robots at once: a map does not take a log of times it has closed (logs in time order), so
  continuing is refused with the one build as the hint. A robot that joins inside the map's
  open window is taken (with a note) and learnt after the map's data: with TF of its own it
  gives the one build's map; its scene graphs of the map's session are a later graph stream
  that replaces the map's graph (as a later log of the map's own robot does), where the one
  build joins both robots' graphs (by design; README *Several robots' scene graphs*). The
  merge holds the one build's entries for TF and track ids, and for one session's graphs the
  one build's union of both robots' graphs (:mod:`aion_cli.merge_graph`).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import tests.test_fleet_graphs as graphs
import tests.test_fleet_tf_trees as tf
from aion_cli.errors import InputError
from aion_cli.mapquery import load_map
from aion_cli.merging import merge_map_files
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import PLACES, sym
from tests.graph_stream_logs import assert_same_map
from tests.test_fleet_session_graphs import PART, live_entries

#: robot 2 numbering its person track 1, as robot 1 does (every tracker counts from 0 or 1)
SAME_TRACK = replace(tf.ROBOT2, track=tf.ROBOT1.track)


def _assert_same_entries(a: Path, b: Path) -> None:
    want, got = live_entries(a), live_entries(b)
    np.testing.assert_array_equal(got["node_id"], want["node_id"])
    np.testing.assert_allclose(got["xyz"], want["xyz"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got["counts"], want["counts"], rtol=0, atol=1e-9)


def _three_ways(folder: Path, one: Path, two: Path) -> dict[str, Path]:
    """The one build, each robot's own map, and their merge; the continued map when the
    build takes it (absent when refused)."""
    out = {name: folder / f"{name}.aion" for name in ("both", "m1", "m2", "merged", "cont")}
    build_map(BuildOptions(logs=(one, two), output=out["both"], workers=1))
    build_map(BuildOptions(logs=(one,), output=out["m1"], workers=1))
    build_map(BuildOptions(logs=(two,), output=out["m2"], workers=1))
    merge_map_files([out["m1"], out["m2"]], out["merged"])
    return out


def _continue(maps: dict[str, Path], two: Path) -> None:
    build_map(BuildOptions(logs=(two,), output=maps["cont"], workers=1,
                           continue_from=maps["m1"]))


def test_tf_robots_one_after_the_other(tmp_path: Path) -> None:
    """Robot 2 drives after robot 1 (its log starts when robot 1's has ended, and after)."""
    one, two = tmp_path / "robot1.mcap", tmp_path / "robot2.mcap"
    tf.write_robot([one], tf.ROBOT1)
    tf.write_robot([two], tf.ROBOT2, offset_ns=2 * tf.DURATION_S * tf.S)
    maps = _three_ways(tmp_path, one, two)
    _continue(maps, two)
    assert_same_map(maps["both"], maps["cont"])
    _assert_same_entries(maps["both"], maps["merged"])


def test_graph_robots_one_after_the_other(tmp_path: Path) -> None:
    """Robot 2 (of robot 1's scene-graph session, places p0..p4) logs after robot 1: its
    graphs replace robot 1's as a later log's do, in the one build and the continued map;
    the merge keeps the later map's graph, so all three hold robot 2's."""
    one = graphs.write_robot(tmp_path / "robot1.mcap", PLACES, PLACES[5][:2], track=1)
    two = graphs.write_robot(tmp_path / "robot2.mcap", PART, PLACES[4][:2], track=1,
                             offset_s=30, seconds=range(1200, 2400))
    maps = _three_ways(tmp_path, one, two)
    _continue(maps, two)
    assert_same_map(maps["both"], maps["cont"])
    _assert_same_entries(maps["both"], maps["merged"])
    for name in ("both", "merged"):
        graph = load_map(maps[name]).state.graph
        assert graph is not None
        assert sorted(np.asarray(graph.places.ids).tolist()) == [sym("p", k) for k in PART]


def test_tf_robots_at_once(tmp_path: Path) -> None:
    """Robots driving at once (both tracking their person as track 1): continuing robot 1's
    map with robot 2's log is refused (its detections fall in windows the map has closed),
    nothing written, the hint the one build; the merge holds the one build's entries (each
    robot's detections moved by its own TF, its track headed by its own estimator)."""
    one, two = tmp_path / "robot1.mcap", tmp_path / "robot2.mcap"
    tf.write_robot([one], tf.ROBOT1)
    tf.write_robot([two], SAME_TRACK, offset_ns=tf.S // 4)
    maps = _three_ways(tmp_path, one, two)
    with pytest.raises(InputError) as exc:
        _continue(maps, two)
    assert "logs must be added to a map in time order" in exc.value.message
    assert f"aion build {one.name} {two} -o NEW.aion" in (exc.value.hint or "")
    assert not maps["cont"].exists()
    _assert_same_entries(maps["both"], maps["merged"])


def test_tf_robot_joining_in_the_open_window(tmp_path: Path) -> None:
    """Robot 2 starts 15 minutes into robot 1's 20 (inside robot 1's map's open window):
    the continued map takes it, with the note, and is the one build's map."""
    one, two = tmp_path / "robot1.mcap", tmp_path / "robot2.mcap"
    tf.write_robot([one], tf.ROBOT1)
    tf.write_robot([two], SAME_TRACK, offset_ns=900 * tf.S)
    maps = _three_ways(tmp_path, one, two)
    report = build_map(BuildOptions(logs=(two,), output=maps["cont"], workers=1,
                                    continue_from=maps["m1"]))
    assert any("before m1.aion's data ends" in note for note in report.notes)
    assert_same_map(maps["both"], maps["cont"])
    _assert_same_entries(maps["both"], maps["merged"])


def test_graph_robot_joining_in_the_open_window(tmp_path: Path) -> None:
    """Robot 2 of robot 1's session (p0..p4) joins 15 minutes in. The one build joins both
    robots' graphs (all seven places; every detection on its place's node). The continued
    map learns robot 2's log after robot 1's: robot 2's graphs replace the map's, and p5,
    which robot 2 never mapped, leaves it: robot 1's person's flow is released to a hash
    cell (by design: a map's graph and a later log's graphs are one stream, README *Several
    robots' scene graphs*). The merge of the robots' maps, whose spans overlap, keeps the one
    build's union (:mod:`aion_cli.merge_graph`)."""
    one = graphs.write_robot(tmp_path / "robot1.mcap", PLACES, PLACES[5][:2], track=1)
    two = graphs.write_robot(tmp_path / "robot2.mcap", PART, PLACES[4][:2], track=1,
                             offset_s=30, seconds=range(900, 2100))
    maps = _three_ways(tmp_path, one, two)
    _continue(maps, two)
    every = sorted(sym("p", k) for k in PLACES)
    for name, places, on_p5 in (("both", every, 1200), ("cont", every[:5], 0),
                                ("merged", every, 1200)):
        state = load_map(maps[name]).state
        assert state.graph is not None
        assert sorted(np.asarray(state.graph.places.ids).tolist()) == places, name
        got = live_entries(maps[name])
        total = got["counts"].sum(axis=1)
        assert total[got["node_id"] == sym("p", 5)].sum() == on_p5, name
        assert total.sum() == 2 * graphs.DURATION_S, name
    _assert_same_entries(maps["both"], maps["merged"])  # the union's entries too
