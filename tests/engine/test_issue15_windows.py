"""Issue 15, per-window costs: the open-window row flags, the block evaluation of a day's
per-window sums, the node-table shortcuts and the route table updated by binds give exactly
what the plain versions give (the bind-check memo: ``test_bind_index.py``).

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
from aion_cli.engine.temporal import scoring
from aion_cli.engine.types import Trajectory
from tests.engine.engine_builders import T0_DAY_END, S, feed_bursts

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


def _per_window_sums_pairwise(fc: Any, entries: np.ndarray,
                              fixed: tuple[np.ndarray, np.ndarray | None],
                              own_pairs: tuple[np.ndarray, np.ndarray, np.ndarray],
                              rot: np.ndarray, floor: float) -> np.ndarray:
    """The pre-issue-15 ``scoring._per_window_sums``: every (entry, window) pair as a row,
    summed chunk by chunk with ``np.bincount``; each pair's term 2 Re(γ z) in the real form
    the block evaluation uses (Re γ · 2 Re z − Im γ · 2 Im z, no complex product), an own
    pair's max(λ, floor) times its exposure, a fixed slot's times its recorded share."""
    fixed_slots, fixed_share = fixed
    obs_e, obs_s, obs_w = own_pairs
    slot_of = np.full(fc.rows.size, -1, np.int64)
    slot_of[entries] = np.arange(entries.size)
    pair_e = [np.repeat(entries, fixed_slots.size)]
    pair_s = [np.tile(fixed_slots, entries.size)]
    whole = np.ones(fixed_slots.size) if fixed_share is None else fixed_share
    pair_w = [np.tile(whole, entries.size)]
    own = slot_of[obs_e] >= 0
    pair_e.append(obs_e[own])
    pair_s.append(obs_s[own])
    pair_w.append(obs_w[own])
    pe, ps, pw = np.concatenate(pair_e), np.concatenate(pair_s), np.concatenate(pair_w)
    m_max = fc.params.max_order
    total = np.zeros((m_max, entries.size))
    for a in range(0, pe.size, scoring._PAIRS):
        e, s = pe[a : a + scoring._PAIRS], ps[a : a + scoring._PAIRS]
        z, coef = rot[s[:, None], fc.period_idx[e]], fc.coef_total[e]
        terms = np.cumsum(coef.real * (2.0 * z.real) - coef.imag * (2.0 * z.imag), axis=1)
        lam = np.maximum(fc.rate_total[e][:, None] + terms, floor)
        lam *= pw[a : a + scoring._PAIRS, None]
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
    fixed_slots = np.flatnonzero(rng.random(slots) < rng.uniform(0, 1))
    # fixed-sensor windows recorded whole, or some in part (a log starting inside one)
    share = None if seed % 3 else np.where(
        rng.random(fixed_slots.size) < 0.5, 1.0, rng.uniform(0.01, 1.0, fixed_slots.size)
    )
    fixed = (fixed_slots, share)
    entries = np.flatnonzero(rng.random(rows) < 0.6)
    n_obs = int(rng.integers(0, 200))
    obs_e = np.sort(rng.integers(0, rows, n_obs))
    obs_s = rng.integers(0, slots, n_obs)
    # robot windows observed whole, or in part (their exposures)
    obs_w = np.ones(n_obs) if seed % 2 else rng.uniform(0.01, 1.0, n_obs)
    own = (obs_e, obs_s, obs_w)
    got = scoring._per_window_sums(fc, entries, fixed, own, rot, 0.01)  # type: ignore[arg-type]
    want = _per_window_sums_pairwise(fc, entries, fixed, own, rot, 0.01)
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
    return feed_bursts(m, rng, start, end, (100, 1300))


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
