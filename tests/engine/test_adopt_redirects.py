"""``adopt_redirects`` (``aion_cli/engine/merge.py``) where the entry moved is row 0.

When two maps are merged (``merge_maps``) or a shard is joined (``join_shard``), the earlier
map's redirects φ(cell) = node are kept for nodes that live in the result; a cell the later map
made at such a key (its node was not yet stable there) moves into the node, as one pass would
have routed those detections to the node all along. The rows that take part are the first ones
a map allocates, so row 0 is the common case, and a ``> 0`` where ``>= 0`` belongs (or a
``-1``/``0`` "no row" confusion) would lose or misplace exactly these entries. Two tiny logs
make each case, with counts worked out by hand, and a one-pass build of both logs is the
reference the merged and joined maps must equal.

Places become stable after 900 s (longer than a 600-s window), so the later log's first
detections reach the node only through the earlier map's redirect.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from aion_cli.engine.compare import differences
from aion_cli.engine.entries import CELL, FREE
from aion_cli.engine.join_blockers import join_blocker
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.merge import merge_maps
from aion_cli.engine.shards import join_shard, start_shard
from aion_cli.engine.spatial_hash import keys_for_points
from aion_cli.engine.state import MapState
from tests.engine.engine_builders import (
    T0,
    S,
    check_invariants,
    closed_counts,
    detections,
    graph,
    open_counts,
    pending_counts,
    pid,
)
from tests.engine.state_logs import CFG, DAY, W

CFG_SLOW = CFG.replace(stability_s=900.0)
HERE = [0.1, 0.1, 0.0]  # in p0's cell (p0 at the origin)
THERE = [3.1, 0.1, 0.0]  # in p1's cell (p1 at x = 3)


def _key(xyz: list[float]) -> int:
    return int(keys_for_points(np.array([xyz]), CFG_SLOW.cell_size)[0])


def _early(m: Mapper) -> None:
    """Day 1: one detection at HERE at T0 + 1 s, while p0 is not stable yet (a cell); the
    cell binds to p0 when the second window closes (1200 s > 900 s): φ(HERE) = p0."""
    m.set_fixed_sensor(T0, T0 + 2 * W)
    m.add_graph(graph(T0, [0], [[0.0, 0.0, 0.0]]))
    m.add_detections(detections(T0 + S, [HERE]))
    m.advance(T0 + 2 * W)


def _late_one_node(m: Mapper) -> None:
    """Day 2: p0 where it was; 2 detections at HERE in the first window (closed: pending day)
    and 3 in the second (open). Alone, p0 is not stable before 900 s: HERE becomes a cell,
    the map's first entry (row 0)."""
    t = T0 + DAY
    m.set_fixed_sensor(t, t + 2 * W)
    m.add_graph(graph(t, [0], [[0.0, 0.0, 0.0]]))
    m.add_detections(detections(t + S, [HERE] * 2))
    m.add_detections(detections(t + W + S, [HERE] * 3))
    m.advance(t + W + 2 * S)


def _late_two_nodes(m: Mapper) -> None:
    """Day 2: p0 first 20 m away, back at the origin at +300 s (its timer restarts there, in
    one pass too), p1 new at x = 3. One detection at THERE (a cell, row 0), two at HERE (a
    cell, row 1); at +1000 s p1 is stable and binds THERE (p1's entry is row 2, row 0 is
    freed) while p0 (stable from +1200 s) binds nothing."""
    t = T0 + DAY
    m.set_fixed_sensor(t, t + 2 * W)
    m.add_graph(graph(t, [0, 1], [[20.0, 0.0, 0.0], [3.0, 0.0, 0.0]]))
    m.add_detections(detections(t + S, [THERE]))
    m.add_detections(detections(t + 2 * S, [HERE] * 2))
    m.add_graph(graph(t + 300 * S, [0, 1], [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]]))
    m.advance(t + 1000 * S)


def _built(*logs: Callable[[Mapper], None], shard: bool = False) -> MapState:
    """The logs in order in one Mapper (with ``shard``: as a parallel build's shard)."""
    m = Mapper(CFG_SLOW, start_shard(MapState.empty(CFG_SLOW)) if shard else None)
    for log in logs:
        log(m)
    return m.state


def _node_total(state: MapState, index: int) -> float:
    row = int(state.node_entry_rows(pid([index]))[0])
    assert row >= 0
    return float(state.entries.counts[row].sum() + state.entries.nodir[row])


def test_the_setup_puts_the_cell_to_adopt_at_row_0() -> None:
    """What the other tests rely on: the earlier map redirects HERE to p0; the later map
    alone has HERE as a cell in row 0 (5 detections) and no redirect; one pass has no cell."""
    early = _built(_early)
    np.testing.assert_array_equal(early.redirects.keys, [_key(HERE)])
    np.testing.assert_array_equal(early.redirects.nodes, pid([0]))
    late = _built(_late_one_node)
    assert late.entries.kind[0] == CELL
    assert late.entries.key[0] == _key(HERE)
    assert late.entries.counts[0].sum() + late.entries.nodir[0] == 5
    assert len(late.redirects) == 0
    one = _built(_early, _late_one_node)
    assert one.entries.cell_rows().size == 0


def test_a_merge_moves_the_later_maps_row_0_cell_into_the_earlier_maps_node() -> None:
    """Merged (copying and consuming alike), the cell of row 0 is gone into p0: p0 holds all
    6 detections (1 absorbed with the earlier day, 2 in the pending day, 3 in the open
    window), φ(HERE) = p0 is kept, and the map equals the one-pass build of both logs."""
    one = _built(_early, _late_one_node)
    for consume in (False, True):
        early, late = _built(_early), _built(_late_one_node)
        assert late.entries.kind[0] == CELL  # the row adopted
        merged = merge_maps(late, early, consume=consume)
        check_invariants(merged)
        ent = merged.entries
        assert ent.cell_rows().size == 0, consume
        np.testing.assert_array_equal(ent.node_id[ent.node_rows()], pid([0]))
        row = int(merged.node_entry_rows(pid([0]))[0])
        assert _node_total(merged, 0) == 6
        assert closed_counts(merged, [row]).sum() == 1
        assert pending_counts(merged)[row].sum() == 2
        assert open_counts(merged)[row].sum() == 3
        np.testing.assert_array_equal(merged.pending.entries(), [row])
        np.testing.assert_array_equal(merged.redirects.keys, [_key(HERE)])
        np.testing.assert_array_equal(merged.redirects.nodes, pid([0]))
        assert merged.routes.lookup(np.array([_key(HERE)]))[0][0] == row
        assert differences(one, merged) == [], consume


def test_a_shard_join_moves_the_shards_row_0_cell_into_the_earlier_maps_node() -> None:
    """The same logs as a parallel build's shard: the join is exact (no blocker) and equals
    one pass, with the 6 detections in p0 and no cell left."""
    one = _built(_early, _late_one_node)
    acc, shard = _built(_early), _built(_late_one_node, shard=True)
    assert shard.entries.kind[0] == CELL
    assert join_blocker(acc, shard) is None
    joined = join_shard(acc, shard)
    check_invariants(joined)
    assert joined.entries.cell_rows().size == 0
    assert _node_total(joined, 0) == 6
    assert differences(one, joined) == []


def test_an_adopted_cell_moves_into_a_node_entry_created_at_row_0() -> None:
    """Row 0 as the destination: the later map freed row 0 when p1 bound THERE, so the
    earlier map's p0 gets its entry there (consuming merge and shard join; a copying merge
    renumbers the rows first), and the cell at HERE (row 1) moves into it. By hand: p0 holds
    1 + 2 = 3 detections, p1 1, no cell; φ = {HERE: p0, THERE: p1}; equal to one pass."""
    one = _built(_early, _late_two_nodes)
    cases = [
        ("merge", lambda: merge_maps(_built(_late_two_nodes), _built(_early), consume=True)),
        ("join", lambda: join_shard(_built(_early), _built(_late_two_nodes, shard=True))),
    ]
    late = _built(_late_two_nodes)
    assert late.entries.kind[0] == FREE
    assert late.entries.kind[1] == CELL
    assert late.entries.key[1] == _key(HERE)
    for name, make in cases:
        out = make()
        check_invariants(out)
        assert int(out.node_entry_rows(pid([0]))[0]) == 0, name
        assert out.entries.cell_rows().size == 0, name
        assert _node_total(out, 0) == 3, name
        assert _node_total(out, 1) == 1, name
        phi = dict(zip(out.redirects.keys.tolist(), out.redirects.nodes.tolist(), strict=True))
        assert phi == {_key(HERE): int(pid(0)), _key(THERE): int(pid(1))}, name
        assert out.routes.lookup(np.array([_key(HERE)]))[0][0] == 0, name
        assert differences(one, out) == [], name
