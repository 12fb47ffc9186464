"""``aion merge``'s fold of maps with nodes is built in the earlier map's storage
(:mod:`aion_cli.engine.merge_rows`): each step costs the map added and the earlier entries
it touches, not the result so far. The result must be the pairwise fold's (built in the
later map, copying the result so far at every step), for the maps of one scene-graph
session whose places lie in areas of their own (``--lineage same``: the earlier maps' nodes,
gone from each later graph, are released to cells) and for maps of a session's growing
graph (a later graph holds the earlier places, one moved by a loop closure, and a new place
next to an earlier map's cells, which bind to it)."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.entries import NODE
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.merge_rows import touched_rows
from aion_cli.engine.state import MapState
from tests.engine.engine_builders import T0, S, detections, graph
from tests.engine.state_logs import CFG, DAY, W, fold_in_earlier_map

HOUR = 3600 * S
#: the places of an area (ids 5k .. 5k + 4 in area k)
PLACES = np.array([[0, 0, 0], [3, 0, 0], [0, 3, 0], [3, 3, 0], [6, 6, 0.0]])
#: members that are sums of one value per map (or min/max): the same to the bit. The
#: day-ahead scores of a day scored during the fold are not: a day is scored over the
#: entries in row order, and the rows of the result differ (within compare's tolerance)
_EXACT = (
    "entry_key", "entry_kind", "entry_node_id", "entry_xyz", "entry_counts", "entry_nodir",
    "entry_window_counts", "entry_speed_n", "entry_speed_sum", "entry_heading_cos",
    "entry_heading_sin", "temporal_glob_n", "temporal_glob_profile", "temporal_obs_n",
    "temporal_obs_profile", "temporal_obs_first", "temporal_obs_last", "temporal_cnt_profile",
    "temporal_cnt_fourier", "pending_windows", "pending_fixed", "pending_obs_entry",
    "pending_cnt_entry", "pending_cnt_slot", "pending_cnt_values",
)


def _shift(area: int) -> np.ndarray:
    """Where area ``area`` lies: 40 m along x per area."""
    return np.array([40.0 * area, 0.0, 0.0])


def _session_graph(k: int, kind: str, t_ns: int) -> tuple[list[int], np.ndarray]:
    """Place ids and positions of map ``k``'s graph: area ``k``'s places alone (``areas``),
    or those of areas ``0 .. k`` (``session``: area 0's p1 moved 0.3 m by a loop closure
    from map 2 on, and from map 1 on a place p99 at (4.6, 4.9, 0), beside cells of map 0)."""
    areas = [k] if kind == "areas" else list(range(k + 1))
    ids = [5 * a + i for a in areas for i in range(5)]
    xyz = np.concatenate([PLACES + _shift(a) for a in areas])
    if kind == "session" and k >= 1:
        ids.append(99)
        xyz = np.vstack([xyz, [4.6, 4.9, 0.0]])
    if kind == "session" and k >= 2:
        xyz[1, 0] += 0.3
    return ids, xyz


def _map(k: int, kind: str, windows: int) -> MapState:
    """Map ``k``: a fixed sensor from 20:00 on day 2k for ``windows`` windows (over midnight:
    a scored day and a pending one) with its graph (:func:`_session_graph`), people at its
    area's places and between them (cells), and in area 0's corner (a cell every map holds),
    the last window left open."""
    rng = np.random.default_rng(k)
    start = T0 + 2 * k * DAY + 20 * HOUR
    m = Mapper(CFG)
    m.set_fixed_sensor(start, start + windows * W)
    ids, xyz = _session_graph(k, kind, start)
    m.add_graph(graph(start, ids, xyz))
    area = PLACES + _shift(k)
    between = area[:4] + np.array([1.6, 1.5, 0])
    spots = np.vstack([area, between, [[5.2, 4.6, 0], [-4.0, -4.0, 0]]])
    for w in range(windows):
        n = int(rng.integers(3, 30))
        t = start + w * W + np.sort(rng.integers(0, W, n))
        heading = np.where(rng.random(n) < 0.1, np.nan, rng.uniform(-np.pi, np.pi, n))
        where = spots[rng.integers(0, len(spots), n)]
        m.add_detections(detections(t, where, heading, rng.uniform(0.2, 2, n)))
    m.advance(start + windows * W - S)  # the last window stays open
    return m.state


#: the fixed-sensor windows of each map: a large first map, then smaller and larger ones
WINDOWS = (40, 30, 24, 50, 20)


def _maps(kind: str) -> list[MapState]:
    return [_map(k, kind, w) for k, w in enumerate(WINDOWS)]


@pytest.mark.parametrize("kind", ["areas", "session"])
def test_the_fold_in_the_earlier_map_is_the_pairwise_fold(kind: str) -> None:
    fold = fold_in_earlier_map(lambda: _maps(kind), _EXACT)
    # every detection counted once, every entry observed over every map's fixed windows
    # but the last map's last (still open)
    inputs = _maps(kind)
    assert fold.accepted == sum(s.accepted for s in inputs)
    assert fold.entries.total_count() == sum(s.entries.total_count() for s in inputs)
    rows = fold.entries.live_rows()
    np.testing.assert_array_equal(fold.windows_observed(rows), np.full(rows.size, 163))
    # the places: the node entries are the last graph's places that hold anything (the
    # earlier areas' places are gone from it in "areas": released to their cells)
    nodes = fold.entries.node_id[fold.entries.node_rows()]
    assert fold.graph is not None
    assert set(nodes.tolist()) <= set(fold.graph.places.ids.tolist())
    np.testing.assert_array_equal(fold.nodes.ids, inputs[-1].nodes.ids)
    assert fold.open_window == inputs[-1].open_window


def test_untouched_rows_are_cells_the_later_map_cannot_reach() -> None:
    """Of an earlier map, the merge copies only what the later map cannot change: cells at
    keys it does not route, away from its places and from the earlier nodes it releases."""
    early, late = _map(0, "session", 20), _map(1, "session", 10)
    touched = touched_rows(early, late)
    e = early.entries
    cells = np.flatnonzero(e.kind[: e.n] == 0)
    assert touched[e.kind[: e.n] == NODE].all()
    late.rebuild_routes()
    _, routed = late.routes.lookup(e.key[cells])
    assert touched[cells[routed]].all()  # the corner cell both maps hold
    near = np.hypot(*(e.xyz[cells, :2] - [4.6, 4.9]).T) <= CFG.bind_radius
    assert near.any()
    assert touched[cells[near]].all()  # beside the later graph's new place p99
    assert not touched[cells[~routed & ~near]].all()  # and some are left alone
