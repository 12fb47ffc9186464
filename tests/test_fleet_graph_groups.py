"""Robots recording at once in shifts (``aion build am1.mcap am2.mcap pm1.mcap pm2.mcap``):
two robots share one Hydra session's graph in the morning, Hydra is restarted, and two robots
share another session's graph in the afternoon. Each shift's logs overlap each other, not the
other shift's. Before, :mod:`aion_cli.graph_owners` compared every overlapping recording with
the first one (the morning's), so the afternoon's session was refused although the
afternoon's graphs follow the morning's as one robot's later recording's do; and the map's
graph was the union of every overlapping recording's latest graph, the morning's among them,
so places only the morning's session holds stayed in the afternoon's graph and owned the
afternoon's detections. Now each group of recordings that overlap is judged on its own, and
its graphs are the map's while its time lasts (:mod:`aion_cli.session_graphs`).

The logs (``tests.test_fleet_graphs.write_robot``): in the morning robot 1 maps the whole
office (p0..p6, ``tests.cli.logdata.PLACES``) and sees a person standing at p5, robot 2 has
mapped p0..p4 and sees a person at p4; in the afternoon's session the office's p0..p4 lie
0.7 m, 3 m away (``tests.test_fleet_graphs.PLACES2``), robot 3 maps them and sees a person at
its p4, robot 4 has mapped p0..p2 and sees a person where the morning's p5 was (no place of
the afternoon's session within ``bind_radius``). The independent answer: the same people and
graphs in one log per shift (one stream: the afternoon's graph replaces the morning's), and
``aion merge`` of each shift's own map."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.types import GraphSnapshot, Layer
from aion_cli.errors import InputError
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from aion_cli.session_graphs import SessionGraphs
from aion_cli.tf_trees import overlap_groups, overlapping
from tests.cli.logdata import PLACES, sym
from tests.graph_stream_logs import assert_same_map
from tests.test_fleet_graphs import DURATION_S, PLACES2, TOPIC, write_robot
from tests.test_fleet_session_graphs import live_entries

#: the morning's session (the office), robot 2's part of it
AM, AM_PART = PLACES, {k: xyz for k, xyz in PLACES.items() if k <= 4}
#: the afternoon's session: p0..p4 elsewhere; robot 4's part of it
PM = {k: xyz for k, xyz in PLACES2.items() if k <= 4}
PM_PART = {k: xyz for k, xyz in PM.items() if k <= 2}
MORNING, AFTERNOON = range(600), range(600, DURATION_S)
#: where the afternoon's robot 4 sees its person: the morning's p5, no afternoon place near
GONE = AM[5][:2]


def _shifts(folder: Path, pm_part: dict[int, tuple[float, float, float]] = PM_PART
            ) -> list[Path]:
    """The four robots' logs (module docstring); ``pm_part``: robot 4's graph."""
    return [
        write_robot(folder / "am1.mcap", AM, AM[5][:2], track=1, seconds=MORNING),
        write_robot(folder / "am2.mcap", AM_PART, AM[4][:2], track=2, offset_s=30,
                    seconds=MORNING),
        write_robot(folder / "pm1.mcap", PM, PM[4][:2], track=3, seconds=AFTERNOON),
        write_robot(folder / "pm2.mcap", pm_part, GONE, track=4, offset_s=30,
                    seconds=AFTERNOON),
    ]


def _one_log_per_shift(folder: Path) -> list[Path]:
    """The same people and each shift's whole session graph, at the same times, in one log
    per shift: one stream, the afternoon's graph replacing the morning's."""
    return [
        write_robot(folder / "am.mcap", AM, AM[5][:2], track=1, others={2: AM[4][:2]},
                    offsets=(30,), seconds=MORNING),
        write_robot(folder / "pm.mcap", PM, PM[4][:2], track=3, others={4: GONE},
                    offsets=(30,), seconds=AFTERNOON),
    ]


def test_shifts_of_two_sessions_build_one_after_the_other(tmp_path: Path) -> None:
    """Before: refused (the afternoon's session is not the morning's). Now the map's graph
    is the afternoon's session's (p0..p4 where it has them: not the morning's p5 and p6),
    robot 4's person is on a hash cell (before the union kept the morning's p5 there and
    owned it), and the map equals the one-stream logs' entry for entry."""
    out = tmp_path / "fleet.aion"
    report = build_map(BuildOptions(logs=tuple(_shifts(tmp_path)), output=out, workers=1))
    assert report.graph_source == "log"
    assert report.detections_used == 2 * DURATION_S
    graph = load_map(out).state.graph
    assert graph is not None
    ids = np.asarray(graph.places.ids)
    assert sorted(ids.tolist()) == [sym("p", k) for k in sorted(PM)]
    np.testing.assert_allclose(np.asarray(graph.places.xyz)[np.argsort(ids)],
                               [PM[k] for k in sorted(PM)])
    got = live_entries(out)
    held = got["counts"].sum(axis=1) > 0
    gone = held & (np.linalg.norm(got["xyz"][:, :2] - GONE, axis=1) < 0.5)
    assert got["node_id"][gone].tolist() == [0]  # a hash cell, no place of the afternoon's
    reference = tmp_path / "shifts.aion"
    build_map(BuildOptions(logs=tuple(_one_log_per_shift(tmp_path)), output=reference,
                           workers=1))
    want = live_entries(reference)
    for name in want:
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)


def test_the_shifts_build_is_the_merge_of_each_shifts_map(tmp_path: Path) -> None:
    """``aion merge`` of each shift's own map (two sessions: the morning's flows released
    and bound to the afternoon's places within reach) holds the one build's entries."""
    from aion_cli.merging import merge_map_files

    logs = _shifts(tmp_path)
    build_map(BuildOptions(logs=tuple(logs), output=tmp_path / "fleet.aion", workers=1))
    for name, shift in (("am", logs[:2]), ("pm", logs[2:])):
        build_map(BuildOptions(logs=tuple(shift), output=tmp_path / f"{name}.aion", workers=1))
    merged = merge_map_files([tmp_path / "am.aion", tmp_path / "pm.aion"],
                             tmp_path / "merged.aion")
    assert merged.lineage == "different"
    got, want = live_entries(tmp_path / "fleet.aion"), live_entries(tmp_path / "merged.aion")
    mine, theirs = (e["counts"].sum(axis=1) > 0 for e in (got, want))  # (empty nodes apart)
    for name in want:
        np.testing.assert_allclose(got[name][mine], want[name][theirs], rtol=0, atol=1e-9,
                                   err_msg=name)


def test_a_parallel_build_of_the_shifts_is_the_one_pass(tmp_path: Path) -> None:
    """``--workers 2``: the shifts are kept in sequence (the afternoon's first graph lacks
    the morning's places), and the map is the one pass's."""
    logs = tuple(_shifts(tmp_path))
    build_map(BuildOptions(logs=logs, output=tmp_path / "one.aion", workers=1))
    build_map(BuildOptions(logs=logs, output=tmp_path / "two.aion", workers=2))
    assert_same_map(tmp_path / "one.aion", tmp_path / "two.aion")


def test_a_shift_of_two_sessions_is_refused_by_its_logs(tmp_path: Path) -> None:
    """Robot 4 logging the morning's session's graph beside robot 3's of another session:
    the afternoon's robots are refused with the clear error, which names them, not the
    morning's robots (whose session is one)."""
    logs = _shifts(tmp_path, pm_part=AM)
    with pytest.raises(InputError) as exc:
        build_map(BuildOptions(logs=tuple(logs), output=tmp_path / "m.aion", workers=1))
    assert f"2 logs carry scene graphs on {TOPIC} at the same time" in exc.value.message
    assert f"({logs[2]}, {logs[3]})" in exc.value.message
    assert str(logs[0]) not in exc.value.message
    assert not (tmp_path / "m.aion").exists()


def test_the_refusals_hint_builds_every_log(tmp_path: Path) -> None:
    """The hint names the build's other logs too (the morning's robots, which the refusal
    does not name): before, following it built the afternoon's robots only. Its route, each
    command as given, holds every detection of the four logs."""
    from aion_cli.merging import merge_map_files

    logs = _shifts(tmp_path, pm_part=AM)
    with pytest.raises(InputError) as exc:
        build_map(BuildOptions(logs=tuple(logs), output=tmp_path / "m.aion", workers=1))
    hint = exc.value.hint or ""
    steps = [
        ((logs[2],), "pm1.aion"), ((logs[3],), "pm2.aion"), (tuple(logs[:2]), "other-logs.aion")
    ]
    for step_logs, name in steps:
        assert f"aion build {' '.join(map(str, step_logs))} -o {name}" in hint
        build_map(BuildOptions(logs=step_logs, output=tmp_path / name, workers=1))
    assert "aion merge pm1.aion pm2.aion other-logs.aion -o fleet.aion" in hint
    merge_map_files([tmp_path / name for _, name in steps], tmp_path / "fleet.aion")
    got = live_entries(tmp_path / "fleet.aion")
    assert got["counts"].sum() == 2 * DURATION_S


def _graph(t: int, ids: list[int], x: float) -> GraphSnapshot:
    layer = Layer(np.array(ids, np.uint64), np.full((len(ids), 3), x), np.zeros(len(ids),
                  np.uint64))
    return GraphSnapshot(t, layer, np.zeros((0, 2), np.int64))


def test_a_later_groups_graph_drops_the_earlier_groups() -> None:
    """Recordings 0 and 1 at once, then 2 and 3 at once: within a group the map's graph is
    the union of its recordings' latest graphs; a later group's first graph is that graph
    alone (not joined with the earlier group's places, nor with its positions)."""
    sessions = SessionGraphs({0: 0, 1: 0, 2: 1, 3: 1})
    sessions.join(0, _graph(1, [10, 11, 12], 0.0))
    morning = sessions.join(1, _graph(2, [10, 13], 0.0))
    assert sorted(np.asarray(morning.places.ids).tolist()) == [10, 11, 12, 13]
    first = sessions.join(2, _graph(3, [10, 11], 5.0))
    assert np.asarray(first.places.ids).tolist() == [10, 11]
    np.testing.assert_array_equal(first.places.xyz, np.full((2, 3), 5.0))
    afternoon = sessions.join(3, _graph(4, [14], 5.0))
    assert sorted(np.asarray(afternoon.places.ids).tolist()) == [10, 11, 14]


def _components(spans: dict[int, tuple[int, int]]) -> list[set[int]]:
    """Spans joined when each starts before the other ends, pair by pair (the brute-force
    answer), as sets of keys."""
    groups = [{key} for key in spans]
    for a in spans:
        for b in spans:
            (lo_a, hi_a), (lo_b, hi_b) = spans[a], spans[b]
            if a != b and lo_a < hi_b and lo_b < hi_a:
                ga = next(g for g in groups if a in g)
                gb = next(g for g in groups if b in g)
                if ga is not gb:
                    groups.remove(gb)
                    ga |= gb
    return groups


def test_overlap_groups_are_the_pairwise_overlaps_joined() -> None:
    """Random spans: the groups are those of joining every pair that overlaps, numbered in
    time order; ``overlapping`` is the keys of the groups of more than one."""
    rng = random.Random(69)
    for _ in range(300):
        spans = {}
        for key in rng.sample(range(100), rng.randint(0, 8)):
            lo = rng.randint(0, 40)
            spans[key] = (lo, lo + rng.randint(0, 12))
        groups = overlap_groups(spans)
        want = _components(spans)
        got: dict[int, set[int]] = {}
        for key, group in groups.items():
            got.setdefault(group, set()).add(key)
        assert sorted(map(sorted, got.values())) == sorted(map(sorted, want))
        starts = [min(spans[k][0] for k in got[g]) for g in sorted(got)]
        assert starts == sorted(starts)
        assert overlapping(spans) == sorted(k for g in want if len(g) > 1 for k in g)
