"""Time shards of logs with Hydra scene graphs: parts whose graph changes, pins another layer,
or holds only damaged graphs, and logs of different sessions kept together; every parallel
map is compared with the sequential build's (``tests/time_shard_logs.py``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.pipeline import BuildOptions
from tests.cli.logdata import T0, S
from tests.time_shard_logs import (
    build_logs,
    same_maps,
    second_part_in_sequence,
)


def _hydra_sessions(path: Path, graphs: list[object]) -> Path:
    """Sessions a day apart (20 minutes each, from Monday 08:00): people every 10 s (the
    office log's), a robot pose every 5 s, and a Hydra graph (``graphs``, one per session, or
    a list of them: the first for the session's first ten minutes, the second after) every
    60 s."""
    from aion_cli.formats.writers import LogWriter
    from tests.cli.logdata import _tracked_persons

    with LogWriter(path) as writer:
        for day, graph in enumerate(graphs):
            halves = graph if isinstance(graph, list) else [graph, graph]
            payloads = [
                np.frombuffer(g.to_binary(False), dtype=np.uint8)  # type: ignore[attr-defined]
                for g in halves
            ]
            start = T0 + day * 86_400 * S
            for k in range(1200):
                t = start + k * S
                payload = payloads[k >= 600]
                if k % 60 == 0:
                    stamp = {"sec": t // S, "nanosec": t % S}
                    writer.write("/hydra/backend/dsg", "hydra_msgs/msg/DsgUpdate",
                                 {"header": {"stamp": stamp, "frame_id": "map"},
                                  "layer_contents": payload, "full_update": True}, t)
                if k % 10 == 5:
                    writer.write("/tracks", "spencer_tracking_msgs/msg/TrackedPersons",
                                 _tracked_persons(t, start, "map"), t)
                if k % 5 == 0:  # the robot (so the first graph is not read for agents)
                    stamp = {"sec": t // S, "nanosec": t % S}
                    writer.write("/tf", "tf2_msgs/msg/TFMessage", {"transforms": [{
                        "header": {"stamp": stamp, "frame_id": "map"},
                        "child_frame_id": "base_link",
                        "transform": {"translation": {"x": 3.0}, "rotation": {"w": 1.0}},
                    }]}, t)
    return path


def test_a_part_whose_graphs_would_pin_another_layer_is_learnt_in_sequence(
    tmp_path: Path,
) -> None:
    # Monday's Hydra graphs hold 3D places only: one pass pins that layer for the rest of the
    # log, so Tuesday's graphs (3D and 2D places) are read by their 3D places too. A part
    # starting on Tuesday, alone, would choose the 2D places: the join sees the other layer,
    # and the part is learnt in sequence with the pinned one.
    from tests.formats.dsg_builders import hydra_graph

    log = _hydra_sessions(tmp_path / "log.mcap", [hydra_graph(False), hydra_graph(True)])
    one, two = second_part_in_sequence(tmp_path, log, "navigational layer")
    assert one.graph_layer == two.graph_layer == "PLACES (3)"


def _grown(graph: Any, place: int = 99) -> Any:
    """``graph`` with one more 3D place (as Hydra adds places while the robot explores)."""
    import spark_dsg as dsg

    attrs = dsg.PlaceNodeAttributes()
    attrs.position = np.array([2.0, -2.0, 1.0])
    attrs.distance = 0.5
    attrs.real_place = True
    graph.add_node(dsg.DsgLayers.PLACES, dsg.NodeSymbol("p", place), attrs)
    return graph


def test_a_log_whose_graph_changes_in_a_later_part_is_not_cut(tmp_path: Path) -> None:
    # Tuesday's Hydra graph gains a place halfway through the session: a part starting on
    # Tuesday, built apart, would bind cells as that graph changes after its first day,
    # which its join cannot replay (it would be learnt twice). The planner compares the
    # part's first and last graph, leaves the log whole and says why; the map is one pass's.
    from tests.formats.dsg_builders import hydra_graph

    tuesday = [hydra_graph(False), _grown(hydra_graph(False))]
    log = _hydra_sessions(tmp_path / "log.mcap", [hydra_graph(False), tuesday])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    build_logs([log], seq, 1)
    two = build_logs([log], par, 2)
    assert two.workers == []
    assert [n for n in two.notes if "not cut into time shards: its scene graph changes after" in n]
    assert not [n for n in two.notes if "no quiet moment" in n]
    assert same_maps(seq, par) == []
    # workers not asked for (the default): a log left whole is no news
    unasked = build_logs([log], tmp_path / "auto.aion", 0)  # one per core, as the CLI
    assert not [n for n in unasked.notes if "time shards" in n]


def test_a_log_whose_graph_stays_in_each_later_part_is_still_cut(tmp_path: Path) -> None:
    # The same log with Tuesday's graph the same all session (another than Monday's): the
    # later part's first and last graph agree, so the log is cut and the parts join.
    from tests.formats.dsg_builders import hydra_graph

    log = _hydra_sessions(tmp_path / "log.mcap", [hydra_graph(False), _grown(hydra_graph(False))])
    two = build_logs([log], tmp_path / "par.aion", 2)
    assert len(two.workers) == 2
    assert not [n for n in two.notes if "not cut" in n]


def test_places_changed_compares_ids_and_moves_beyond_the_tolerance() -> None:
    from aion_cli.engine.types import GraphSnapshot, Layer
    from aion_cli.shard_graphs import places_changed

    def snap(ids: list[int], xyz: list[tuple[float, float, float]]) -> GraphSnapshot:
        layer = Layer(np.array(ids, np.uint64), np.array(xyz, float), np.zeros(len(ids), np.uint64))
        return GraphSnapshot(0, layer, np.zeros((0, 2), np.int64))

    a = snap([1, 2, 3], [(0, 0, 0), (1, 0, 0), (2, 0, 0)])
    shuffled = snap([3, 1, 2], [(2, 0, 0), (0, 0, 0), (1, 0, 0)])
    drifted = snap([1, 2, 3], [(0, 0.2, 0), (1, 0, 0), (2, 0, 0)])
    moved = snap([1, 2, 3], [(0, 0.3, 0), (1, 0, 0), (2, 0, 0)])
    grown = snap([1, 2, 3, 4], [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)])
    assert not places_changed(a, shuffled, 0.25)
    assert not places_changed(a, drifted, 0.25)
    assert places_changed(a, moved, 0.25)
    assert places_changed(a, grown, 0.25)
    assert places_changed(grown, a, 0.25)


def test_places_lost_counts_places_gone_or_moved_not_added() -> None:
    """Between two logs, a graph that grew keeps the join (its places are all still there);
    one that lacks a place, or moved one beyond the tolerance, does not."""
    from aion_cli.engine.types import GraphSnapshot, Layer
    from aion_cli.shard_graphs import places_lost

    def snap(ids: list[int], xyz: list[tuple[float, float, float]]) -> GraphSnapshot:
        where = np.array(xyz, float).reshape(-1, 3)
        layer = Layer(np.array(ids, np.uint64), where, np.zeros(len(ids), np.uint64))
        return GraphSnapshot(0, layer, np.zeros((0, 2), np.int64))

    a = snap([1, 2, 3], [(0, 0, 0), (1, 0, 0), (2, 0, 0)])
    grown = snap([4, 3, 1, 2], [(3, 0, 0), (2, 0, 0), (0, 0.2, 0), (1, 0, 0)])
    lacking = snap([1, 3], [(0, 0, 0), (2, 0, 0)])
    moved = snap([1, 2, 3], [(0, 0, 0), (1, 0.3, 0), (2, 0, 0)])
    other = snap([7, 8, 9], [(0, 0, 0), (1, 0, 0), (2, 0, 0)])
    empty = snap([], [])
    assert not places_lost(a, grown, 0.25)
    assert places_lost(grown, a, 0.25)
    assert places_lost(a, lacking, 0.25)
    assert places_lost(a, moved, 0.25)
    assert places_lost(a, other, 0.25)
    assert places_lost(a, empty, 0.25)
    assert not places_lost(empty, a, 0.25)



class _Damaged:
    """A graph whose payload no spark_dsg version decodes."""

    def to_binary(self, _: bool) -> bytes:
        return b"\x07not a scene graph" * 8


def test_damaged_graphs_in_one_part_are_skipped_as_in_one_pass(tmp_path: Path) -> None:
    # Tuesday's graphs are all damaged: one pass skips them (a note) and keeps Monday's graph;
    # the part that holds them alone must not stop the build for having decoded none, and
    # the counts are the whole log's
    from tests.formats.dsg_builders import hydra_graph

    log = _hydra_sessions(tmp_path / "log.mcap", [hydra_graph(False), _Damaged()])
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    one = build_logs([log], seq, 1)
    two = build_logs([log], par, 2)
    assert len(two.workers) == 2
    assert (two.graph_messages, two.graph_skipped) == (one.graph_messages, one.graph_skipped)
    assert one.graph_skipped == 20
    counts = [n for n in two.notes if n.startswith("scene graphs: ")]
    assert counts == [n for n in one.notes if n.startswith("scene graphs: ")]
    assert counts[0].startswith("scene graphs: 20 of 40 applied")
    assert same_maps(seq, par) == []


def test_a_log_whose_graphs_all_fail_stops_with_workers_too(tmp_path: Path) -> None:
    from aion_cli.errors import MessageDecodeError

    log = _hydra_sessions(tmp_path / "log.mcap", [_Damaged(), _Damaged()])
    for workers in (1, 2):
        with pytest.raises(MessageDecodeError):
            build_logs([log], tmp_path / "m.aion", workers)
        assert not (tmp_path / "m.aion").exists()



def test_graph_breaks_between_logs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Between two logs (each one Hydra session): a later log whose first graph lacks a
    place of the earlier log's last is a break; one that grew, or repeats it, is not (a
    repeated payload is not even decoded); one whose graphs do not decode cannot tell (no
    break: the join decides)."""
    import aion_cli.shard_graphs as shard_graphs
    from aion_cli.shard_graphs import graph_breaks
    from tests.formats.dsg_builders import hydra_graph

    def log(name: str, graph: object) -> Path:
        return _hydra_sessions(tmp_path / f"{name}.mcap", [graph])

    plain = log("plain", hydra_graph(False))
    again = log("again", hydra_graph(False))
    grown = log("grown", _grown(hydra_graph(False)))
    damaged = log("damaged", _Damaged())
    opts = BuildOptions(logs=(plain,), output=tmp_path / "x.aion")

    def breaks(*logs: Path) -> list[bool]:
        return graph_breaks([(p,) for p in logs], opts, 0.25)

    decoded: list[object] = []

    def counting(real: Any) -> Any:
        def count(*args: Any) -> Any:
            decoded.append(args)
            return real(*args)

        return count

    # the last graph of a group, and the first its build applies
    for name in ("_decoded", "_first_graph"):
        monkeypatch.setattr(shard_graphs, name, counting(getattr(shard_graphs, name)))
    assert breaks(plain, again) == [False]
    assert decoded == []  # the same payload bytes: no decoding
    assert breaks(plain, again, grown) == [False, False]
    assert len(decoded) == 2  # the grown graph's payload differs: both ends decoded
    assert breaks(grown, plain) == [True]  # the grown graph's extra place is gone
    assert breaks(plain, damaged, plain) == [False, False]
    assert breaks(plain) == []


def test_groups_kept_together_are_not_cut_nor_their_times_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A group the planner kept together across sessions stays one shard: its times are not
    read (nothing to cut); the other groups are planned as before."""
    import aion_cli.time_shards as time_shards

    read: list[object] = []

    def times(group: Any, *_: Any) -> None:
        read.append(group)

    monkeypatch.setattr(time_shards, "group_times", times)
    a, b = (Path("a.mcap"),), (Path("b.mcap"),)
    opts = BuildOptions(logs=(a[0],), output=tmp_path / "x.aion")
    shards, notes = time_shards.split_groups([a], opts, 600 * S, 2, 0.25, frozenset({0}))
    assert (shards, notes, read) == ([(a, None, True)], [], [])
    shards, notes = time_shards.split_groups([a, b], opts, 600 * S, 4, 0.25, frozenset({1}))
    assert read == [a]  # only the other group's times (none found here: not cut)
    assert shards == [(a, None, True), (b, None, True)]


def test_graph_breaks_between_logs_from_the_first_graph_used(tmp_path: Path) -> None:
    """The later log's first graph is the first its build uses: a stray graph message (two
    days before the log, which the build drops) holding the earlier log's places hid that
    the log's own graphs moved one of them 5 m (they were compared with the stray: no break;
    the logs went to two workers, whose join refuses). Now the first kept graph decides: a
    break, as for the same log without the stray."""
    from aion_cli.shard_graphs import graph_breaks
    from tests.cli.logdata import PLACES, graph_payload, write_office_log

    x, y, z = PLACES[6]
    fewer = {**PLACES, 6: (x + 5.0, y, z)}  # place 6 moved: the earlier log's is lost
    full, own, stray = tmp_path / "full.mcap", tmp_path / "own.mcap", tmp_path / "stray.mcap"
    write_office_log(full, "mcap")
    write_office_log(own, "mcap", places=fewer, shift_s=3600)
    write_office_log(
        stray, "mcap", places=fewer, shift_s=3600, early_graph=(2 * 86_400, graph_payload(PLACES))
    )
    opts = BuildOptions(logs=(full,), output=tmp_path / "x.aion")
    assert graph_breaks([(full,), (own,)], opts, 0.25) == [True]
    assert graph_breaks([(full,), (stray,)], opts, 0.25) == [True]
