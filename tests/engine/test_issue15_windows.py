"""Issue 15, per-window costs: the memoised bind check, the open-window row flags and the
block evaluation of a day's per-window sums give exactly what the plain versions give.

Each fast path is compared with a plain reference on random inputs (hypothesis), and whole
builds (detections, graph updates that move and remove nodes, day closes, fixed sensor and
robot coverage) are compared member by member, bit for bit, with builds that use the plain
bind check (``plan_binds_plain``: a new KD-tree queried by every cell) and the pair-by-pair
per-window sums (a verbatim copy of the pre-issue-15 code, below).
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.engine import closing, ownership
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import FREE, EntryStore
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.nodes import BindIndex, nearest_nodes
from aion_cli.engine.temporal import scoring
from aion_cli.engine.types import Trajectory
from tests.engine.engine_builders import T0_DAY_END, S, detections, graph

# -- the bind-check memo --------------------------------------------------------------------


def _points(rng: np.random.Generator, n: int) -> np.ndarray:
    """Cell-like points on two floors around a few nodes (some in reach, most not)."""
    return np.c_[rng.uniform(-4, 4, (n, 2)), rng.choice([0.0, 0.2, 3.0], n)]


def _by_row(rows: np.ndarray, keys: np.ndarray, pts: np.ndarray, seed: int = 0
            ) -> tuple[np.ndarray, np.ndarray]:
    """Per-row key and position arrays holding the cells at ``rows`` (other rows: filler
    an entry store could hold, a node's -1 key and any position)."""
    rng = np.random.default_rng(seed)
    size = int(rows.max(initial=-1)) + 1 + int(rng.integers(0, 4))
    key = np.full(size, -1, np.int64)
    xyz = _points(rng, size)
    key[rows], xyz[rows] = keys, pts
    return key, xyz


def radius_of(s: int) -> float:
    return 1.0 if s % 5 else 2.0


step = st.tuples(
    st.sampled_from(["add", "drop", "reuse", "nodes", "same", "move", "shift", "jitter"]),
    st.integers(0, 2**31 - 1),
)


@given(st.integers(0, 2**31 - 1), st.lists(step, min_size=1, max_size=25))
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_bind_index_answers_equal_nearest_nodes(seed: int, steps: list[tuple[str, int]]) -> None:
    """Any sequence of checks: cells added (new rows), dropped, rows reused by other cells,
    cells moved in place, node sets changed or repeated: every answer equals a fresh
    ``nearest_nodes`` over all cells, and cells seen unbound before are not queried again."""
    rng = np.random.default_rng(seed)
    index = BindIndex()
    nodes = _points(rng, 6)
    rows = np.arange(20, dtype=np.int64)
    keys = rows * 3 + 1
    pts = _points(rng, rows.size)
    next_key = int(keys.max()) + 1
    for kind, s in steps:
        r = np.random.default_rng(s)
        if kind == "add":
            k = int(r.integers(1, 30))
            rows = np.r_[rows, rows.max(initial=-1) + 1 + np.arange(k)]
            keys = np.r_[keys, next_key + np.arange(k)]
            pts = np.r_[pts, _points(r, k)]
            next_key += k
        elif kind == "drop" and rows.size:
            keep = r.random(rows.size) < 0.7
            rows, keys, pts = rows[keep], keys[keep], pts[keep]
        elif kind == "reuse" and rows.size:  # a freed row now holds another cell
            i = int(r.integers(rows.size))
            keys[i], pts[i] = next_key, _points(r, 1)[0]
            next_key += 1
        elif kind == "move" and rows.size:  # same key and row, another position
            i = int(r.integers(rows.size))
            pts[i] = _points(r, 1)[0]
        elif kind == "nodes":
            nodes = _points(r, int(r.integers(0, 12)))
        elif kind == "shift":  # a live graph: some nodes move a little, leave or appear
            nodes = nodes[r.random(len(nodes)) < 0.8].copy()
            moved = r.random(len(nodes)) < 0.4
            nodes[moved, :2] += r.normal(0.0, 0.5, (int(moved.sum()), 2))
            nodes = np.r_[nodes, _points(r, int(r.integers(0, 3)))]
            nodes = nodes[r.permutation(len(nodes))]
        elif kind == "jitter":  # Hydra's optimisation: the same nodes moved by millimetres
            nodes = nodes.copy()
            nodes[:, :2] += r.uniform(-0.003, 0.003, (len(nodes), 2))
            if len(nodes) and rows.size and r.random() < 0.3:
                nodes[0, :2] = pts[0, :2] + [radius_of(s), 0.0]  # exactly at the bind radius
        radius, vtol = (radius_of(s), 1.0 if s % 5 else 0.5)
        order = r.permutation(rows.size)  # callers pass cells in any row order
        key_of_row, xyz_of_row = _by_row(rows, keys, pts, s)
        got = index.nearest(rows[order], key_of_row, xyz_of_row, nodes, radius, vtol)
        want = nearest_nodes(pts[order], nodes, radius, vtol)
        np.testing.assert_array_equal(got, want)
        if kind == "same" and len(nodes) and rows.size:
            before = index.queried
            again = index.nearest(rows[order], key_of_row, xyz_of_row, nodes, radius, vtol)
            np.testing.assert_array_equal(again, want)
            # a repeat asks only the cells that have a node in reach (they would bind)
            assert index.queried - before == int(np.count_nonzero(want >= 0))


def test_bind_index_reuses_the_tree_and_queries_only_new_cells() -> None:
    nodes = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    pts = np.array([[0.2, 0.0, 0.0], [5.0, 5.0, 0.0], [9.5, 0.0, 3.0]])
    rows, keys = np.array([4, 0, 7]), np.array([40, 41, 42])
    index = BindIndex()
    key, xyz = _by_row(rows, keys, pts)
    np.testing.assert_array_equal(index.nearest(rows, key, xyz, nodes, 1.0, 1.0), [0, -1, -1])
    assert index.queried == 3
    # same cells and nodes: only the cell that binds is asked again
    np.testing.assert_array_equal(index.nearest(rows, key, xyz, nodes, 1.0, 1.0), [0, -1, -1])
    assert index.queried == 4
    # the binding cell is gone; one new cell (row 9) near node 1
    rows2, keys2 = np.r_[rows[1:], 9], np.r_[keys[1:], 43]
    key2, xyz2 = _by_row(rows2, keys2, np.r_[pts[1:], [[10.0, 0.5, 0.0]]])
    np.testing.assert_array_equal(index.nearest(rows2, key2, xyz2, nodes, 1.0, 1.0), [-1, -1, 1])
    assert index.queried == 5
    # a node moves: every cell is asked again
    moved = nodes + np.array([[0.0, 0.0, 0.0], [-4.9, 5.0, 0.0]])
    np.testing.assert_array_equal(index.nearest(rows2, key2, xyz2, moved, 1.0, 1.0), [1, -1, -1])
    assert index.queried == 8


def test_nodes_moved_by_millimetres_ask_only_the_cells_near_reach() -> None:
    """A live graph's optimisation moves every node a little: a cell whose nearest node was
    farther than the radius by more than the nodes moved is not asked again; a cell that the
    move brings into reach is (and binds), as a fresh query says."""
    rng = np.random.default_rng(4)
    nodes = np.c_[rng.uniform(-20, 20, (50, 2)), np.zeros(50)]
    pts = np.c_[rng.uniform(-25, 25, (2000, 2)), np.zeros(2000)]
    pts[0, :2] = nodes[7, :2] + [1.0005, 0.0]  # just out of reach (radius 1 m)
    rows, keys = np.arange(2000), np.arange(2000) + 100
    key, xyz = _by_row(rows, keys, pts)
    index = BindIndex()
    first = index.nearest(rows, key, xyz, nodes, 1.0, 1.0)
    np.testing.assert_array_equal(first, nearest_nodes(pts, nodes, 1.0, 1.0))
    assert first[0] == -1
    asked = index.queried
    for step in range(5):
        nodes = nodes.copy()
        nodes[:, :2] += rng.uniform(-0.0002, 0.0002, nodes[:, :2].shape)
        if step == 3:
            nodes[7, 0] += 0.001  # now cell 0 is in reach
        got = index.nearest(rows, key, xyz, nodes, 1.0, 1.0)
        np.testing.assert_array_equal(got, nearest_nodes(pts, nodes, 1.0, 1.0))
        near = int(np.count_nonzero(first >= 0))
        assert index.queried - asked <= near + 5  # the bound cells and the ones at the edge
        asked = index.queried
    assert got[0] == 7


def test_a_bind_check_with_nothing_new_asks_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """A check that bound no cell is not redone while the cells and the stable nodes stay the
    same (EntryStore.cells_version): the memo is not even consulted; a new cell is looked
    at again."""
    calls = []
    nearest = BindIndex.nearest

    def counted(self: BindIndex, *args: Any) -> np.ndarray:
        calls.append(1)
        return nearest(self, *args)

    monkeypatch.setattr(BindIndex, "nearest", counted)
    cfg = ModelConfig(stability_s=0.0, cell_size=0.5, bind_radius=1.0)
    m = Mapper(cfg)
    t0 = T0_DAY_END - 3600 * S
    m.add_graph(graph(t0, [1], [[0.0, 0.0, 0.0]]))
    m.add_detections(detections(t0 + S, [[20.0, 20.0, 0.0]]))  # far from the node
    state = m.state
    assert ownership.plan_binds(state, t0 + 2 * S) is None
    index = state.nodes.bind_index
    assert index is not None
    asked, checks = index.queried, len(calls)
    assert ownership.plan_binds(state, t0 + 3 * S) is None
    assert len(calls) == checks  # nothing changed: no look-up at all
    m.add_detections(detections(t0 + 4 * S, [[0.3, 0.1, 0.0]]))  # a new cell near the node
    plan = ownership.plan_binds(state, t0 + 5 * S)
    assert plan is not None
    assert len(plan.cells) == 1
    assert len(calls) == checks + 1
    assert index.queried == asked + 1


# -- the open-window row flags --------------------------------------------------------------


@given(st.lists(st.tuples(st.sampled_from(["acc", "move", "delete", "alloc", "clear"]),
                          st.integers(0, 2**31 - 1)), min_size=1, max_size=30))
@settings(max_examples=150, deadline=None)
def test_window_rows_are_the_rows_with_open_window_counts(ops: list[tuple[str, int]]) -> None:
    """``window_rows`` equals the live rows whose open-window totals are positive, and
    ``clear_window`` zeroes every open-window count, after any sequence of accumulations,
    moves (bind/release), deletions, allocations (row reuse, growth) and clears."""
    store = EntryStore.empty(4, capacity=2)
    store.allocate(0, np.arange(3), np.zeros(3, np.uint64), np.zeros((3, 3)))
    for kind, s in ops:
        r = np.random.default_rng(s)
        live = store.live_rows()
        if kind == "acc" and live.size:
            n = int(r.integers(0, 40))
            rows = r.choice(live, n)
            bins = r.integers(-1, 4, n)
            store.accumulate(rows, bins, r.uniform(0, 2, n))
        elif kind == "move" and live.size >= 2:
            src = r.choice(live, int(r.integers(1, live.size)), replace=False)
            rest = np.setdiff1d(live, src)
            if rest.size:
                dst = r.choice(rest, src.size)
                store.add_into(src, dst)
                store.delete(src)
        elif kind == "delete" and live.size:
            store.delete(r.choice(live, 1))
        elif kind == "alloc":
            k = int(r.integers(1, 6))
            store.allocate(0, r.integers(0, 10**6, k), np.zeros(k, np.uint64), np.zeros((k, 3)))
        elif kind == "clear":
            store.clear_window()
            assert not store.window_counts.any()
            assert not store.window_nodir.any()
        live = store.live_rows()
        want = live[store.window_totals(live) > 0]
        np.testing.assert_array_equal(store.window_rows(), want)
        assert not (store.kind[store.window_rows()] == FREE).any()


def test_loaded_store_knows_its_open_window_rows() -> None:
    store = EntryStore.empty(2)
    store.allocate(0, np.arange(5), np.zeros(5, np.uint64), np.zeros((5, 3)))
    store.accumulate(np.array([1, 3, 3]), np.array([0, -1, 1]), np.ones(3))
    prefix = "entry_"
    arrays = store.to_arrays(np.arange(5), prefix)
    loaded = EntryStore.from_arrays(arrays, 2, prefix)
    np.testing.assert_array_equal(loaded.window_rows(), [1, 3])
    loaded.clear_window()
    assert loaded.window_rows().size == 0
    assert not loaded.window_counts.any()


# -- the per-window sums of a day ------------------------------------------------------------


def _per_window_sums_pairwise(fc: Any, entries: np.ndarray, fixed_slots: np.ndarray,
                              obs_e: np.ndarray, obs_s: np.ndarray, rot: np.ndarray,
                              floor: float) -> np.ndarray:
    """The pre-issue-15 ``scoring._per_window_sums``: every (entry, window) pair as a row,
    summed chunk by chunk with ``np.bincount``; each pair's term 2 Re(γ z) in the real form
    the block evaluation uses (Re γ · 2 Re z − Im γ · 2 Im z, no complex product)."""
    slot_of = np.full(fc.rows.size, -1, np.int64)
    slot_of[entries] = np.arange(entries.size)
    pair_e = [np.repeat(entries, fixed_slots.size)]
    pair_s = [np.tile(fixed_slots, entries.size)]
    own = slot_of[obs_e] >= 0
    pair_e.append(obs_e[own])
    pair_s.append(obs_s[own])
    pe, ps = np.concatenate(pair_e), np.concatenate(pair_s)
    m_max = fc.params.max_order
    total = np.zeros((m_max, entries.size))
    for a in range(0, pe.size, scoring._PAIRS):
        e, s = pe[a : a + scoring._PAIRS], ps[a : a + scoring._PAIRS]
        z, coef = rot[s[:, None], fc.period_idx[e]], fc.coef_total[e]
        terms = np.cumsum(coef.real * (2.0 * z.real) - coef.imag * (2.0 * z.imag), axis=1)
        lam = np.maximum(fc.rate_total[e][:, None] + terms, floor)
        local = slot_of[e]
        for j in range(m_max):
            total[j] += np.bincount(local, lam[:, j], minlength=entries.size)
    return total


@pytest.mark.parametrize("chunk", [7, 100, 1 << 15])
@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_per_window_sums_equal_the_pairwise_sums_bit_for_bit(
    chunk: int, seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Random forecasts (rates, FreMEn coefficients, periods), fixed-sensor slots and own
    observation pairs, chunk sizes that cut entries' pairs anywhere: equal bits."""
    monkeypatch.setattr(scoring, "_PAIRS", chunk)
    rng = np.random.default_rng(seed)
    rows, m, k, slots = int(rng.integers(1, 60)), int(rng.integers(1, 5)), 7, 30
    fc = SimpleNamespace(
        rows=np.arange(rows),
        params=SimpleNamespace(max_order=m),
        rate_total=rng.exponential(0.3, rows),
        coef_total=rng.normal(0, 0.2, (rows, m)) + 1j * rng.normal(0, 0.2, (rows, m)),
        period_idx=rng.integers(0, k, (rows, m)),
    )
    t = np.sort(rng.uniform(0, 86_400, slots))
    rot = np.exp(-1j * np.multiply.outer(t, rng.uniform(1e-5, 1e-3, k)))
    fixed = np.flatnonzero(rng.random(slots) < rng.uniform(0, 1))
    entries = np.flatnonzero(rng.random(rows) < 0.6)
    n_obs = int(rng.integers(0, 200))
    obs_e = np.sort(rng.integers(0, rows, n_obs))
    obs_s = rng.integers(0, slots, n_obs)
    got = scoring._per_window_sums(fc, entries, fixed, obs_e, obs_s, rot, 0.01)  # type: ignore[arg-type]
    want = _per_window_sums_pairwise(fc, entries, fixed, obs_e, obs_s, rot, 0.01)
    assert got.shape == want.shape
    assert got.tobytes() == want.tobytes()


# -- whole builds ----------------------------------------------------------------------------


def _build(seed: int, robot: bool) -> dict[str, np.ndarray]:
    """Three days of a map: detections in bursts (some windows empty), a graph every window
    whose nodes come, go and move, stability and binds, a fixed sensor or a robot path."""
    rng = np.random.default_rng(seed)
    cfg = ModelConfig(stability_s=120.0, window_s=600.0, cell_size=0.5, bind_radius=1.0)
    m = Mapper(cfg)
    start = T0_DAY_END - 3 * 3600 * S
    end = start + 3 * 86_400 * S
    if robot:
        t = np.arange(start, end, 30 * S)
        xyz = np.c_[6 * np.cos(t / 4e12), 6 * np.sin(t / 4e12), np.zeros(t.size)]
        m.add_trajectory(Trajectory(t, xyz))
    else:
        m.set_fixed_sensor(start, end)
    pool = np.c_[rng.uniform(-6, 6, (12, 2)), rng.choice([0.0, 3.0], 12)]
    present = rng.random(12) < 0.7
    t = start
    while t < end - 700 * S:
        t += int(rng.integers(100, 1300)) * S
        if rng.random() < 0.6:
            n = int(rng.integers(1, 40))
            xyz = np.c_[rng.uniform(-7, 7, (n, 2)), rng.choice([0.0, 3.0], n)]
            stamps = t + rng.integers(0, 60 * S, n)
            heading = np.where(rng.random(n) < 0.2, np.nan, rng.uniform(-np.pi, np.pi, n))
            m.add_detections(detections(np.sort(stamps), xyz, heading, rng.uniform(0, 2, n)))
        if rng.random() < 0.5:
            flip = rng.random(12) < 0.1
            present ^= flip
            pool[rng.random(12) < 0.05, :2] += rng.normal(0, 1.0, 2)
            idx = np.flatnonzero(present)
            m.add_graph(graph(t + 61 * S, idx.tolist(), pool[idx]))
            t += 61 * S
    m.advance(end)
    arrays, _meta = m.state.to_arrays()
    return {k: np.asarray(v) for k, v in arrays.items()}


def _plain(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every issue-15 shortcut replaced by its plain version."""
    monkeypatch.setattr(ownership, "plan_binds", ownership.plan_binds_plain)
    monkeypatch.setattr(closing, "plan_binds", ownership.plan_binds_plain)
    monkeypatch.setattr(ownership, "apply_binds", ownership.apply_binds_plain)
    monkeypatch.setattr(closing, "apply_binds", ownership.apply_binds_plain)
    monkeypatch.setattr(scoring, "_per_window_sums", _per_window_sums_pairwise)

    def window_rows(self: EntryStore) -> np.ndarray:
        live = self.live_rows()
        return live[self.window_totals(live) > 0]

    monkeypatch.setattr(EntryStore, "window_rows", window_rows)


@pytest.mark.parametrize("robot", [False, True])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_builds_equal_the_plain_builds_bit_for_bit(
    seed: int, robot: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    fast = _build(seed, robot)
    with monkeypatch.context() as patch:
        _plain(patch)
        plain = _build(seed, robot)
    assert ownership.plan_binds is not ownership.plan_binds_plain  # patches undone
    assert sorted(fast) == sorted(plain)
    for name in fast:
        assert fast[name].dtype == plain[name].dtype, name
        assert fast[name].shape == plain[name].shape, name
        assert fast[name].tobytes() == plain[name].tobytes(), name
    # the builds did what they are meant to exercise
    assert fast["redirect_keys"].size > 0  # cells bound
    assert (fast["entry_kind"] == 1).any()  # node entries
    assert (fast["entry_kind"] == 0).any()  # cell entries
    assert fast["temporal_flow_scored"].sum() > 0  # days were closed and scored


# -- an unchanged graph ------------------------------------------------------------------------


@given(
    st.integers(0, 2**31 - 1),
    st.sampled_from(["same", "moved", "beyond", "new", "gone", "moving"]),
)
@settings(max_examples=120, deadline=None)
def test_node_table_update_by_an_unchanged_graph_keeps_the_table(seed: int, kind: str) -> None:
    """A snapshot repeating the table's nodes (the shortcuts: unchanged, or the same ids
    moved) gives the table the full update gives for the same snapshot in another order
    (which takes the general path), whatever changed before: timers, references and the gone
    mask equal."""
    from aion_cli.engine.nodes import NodeTable

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 12))
    ids = np.sort(rng.choice(10**6, n, replace=False)).astype(np.uint64)
    xyz = rng.uniform(-5, 5, (n, 3))
    table, _ = NodeTable().updated(ids, xyz, 0, 0.1)
    later = xyz.copy()
    if kind == "moved":  # within the tolerance: timers kept, reference kept
        later[0] += 0.05
    elif kind == "beyond":
        later[0] += 1.0
    table, _ = table.updated(ids, later, 10 * S, 0.1)
    snap_ids, snap_xyz = ids.copy(), later.copy()
    if kind == "new":
        snap_ids, snap_xyz = np.r_[ids, np.uint64(10**7)], np.r_[later, [[0.0, 0.0, 0.0]]]
    elif kind == "gone" and n > 1:
        snap_ids, snap_xyz = ids[1:], later[1:]
    elif kind == "moving":  # the same nodes, every one moved: some within tolerance, some not
        snap_xyz = later + rng.normal(0.0, 0.08, later.shape)
    perm = rng.permutation(len(snap_ids))
    fast, fast_gone = table.updated(snap_ids, snap_xyz, 20 * S, 0.1)
    full, full_gone = table.updated(snap_ids[perm][::-1].copy(), snap_xyz[perm][::-1].copy(),
                                    20 * S, 0.1)
    if len(perm) > 1 and not (perm[::-1] == np.arange(len(perm))).all():
        assert not np.array_equal(snap_ids[perm][::-1], table.ids)  # really the other path
    for name in ("ids", "xyz", "ref_xyz", "stable_since_ns"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(full, name), err_msg=name)
    np.testing.assert_array_equal(fast_gone, full_gone)
    if kind in ("same", "moved"):
        np.testing.assert_array_equal(fast.stable_since_ns, np.zeros(n, np.int64))
    if kind == "beyond":
        assert fast.stable_since_ns[0] == 10 * S


def test_bind_index_travels_empty_and_answers_alike() -> None:
    """A pickled memo (a parallel build's shard state) arrives empty, without its KD-tree,
    and gives the same answers as before and as :func:`nearest_nodes`."""
    import pickle

    rng = np.random.default_rng(5)
    nodes = rng.uniform(0, 20, (40, 3))
    cells = rng.uniform(0, 20, (300, 3))
    rows = np.arange(300)
    keys = np.arange(300)
    index = BindIndex()
    before = index.nearest(rows, keys, cells, nodes, 1.5, 0.5)
    copy = pickle.loads(pickle.dumps(index))
    assert copy._tree is None
    assert not copy._known.any()
    np.testing.assert_array_equal(copy.nearest(rows, keys, cells, nodes, 1.5, 0.5), before)
    np.testing.assert_array_equal(before, nearest_nodes(cells, nodes, 1.5, 0.5))


@pytest.mark.parametrize("robot", [False, True])
def test_binds_update_the_route_table_as_a_rebuild_would(
    robot: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """After every bind of a build (at graphs and window closes), the route table updated in
    place equals the one rebuilt from the live cells and the redirects."""
    incremental = ownership.apply_binds
    checked = []

    def checking(state: Any, plan: Any) -> None:
        incremental(state, plan)
        keys, rows = state.routes.keys.copy(), state.routes.rows.copy()
        state.rebuild_routes()
        np.testing.assert_array_equal(keys, state.routes.keys)
        np.testing.assert_array_equal(rows, state.routes.rows)
        checked.append(len(plan.cells))

    monkeypatch.setattr(ownership, "apply_binds", checking)
    monkeypatch.setattr(closing, "apply_binds", checking)
    _build(4, robot)
    assert len(checked) >= 3
