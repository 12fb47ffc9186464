"""Issue 15, per-batch and per-day repeats of a build's stream: each shortcut gives exactly
what the code it replaced gave (verbatim copies below), and takes the shortcut.

* ``Mapper.add_detections`` for the usual batch (every row accepted, one window): no
  per-row window index, no selection, no drop masks; against the general path on batches
  with NaN, unhashable and late rows and batches across windows, and on whole builds.
* ``direction_prior.fitted_kappa`` evaluating ln Γ once per likelihood step (one call on
  every argument) against one call per argument, to the bit.
* ``grouping.insert_sorted`` against ``np.insert`` (the route table's and the redirects'
  growth).
* A bind check after one that bound none, or whose binds were made, with the same stable
  nodes asks only about the cells added since (``EntryStore.cells_added_since``), not every
  cell, and finds what the plain check finds (whole builds: ``test_issue15_day_paths``).
"""

from __future__ import annotations

import copy
import pickle
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine import mapper as mapper_module
from aion_cli.engine import ownership
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import CELL, NODE, EntryStore
from aion_cli.engine.grouping import insert_sorted, split_by_key
from aion_cli.engine.mapper import ACCEPTED, Mapper, _later, check_time
from aion_cli.engine.spatial_hash import hashable_indices
from aion_cli.engine.state import DROP_REASONS
from aion_cli.engine.temporal import direction_prior
from aion_cli.engine.types import DetectionBatch
from aion_cli.engine.windows import window_index
from tests.engine import test_issue15_windows as window_builds
from tests.engine.engine_builders import T0, S, detections, graph

# -- Mapper.add_detections -------------------------------------------------------------------


def _add_detections_before(self: Mapper, batch: DetectionBatch, codes: Any = None) -> Any:
    """``Mapper.add_detections`` before the usual batch's shortcut (verbatim)."""
    st = self._state
    drops = dict.fromkeys(DROP_REASONS, 0)
    if codes is None:
        codes = np.empty(len(batch), dtype=np.int8)
    codes[:] = ACCEPTED
    if len(batch) == 0:
        return drops
    check_time(int(batch.t_ns.min()), "a detection")
    check_time(int(batch.t_ns.max()), "a detection")
    ijk, finite, hashable = hashable_indices(batch.xyz, st.config.cell_size)
    window = window_index(batch.t_ns, self._delta)
    if st.open_window is None and hashable.any():
        st.open_window = int(window[hashable].min())
    opened = st.open_window if st.open_window is not None else 0
    late = hashable & (window < opened)
    keep = hashable & ~late
    drops["nan"] = int(len(batch) - np.count_nonzero(finite))
    drops["out_of_range"] = int(np.count_nonzero(finite) - np.count_nonzero(hashable))
    drops["before_window"] = int(np.count_nonzero(late))
    for reason, count in drops.items():
        st.dropped[reason] = st.dropped.get(reason, 0) + count
    codes[~finite] = DROP_REASONS.index("nan")
    codes[finite & ~hashable] = DROP_REASONS.index("out_of_range")
    codes[late] = DROP_REASONS.index("before_window")
    if keep.all():
        _accumulate_by_window_before(self, batch, ijk, window)
    elif keep.any():
        _accumulate_by_window_before(self, batch.select(keep), ijk[keep], window[keep])
    return drops


def _accumulate_by_window_before(self: Mapper, batch: DetectionBatch, ijk: Any,
                                 window: Any) -> None:
    """``Mapper._accumulate_by_window`` before (verbatim)."""
    st = self._state
    if window.min() == window.max():
        groups = [(int(window[0]), np.arange(len(window)))]
    else:
        groups = [(int(window[idx[0]]), idx) for idx in split_by_key(window)]
    whole = len(groups) == 1
    for w, idx in groups:
        mapper_module.close_windows(st, w)
        part = batch if whole else batch.select(idx)
        self._accumulate(part, ijk if whole else ijk[idx])
        st.log_time_ns = _later(st.log_time_ns, int(part.t_ns.max()))


def _batches(seed: int) -> list[DetectionBatch]:
    """Batches as a build feeds them, and the odd ones: NaN and unhashable positions, rows
    before the open window (late), batches across two or three windows, an empty one."""
    rng = np.random.default_rng(seed)
    out, t = [], T0 + 30 * S
    for _ in range(60):
        n = int(rng.integers(0, 30))
        xyz = np.c_[rng.uniform(-8, 8, (n, 2)), rng.choice([0.0, 3.0], n)]
        span = int(rng.choice([50, 50, 50, 900, 1500])) * S  # some cross windows
        stamps = np.sort(t + rng.integers(0, span, n))
        kind = rng.random()
        if kind < 0.1 and n:
            xyz[rng.integers(0, n)] = np.nan
        elif kind < 0.2 and n:
            xyz[rng.integers(0, n), 0] = 1e300
        elif kind < 0.3 and n:
            stamps[: max(1, n // 3)] -= 2000 * S  # before the open window
        heading = np.where(rng.random(n) < 0.2, np.nan, rng.uniform(-np.pi, np.pi, n))
        out.append(detections(stamps, xyz, heading, rng.uniform(0, 2, n)))
        t += int(rng.integers(20, 700)) * S
    return out


def _feed(add: Any, seed: int) -> tuple[dict[str, np.ndarray], list[Any], dict[str, int]]:
    m = Mapper(ModelConfig(window_s=600.0, cell_size=0.5))
    m.set_fixed_sensor(T0, T0 + 86_400 * S)
    results = []
    for batch in _batches(seed):
        codes = np.full(len(batch), 99, np.int8)
        drops = add(m, batch, codes)
        results.append((drops, codes.tolist()))
    m.advance(T0 + 86_400 * S)
    arrays, _ = m.state.to_arrays()
    return {k: np.asarray(v) for k, v in arrays.items()}, results, dict(m.state.dropped)


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_add_detections_equals_the_general_path(seed: int) -> None:
    fast, fast_results, fast_dropped = _feed(Mapper.add_detections, seed)
    plain, plain_results, plain_dropped = _feed(_add_detections_before, seed)
    assert fast_results == plain_results
    assert fast_dropped == plain_dropped
    assert sum(d["before_window"] for d, _ in fast_results) > 0  # late rows were fed
    assert sum(d["nan"] + d["out_of_range"] for d, _ in fast_results) > 0
    assert sorted(fast) == sorted(plain)
    for name in fast:
        assert fast[name].tobytes() == plain[name].tobytes(), name


@pytest.mark.parametrize("robot", [False, True])
def test_builds_equal_the_general_detection_path(robot: bool,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    fast = window_builds._build(5, robot)
    monkeypatch.setattr(Mapper, "add_detections", _add_detections_before)
    plain = window_builds._build(5, robot)
    assert sorted(fast) == sorted(plain)
    for name in fast:
        assert fast[name].tobytes() == plain[name].tobytes(), name


def test_a_batch_inside_one_window_is_neither_indexed_by_window_nor_selected(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    m = Mapper(ModelConfig(window_s=600.0))
    xyz = np.c_[np.arange(20) * 0.3, np.zeros(20), np.zeros(20)]
    m.add_detections(detections(T0 + np.arange(20) * S, xyz, np.zeros(20), np.ones(20)))
    calls: list[str] = []
    real_index, real_select = mapper_module.window_index, DetectionBatch.select
    monkeypatch.setattr(mapper_module, "window_index",
                        lambda *a: calls.append("window_index") or real_index(*a))
    monkeypatch.setattr(DetectionBatch, "select",
                        lambda self, i: calls.append("select") or real_select(self, i))
    batch = detections(T0 + (30 + np.arange(20)) * S, xyz, np.zeros(20), np.ones(20))
    codes = np.full(20, 99, np.int8)
    assert m.add_detections(batch, codes) == dict.fromkeys(DROP_REASONS, 0)
    assert (codes == ACCEPTED).all()
    assert m.state.entries.total_count() == 40.0
    assert calls == []


# -- the direction prior's estimate ------------------------------------------------------------


def _fitted_kappa_before(counts: np.ndarray, parent: np.ndarray) -> float:
    """``direction_prior.fitted_kappa`` with one ln Γ call per argument (verbatim)."""
    dp = direction_prior
    n = dp.row_sums(counts)
    tell = n >= 2
    if int(tell.sum()) < dp.MIN_ENTRIES:
        return dp.FALLBACK
    c = np.asarray(counts, np.float64)[tell]
    p = np.clip(np.asarray(parent, np.float64)[tell], 1e-12, None)
    n = n[tell]
    if c.shape[0] > dp.MAX_ENTRIES:
        keep = dp.sample_rows(c, dp.MAX_ENTRIES, np.asarray(parent, np.float64)[tell])
        c, p, n = c[keep], p[keep], n[keep]
    row, col = np.nonzero(c)
    pairs, pair_times = np.unique(c[row, col] + 1j * p[row, col], return_counts=True)
    totals, total_times = np.unique(n, return_counts=True)
    pair_count, pair_share = pairs.real.copy(), pairs.imag.copy()
    entries = float(n.size)
    log_gamma = dp.log_gamma

    def log_likelihood(log_kappa: float) -> float:
        kappa = float(np.exp(log_kappa))
        a = kappa * pair_share
        of_pairs = float(pair_times @ (log_gamma(pair_count + a) - log_gamma(a)))
        of_entries = float(total_times @ log_gamma(totals + kappa))
        return of_pairs - of_entries + entries * float(log_gamma(np.array([kappa]))[0])

    lo, hi = (float(np.log(b)) for b in dp.KAPPA_RANGE)
    return float(np.exp(dp._golden_max(log_likelihood, lo, hi, 0.03)))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(5, 3000), st.sampled_from([0.7, 4.0, 40.0]))
def test_fitted_kappa_equals_one_log_gamma_call_per_argument(
    seed: int, entries: int, kappa: float
) -> None:
    rng = np.random.default_rng(seed)
    parent = rng.dirichlet(np.full(8, 2.0), entries)
    shares = np.array([rng.dirichlet(kappa * p + 1e-3) for p in parent])
    totals = rng.integers(0, 40, entries)
    counts = np.array([rng.multinomial(k, q) for k, q in zip(totals, shares, strict=True)])
    got = direction_prior.fitted_kappa(counts.astype(np.float64), parent)
    want = _fitted_kappa_before(counts.astype(np.float64), parent)
    assert np.float64(got).tobytes() == np.float64(want).tobytes()


def test_fitted_kappa_evaluates_log_gamma_once_per_step(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(7)
    parent = np.tile(rng.dirichlet(np.full(8, 2.0)), (300, 1))
    counts = np.array([rng.multinomial(20, rng.dirichlet(5.0 * p)) for p in parent])
    steps, calls = [0], [0]
    golden, log_gamma = direction_prior._golden_max, direction_prior.log_gamma

    def counted_golden(f: Any, *args: Any) -> float:
        def step(x: float) -> float:
            steps[0] += 1
            return float(f(x))
        return golden(step, *args)

    def counted_log_gamma(x: Any) -> Any:
        calls[0] += 1
        return log_gamma(x)

    monkeypatch.setattr(direction_prior, "_golden_max", counted_golden)
    monkeypatch.setattr(direction_prior, "log_gamma", counted_log_gamma)
    kappa = direction_prior.fitted_kappa(counts.astype(np.float64), parent)
    assert 2.0 < kappa < 12.0  # drawn with κ = 5
    assert steps[0] > 10
    assert calls[0] == steps[0]


# -- sorted insertion -------------------------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.integers(-50, 50), max_size=40),
    st.lists(st.integers(-60, 60), max_size=10),
    st.sampled_from([np.int64, np.uint64, np.float64]),
    st.booleans(),
)
def test_insert_sorted_equals_np_insert(
    base: list[int], new: list[int], dtype: Any, rows: bool
) -> None:
    table = np.sort(np.abs(np.asarray(base, np.int64))).astype(dtype)
    keys = np.sort(np.abs(np.asarray(new, np.int64))).astype(dtype)
    at = np.searchsorted(table, keys)
    if rows:  # rows of a 2-D table (positions), as np.insert(..., axis=0)
        table2 = np.c_[table, table * 2]
        values = np.c_[keys, keys + 1]
        want = np.insert(table2, at, values, axis=0)
        got = insert_sorted(table2, at, values)
    else:
        want = np.insert(table, at, keys)
        got = insert_sorted(table, at, keys)
    assert got.dtype == want.dtype
    assert got.shape == want.shape
    assert got.tobytes() == want.tobytes()


# -- bind checks after one that bound none -----------------------------------------------------


def _cells(store: EntryStore, keys: list[int]) -> np.ndarray:
    k = np.asarray(keys, np.int64)
    return store.allocate(CELL, k, np.zeros(k.size, np.uint64), np.zeros((k.size, 3)))


def test_cells_added_since_a_version() -> None:
    store = EntryStore.empty(8)
    v0 = store.cells_version
    first = _cells(store, [1, 2])
    v1 = store.cells_version
    second = _cells(store, [3])
    assert store.cells_added_since(store.cells_version).size == 0
    assert store.cells_added_since(v1).tolist() == second.tolist()
    assert store.cells_added_since(v0).tolist() == [*first.tolist(), *second.tolist()]
    assert store.cells_added_since(-5) is None  # never this store's
    for other in (copy.deepcopy(store), pickle.loads(pickle.dumps(store))):
        assert other.cells_added_since(v1) is None  # a copy has versions of its own
        assert other.cells_added_since(other.cells_version).size == 0
    v2 = store.cells_version
    store.delete(first[:1])  # a cell gone: what came before is not known any more
    assert store.cells_added_since(v2) is None
    v3 = store.cells_version
    third = _cells(store, [4])  # the freed row again
    assert store.cells_added_since(v3).tolist() == third.tolist() == first[:1].tolist()
    store.allocate(NODE, np.array([-1]), np.array([7], np.uint64), np.zeros((1, 3)))
    assert store.cells_added_since(v3) is None


def test_a_bind_check_after_one_that_bound_none_asks_only_about_new_cells(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    cfg = ModelConfig(window_s=600.0, cell_size=0.5, stability_s=60.0, bind_radius=1.0)
    m = Mapper(cfg)
    nodes = np.array([[0.0, 0.0, 0.0], [20.0, 0.0, 0.0]])
    m.add_graph(graph(T0, [0, 1], nodes))
    far = np.c_[np.linspace(5, 15, 30), np.full(30, 5.0), np.zeros(30)]
    m.add_detections(detections(T0 + 10 * S + np.arange(30) * S, far))
    m.add_graph(graph(T0 + 100 * S, [0, 1], nodes))  # stable now: a check binding none
    st = m.state
    cells_before = st.entries.cell_rows()
    assert cells_before.size == 21  # 10 m of 0.5 m cells
    assert ownership.plan_binds(st, T0 + 100 * S) is None
    new = np.array([[0.3, 0.2, 0.0], [8.0, -6.0, 0.0], [20.4, 0.1, 0.0]])
    m.add_detections(detections(T0 + 120 * S + np.arange(3) * S, new))
    assert st.entries.cell_rows().size == 24
    listed = []
    real = EntryStore.cell_rows

    def counted(self: EntryStore) -> np.ndarray:
        listed.append(1)
        return real(self)

    asked = st.nodes.bind_index.queried
    monkeypatch.setattr(EntryStore, "cell_rows", counted)
    plan = ownership.plan_binds(st, T0 + 130 * S)
    assert listed == []  # the cells were not listed ...
    assert st.nodes.bind_index.queried - asked == 3  # ... only the three new ones asked about
    monkeypatch.undo()
    want = ownership.plan_binds_plain(st, T0 + 130 * S)
    assert plan is not None
    assert want is not None
    assert plan.cells.tolist() == want.cells.tolist()
    assert plan.node_ids.tolist() == want.node_ids.tolist()
    assert plan.node_xyz.tobytes() == want.node_xyz.tobytes()
    assert sorted(st.entries.xyz[plan.cells, 0].round(2).tolist()) == [0.25, 20.25]
    # once bound, every cell left was seen unbound: the next check lists none either
    ownership.apply_binds(st, plan)
    more = np.array([[19.6, -0.3, 0.0], [12.0, 9.0, 0.0]])
    m.add_detections(detections(T0 + 140 * S + np.arange(2) * S, more))
    asked = st.nodes.bind_index.queried
    monkeypatch.setattr(EntryStore, "cell_rows", counted)
    again = ownership.plan_binds(st, T0 + 150 * S)
    assert listed == []
    assert st.nodes.bind_index.queried - asked == 2
    monkeypatch.undo()
    want = ownership.plan_binds_plain(st, T0 + 150 * S)
    assert again is not None
    assert want is not None
    assert again.cells.tolist() == want.cells.tolist()
    assert again.node_ids.tolist() == want.node_ids.tolist()
    assert st.entries.xyz[again.cells, :2].round(2).tolist() == [[19.75, -0.25]]
