"""Issue 15, stop 64: the per-window work between two scene graphs.

* A bind check that sees the stable nodes and the cells of one that planned nothing answers
  None from the node table's memo (:class:`aion_cli.engine.nodes.QuietCheck`) without looking
  at a node or a cell. Builds with and without the memo give byte-identical states (random
  graphs that repeat, move, add and drop places, detections near and far, times that make
  nodes stable between checks); the memo is used, forgotten when the stable set, the cells,
  the timers or the table change, and a check it does not cover answers as the plain check.
* A repeated scene graph's payload is compared as bytes block by block
  (``graph_feed._same_bytes``) and its snapshot restamped (``GraphSnapshot.restamped``):
  the same answers as the numpy comparison and ``dataclasses.replace``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.engine import nodes as nodes_module
from aion_cli.engine import ownership
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.node_drift import approximate_timers
from aion_cli.engine.rebind import bind_to_graph
from aion_cli.engine.state import MapState
from aion_cli.graph_feed import _same_bytes
from tests.engine.engine_builders import T0, S, detections, graph

CFG = ModelConfig(window_s=600.0, cell_size=0.5, stability_s=300.0, bind_radius=1.0)
P = (CFG.bind_radius, CFG.bind_vertical_tolerance)
PLACES = np.array([[0.0, 0.0, 0.0], [6.0, 0.0, 0.0], [0.0, 6.0, 0.0], [6.0, 6.0, 0.0]])


def _state_bytes(state: MapState) -> dict[str, bytes]:
    """Every array of a state's map members as bytes (what a map file stores)."""
    arrays, _ = state.to_arrays()
    return {k: np.asarray(v).tobytes() for k, v in sorted(arrays.items())}


step = st.tuples(
    st.sampled_from(["near", "far", "same", "move", "add", "drop", "advance"]),
    st.integers(0, 2**31 - 1),
)


def _build(steps: list[tuple[str, int]], quiet: bool) -> tuple[MapState, int]:
    """:func:`_feed`; with ``quiet`` False the memo never answers (the checks before
    it). Returns the state and how many checks the memo answered."""
    answered = [0]
    real = nodes_module.QuietCheck.covers

    def covers(self: Any, *args: Any) -> bool:
        hit = quiet and real(self, *args)
        answered[0] += hit
        return hit

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(nodes_module.QuietCheck, "covers", covers)
        state = _feed(steps)
    return state, answered[0]


def _feed(steps: list[tuple[str, int]]) -> MapState:
    """The Mapper's state after ``steps`` (one every 1-700 s)."""
    m = Mapper(CFG)
    present = [0, 1, 2]
    xyz = PLACES.copy()
    t = T0
    snap = graph(t, present, xyz[present])
    m.add_graph(snap)
    for kind, seed in steps:
        rng = np.random.default_rng(seed)
        t += int(rng.integers(1, 700)) * S
        if kind in ("near", "far"):
            n = int(rng.integers(1, 6))
            around = xyz[rng.choice(present, n)] if kind == "near" else rng.uniform(-9, 15, (n, 3))
            pts = around + np.c_[rng.uniform(-0.9, 0.9, (n, 2)), np.zeros(n)]
            pts[:, 2] = 0.0
            m.add_detections(detections(t + np.arange(n) * S, pts, rng.uniform(-3, 3, n),
                                        rng.uniform(0.5, 1.5, n)))
        elif kind == "same":  # the same place layer again (a static map's repeated graph)
            snap = snap.restamped(t)
            m.add_graph(snap)
        elif kind in ("move", "add", "drop"):
            if kind == "move":
                xyz[present] += rng.uniform(-0.002, 0.002, (len(present), 3)) * (seed % 3)
                if seed % 7 == 0:
                    xyz[present[0]] += 2.0  # beyond the tolerance: its timer restarts
            elif kind == "add" and len(present) < len(PLACES):
                present = sorted({*present, int(rng.integers(0, len(PLACES)))})
            elif kind == "drop" and len(present) > 1:
                gone = present[int(rng.integers(len(present)))]
                present = [p for p in present if p != gone]
            snap = graph(t, present, xyz[present])
            m.add_graph(snap)
        else:
            m.advance(t)
    m.advance(t + 3 * 600 * S)
    return m.state


@given(st.lists(step, min_size=1, max_size=30))
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_builds_with_and_without_the_quiet_memo_are_byte_identical(
    steps: list[tuple[str, int]],
) -> None:
    memo, _used = _build(steps, True)
    plain, answered = _build(steps, False)
    assert answered == 0
    assert _state_bytes(memo) == _state_bytes(plain)


def test_the_random_builds_use_the_memo() -> None:
    """The steps above reach the memo: a run of windows with detections far from the
    places, repeated graphs and checks after the places are stable."""
    steps = [("far", 1), ("same", 2), ("far", 3), ("same", 4), ("far", 5), ("same", 6)] * 4
    memo, used = _build(steps, True)
    plain, _ = _build(steps, False)
    assert used > 0
    assert _state_bytes(memo) == _state_bytes(plain)


def test_the_memo_answers_repeated_checks_and_forgets_what_changes() -> None:
    m = Mapper(CFG)
    m.add_graph(graph(T0, [0, 1], PLACES[:2]))
    m.add_detections(detections(T0 + 10 * S, [[3.0, 3.0, 0.0]]))  # far from both places
    m.add_graph(graph(T0 + 100 * S, [0, 1], PLACES[:2]))  # nothing stable yet
    nodes = m.state.nodes
    quiet = nodes.quiet
    assert quiet is not None
    assert quiet.cells_version is None
    assert (quiet.start_ns, quiet.end_ns) == (np.iinfo(np.int64).min, T0 + 300 * S)
    # stable from T0 + 300 s on: a check then sees nodes and the cell, and binds none
    assert ownership.plan_binds(m.state, T0 + 300 * S) is None
    quiet = nodes.quiet
    assert quiet is not None
    assert quiet.cells_version == m.state.entries.cells_version
    assert (quiet.start_ns, quiet.end_ns) == (T0 + 300 * S, np.iinfo(np.int64).max)
    assert quiet.covers(nodes.stable_since_ns, 300 * S, P, T0 + 900 * S,
                        m.state.entries.cells_version)
    assert not quiet.covers(nodes.stable_since_ns, 300 * S, P, T0 + 299 * S,
                            m.state.entries.cells_version)  # another stable set
    assert not quiet.covers(nodes.stable_since_ns.copy(), 300 * S, P, T0 + 900 * S,
                            m.state.entries.cells_version)  # other timers
    wider = (2.0, CFG.bind_vertical_tolerance)
    assert not quiet.covers(nodes.stable_since_ns, 300 * S, wider, T0 + 900 * S,
                            m.state.entries.cells_version)  # another radius
    # a new cell near a stable place: a new cells version, and the check binds it
    m.add_detections(detections(T0 + 400 * S, [[0.2, 0.1, 0.0]]))
    assert not quiet.covers(nodes.stable_since_ns, 300 * S, P, T0 + 900 * S,
                            m.state.entries.cells_version)
    plan = ownership.plan_binds(m.state, T0 + 400 * S)
    want = ownership.plan_binds_plain(m.state, T0 + 400 * S)
    assert plan is not None
    assert want is not None
    assert plan.cells.tolist() == want.cells.tolist()
    assert plan.node_ids.tolist() == want.node_ids.tolist()


def test_timers_changed_in_place_or_replaced_forget_the_memo() -> None:
    m = Mapper(CFG)
    m.add_graph(graph(T0, [0, 1], PLACES[:2]))
    m.add_detections(detections(T0 + 10 * S, [[3.0, 3.0, 0.0]]))
    m.advance(T0 + 400 * S)
    nodes = m.state.nodes
    assert nodes.quiet is not None
    earlier = dataclasses.replace(nodes, stable_since_ns=nodes.stable_since_ns - 10**6 * S)
    approximate_timers(nodes, earlier, 1.0)  # a shard's join: timers changed in place
    assert nodes.quiet is None
    # the table re-stamped by a merge onto a graph: a new timers array, seen as such
    ownership.plan_binds(m.state, T0 + 400 * S)
    assert m.state.nodes.quiet is not None
    before = m.state.nodes.quiet
    bind_to_graph(m.state, graph(T0 + 500 * S, [0, 1, 2], PLACES[:3]), T0 + 500 * S)
    assert m.state.nodes.quiet is not before


def test_a_repeated_graph_keeps_the_memo_on_its_copied_table() -> None:
    nodes = Mapper(CFG).state.nodes
    table, _ = nodes.updated(np.array([3, 1], np.uint64), PLACES[:2], T0, 0.05)
    stable = table.stable_mask(T0 + 400 * S, 300 * S)
    start, end = table.stable_span(stable, 300 * S)
    table.quiet = nodes_module.QuietCheck(table.stable_since_ns, 300 * S, P, start,
                                          end, 7)
    again, gone = table.updated(table.ids, table.xyz.copy(), T0 + 500 * S, 0.05)
    assert not gone.any()
    assert again is not table
    assert again.quiet is not None
    assert again.quiet.since is again.stable_since_ns  # the copy's own timers
    moved, _ = table.updated(table.ids, table.xyz + 0.01, T0 + 500 * S, 0.05)
    assert moved.quiet is None  # moved places: a new table, nothing remembered


@given(st.binary(min_size=0, max_size=300), st.integers(0, 299), st.integers(1, 64))
def test_same_bytes_answers_as_comparing_the_whole_payloads(
    data: bytes, where: int, block: int
) -> None:
    pad = b"xyz"
    a = memoryview(pad + data)[len(pad):]  # a view into a larger message, as payloads are
    assert _same_bytes(a, memoryview(bytes(data)), block)
    if data:
        changed = bytearray(data)
        changed[where % len(data)] ^= 0x41
        assert not _same_bytes(a, memoryview(bytes(changed)), block)
    assert not _same_bytes(a, memoryview(data + b"\x00"), block)
    as_words = np.frombuffer(bytes(data[: len(data) // 4 * 4]), np.uint32)
    assert _same_bytes(memoryview(as_words), memoryview(as_words.tobytes()), block)


def test_restamped_equals_replace() -> None:
    snap = graph(T0, [0, 1], PLACES[:2])
    again = snap.restamped(T0 + 5 * S)
    assert again == dataclasses.replace(snap, t_ns=T0 + 5 * S)
    assert again.t_ns == T0 + 5 * S
    assert snap.t_ns == T0
    assert again.places is snap.places
    assert again.edges is snap.edges
    assert type(again) is type(snap)
    with pytest.raises(dataclasses.FrozenInstanceError):
        again.t_ns = 0  # type: ignore[misc]


@given(
    st.integers(1, 6),
    st.integers(1, 12),
    st.integers(0, 2**31 - 1),
    st.sampled_from([0.5, 1.0, 1.5]),
)
def test_every_pair_answers_as_the_gathered_pairs(n: int, m: int, seed: int, radius: float
                                                  ) -> None:
    """On a half-metre grid (exact ties in distance, pairs exactly at the radius and the
    vertical tolerance), the broadcast comparison finds the nodes and least distances the
    gathered pairs do."""
    from aion_cli.engine.nearest import _closest, _closest_every_pair, all_pairs

    rng = np.random.default_rng(seed)
    points = rng.integers(-4, 5, (n, 3)) * 0.5
    nodes = rng.integers(-4, 5, (m, 3)) * 0.5
    hit, least = _closest_every_pair(points, nodes, radius, 0.5)
    p, j = all_pairs(n, m)
    want, d = _closest(points, nodes, p, j, radius, 0.5)
    assert hit.tolist() == want.tolist()
    assert hit.dtype == want.dtype
    assert least.tobytes() == d.reshape(n, m).min(axis=1).tobytes()
