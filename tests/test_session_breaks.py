"""One build of logs one after the other whose scene graphs are of two Hydra sessions (``aion
build day1.mcap day2.mcap``: Hydra restarted between the days, numbering its places from p0
again, elsewhere). The stream used to take the second day's graph as a later graph of one
session: every node entry followed its node id to the new session's place of that id, so the
first day's flows landed where nobody was seen (3 m away here). ``aion merge`` of the days'
maps and ``aion build day2.mcap --map day1.aion --lineage different`` release the first
day's node entries to hash cells at their places instead, to bind to the new session's places
within reach; the one build now does the same at the first graph of a later log that is of
another session (``aion merge``'s lineage test), with a note.

The logs (``tests.test_fleet_graphs.write_robot``): day 1's graph is the office
(``tests.cli.logdata.PLACES``) and its person stands at p4 (4, 2); day 2's graph holds the
same ids 0.7 m, 3 m away (``PLACES2``: p4 at (4.7, 5), p2 at (4.7, 3)) and its person stands
at its p1. The answer is known independently: the merge of the two days' own maps and the
continued map, which both release by the lineage rule."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.merging import merge_map_files
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import PLACES, sym
from tests.graph_stream_logs import assert_same_map
from tests.test_fleet_graphs import PLACES2, write_robot
from tests.test_fleet_session_graphs import live_entries

DAY1, DAY2 = range(600), range(600, 1200)


def _days(folder: Path) -> tuple[Path, Path]:
    one = write_robot(folder / "day1.mcap", PLACES, PLACES[4][:2], track=1, seconds=DAY1)
    two = write_robot(folder / "day2.mcap", PLACES2, PLACES2[1][:2], track=1, seconds=DAY2)
    return one, two


def _held(path: Path) -> dict[str, np.ndarray]:
    got = live_entries(path)
    held = got["counts"].sum(axis=1) > 0
    return {name: values[held] for name, values in got.items()}


def test_a_later_session_releases_the_flows_before_it(tmp_path: Path) -> None:
    """Before: day 1's 600 detections were on p4 at day 2's (4.7, 5), 3.2 m from where its
    person stood, beside nothing day 2 saw. Now they are released there and bind, as the
    merge's and the continued map's, to day 2's place within reach of where they were seen
    (p2, 0.87 m from their cell); the three maps hold the same entries."""
    one, two = _days(tmp_path)
    report = build_map(BuildOptions(logs=(one, two), output=tmp_path / "both.aion", workers=1))
    build_map(BuildOptions(logs=(one,), output=tmp_path / "day1.aion", workers=1))
    build_map(BuildOptions(logs=(two,), output=tmp_path / "day2.aion", workers=1))
    merged = merge_map_files([tmp_path / "day1.aion", tmp_path / "day2.aion"],
                             tmp_path / "merged.aion")
    assert merged.lineage == "different"
    build_map(BuildOptions(logs=(two,), output=tmp_path / "cont.aion", workers=1,
                           continue_from=tmp_path / "day1.aion", lineage="different"))
    got = _held(tmp_path / "both.aion")
    assert got["node_id"].tolist() == [sym("p", 1), sym("p", 2)]
    np.testing.assert_allclose(got["xyz"][:, :2], [PLACES2[1][:2], PLACES2[2][:2]])
    assert got["counts"].sum(axis=1).tolist() == [600, 600]
    for other in ("merged", "cont"):
        want = _held(tmp_path / f"{other}.aion")
        for name in want:
            np.testing.assert_allclose(got[name], want[name], rtol=0, atol=1e-9,
                                       err_msg=f"{other} {name}")
    assert any("another scene-graph session" in note for note in report.notes), report.notes


def test_a_later_log_of_the_same_session_keeps_its_flows(tmp_path: Path) -> None:
    """A later log of the same session whose graph moved one place 3 m (a loop closure
    between the logs; the other ids where they were): no release, no note; the flows on the
    moved place follow it, as in one log."""
    moved = dict(PLACES)
    moved[4] = PLACES2[4]
    one = write_robot(tmp_path / "day1.mcap", PLACES, PLACES[4][:2], track=1, seconds=DAY1)
    two = write_robot(tmp_path / "day2.mcap", moved, PLACES[1][:2], track=1, seconds=DAY2)
    report = build_map(BuildOptions(logs=(one, two), output=tmp_path / "both.aion", workers=1))
    assert not any("another scene-graph session" in note for note in report.notes)
    got = _held(tmp_path / "both.aion")
    assert got["node_id"].tolist() == [sym("p", 1), sym("p", 4)]
    np.testing.assert_allclose(got["xyz"][:, :2], [PLACES[1][:2], PLACES2[4][:2]])


def test_a_parallel_build_releases_as_one_pass(tmp_path: Path) -> None:
    """Three logs, the first two of one session, the third of another: ``--workers 2``
    gives the one pass's map."""
    zero = write_robot(tmp_path / "day0.mcap", PLACES, PLACES[1][:2], track=1,
                       seconds=range(-600, 0))
    one, two = _days(tmp_path)
    logs = (zero, one, two)
    build_map(BuildOptions(logs=logs, output=tmp_path / "one.aion", workers=1))
    build_map(BuildOptions(logs=logs, output=tmp_path / "two.aion", workers=2))
    assert_same_map(tmp_path / "one.aion", tmp_path / "two.aion")
    got = _held(tmp_path / "one.aion")
    assert sym("p", 4) not in got["node_id"].tolist()  # day 1's person: released, on p2
