"""Issue 15, per-batch, per-bind and per-day costs: ``EntryStore.accumulate``'s path for
batches whose every detection has a heading and a speed, and ``Redirects.add`` merging new
keys into the sorted table, give exactly what the general code gave (verbatim copies of it
below), bit for bit, on random inputs (hypothesis); a day's forecasters reading the profile
sums their pooling kept learn exactly what computing them again learnt; builds whose node
tables remember where the node entries lie equal builds that search at every graph."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import EntryStore
from aion_cli.engine.grouping import unique_inverse
from aion_cli.engine.nodes import Redirects
from aion_cli.engine.temporal.params import TemporalParams

_ARRAYS = ("counts", "window_counts", "speed_sum", "speed_n", "heading_cos", "heading_sin",
           "nodir", "window_nodir", "window_mark")


def _accumulate_general(store: EntryStore, rows: np.ndarray, bins: np.ndarray,
                        speed: np.ndarray, heading: np.ndarray | None) -> None:
    """``EntryStore.accumulate`` before the fast path (verbatim but for ``self``)."""
    if len(rows) == 0:
        return
    b = store.bins
    if store.n * b <= 4 * len(rows):
        target, local, m = slice(0, store.n), rows, store.n
    else:
        target, local = unique_inverse(rows)
        m = len(target)
    directed = bins >= 0
    flat_dir = local[directed] * b + bins[directed]
    hist = np.bincount(flat_dir, minlength=m * b).reshape(m, b).astype(np.float64)
    undirected = np.bincount(local[~directed], minlength=m).astype(np.float64)
    store.counts[target] += hist
    store.window_counts[target] += hist
    store.window_mark[rows] = True
    store.nodir[target] += undirected
    store.window_nodir[target] += undirected
    if heading is not None and directed.any():
        theta = heading[directed]
        for name, part in (("heading_cos", np.cos(theta)), ("heading_sin", np.sin(theta))):
            getattr(store, name)[target] += np.bincount(
                flat_dir, weights=part, minlength=m * b
            ).reshape(m, b)
    sp = speed[directed]
    has_speed = np.isfinite(sp)
    if has_speed.any():
        idx = flat_dir[has_speed]
        store.speed_sum[target] += np.bincount(
            idx, weights=sp[has_speed], minlength=m * b
        ).reshape(m, b)
        store.speed_n[target] += np.bincount(idx, minlength=m * b).reshape(m, b)


def _store(n: int, bins: int) -> EntryStore:
    store = EntryStore.empty(bins, capacity=n)
    store.n = n
    return store


@given(
    st.integers(1, 300),
    st.lists(st.tuples(st.integers(0, 400), st.sampled_from(["all", "some", "none"]),
                       st.sampled_from(["finite", "some_nan", "nan"]), st.booleans(),
                       st.integers(0, 2**31 - 1)), min_size=1, max_size=8),
)
@settings(max_examples=200, deadline=None)
def test_accumulate_equals_the_general_path(
    n: int, batches: list[tuple[int, str, str, bool, int]]
) -> None:
    """Batches of any size over any number of rows (dense and sparse histograms), with every,
    some or no detection directed, speeds finite, partly NaN or all NaN, with or without
    headings: every array of the store equals the general path's, bit for bit."""
    bins = 8
    fast, plain = _store(n, bins), _store(n, bins)
    for size, directed, speeds, with_heading, seed in batches:
        rng = np.random.default_rng(seed)
        rows = rng.integers(0, n, size)
        heading = rng.uniform(-np.pi, np.pi, size)
        b = (rng.integers(0, bins, size)).astype(np.int64)
        if directed == "some":
            b[rng.random(size) < 0.3] = -1
        elif directed == "none":
            b[:] = -1
        speed = rng.uniform(0.0, 2.5, size)
        if speeds == "some_nan":
            speed[rng.random(size) < 0.3] = np.nan
        elif speeds == "nan":
            speed[:] = np.nan
        h = heading if with_heading else None
        fast.accumulate(rows, b, speed, h)
        _accumulate_general(plain, rows, b, speed, h)
    for name in _ARRAYS:
        got, want = getattr(fast, name), getattr(plain, name)
        assert got.dtype == want.dtype, name
        assert got.tobytes() == want.tobytes(), name


def _add_general(red: Redirects, keys: np.ndarray, nodes: np.ndarray) -> None:
    """``Redirects.add`` before the merge (verbatim but for ``self``)."""
    all_keys = np.concatenate([red.keys, keys.astype(np.int64)])
    all_nodes = np.concatenate([red.nodes, nodes.astype(np.uint64)])
    order = np.argsort(all_keys, kind="stable")
    red.keys, red.nodes = all_keys[order], all_nodes[order]
    if len(red.keys) > 1 and np.any(red.keys[1:] == red.keys[:-1]):
        raise ValueError("a cell key was redirected twice")


@given(st.lists(st.tuples(st.integers(0, 60), st.booleans(), st.booleans(),
                          st.integers(0, 2**31 - 1)), min_size=1, max_size=12))
@settings(max_examples=200, deadline=None)
def test_redirects_add_equals_a_sort_of_the_whole_table(
    steps: list[tuple[int, bool, bool, int]]
) -> None:
    """Keys added sorted (as binds add them) or not, distinct or repeating old ones (or each
    other): the table equals the stable sort of old and new keys, and a key redirected twice
    raises exactly when the whole-table scan finds it, leaving the table as it was."""
    merged, plain = Redirects(), Redirects()
    for size, in_order, repeat, seed in steps:
        rng = np.random.default_rng(seed)
        fresh = rng.choice(np.arange(-500, 500), size=size, replace=False).astype(np.int64)
        if repeat and plain.keys.size:
            fresh[: max(1, size // 4)] = rng.choice(plain.keys, size=min(size, max(1, size // 4)))
        if not repeat and size > 2 and seed % 3 == 0:  # a key twice among the new ones
            fresh[-1] = fresh[seed % (size - 1)]
        keys = np.sort(fresh) if in_order else fresh
        nodes = rng.integers(1, 2**40, size).astype(np.uint64)
        before = merged.keys.copy(), merged.nodes.copy()
        outcome = []
        for red, add in ((merged, Redirects.add), (plain, _add_general)):
            try:
                add(red, keys, nodes)
                outcome.append(None)
            except ValueError as exc:
                outcome.append(str(exc))
        assert outcome[0] == outcome[1]
        if outcome[0] is not None:  # left as it was; the scan's table is broken: start again
            assert np.array_equal(merged.keys, before[0])
            assert np.array_equal(merged.nodes, before[1])
            merged, plain = Redirects(), Redirects()
            continue
        assert merged.keys.dtype == plain.keys.dtype
        assert merged.nodes.dtype == plain.nodes.dtype
        assert np.array_equal(merged.keys, plain.keys)
        assert np.array_equal(merged.nodes, plain.nodes)


def test_redirects_add_to_an_empty_table_and_nothing() -> None:
    red = Redirects()
    red.add(np.zeros(0, np.int64), np.zeros(0, np.uint64))
    assert red.keys.size == 0
    assert red.keys.dtype == np.int64
    assert red.nodes.dtype == np.uint64
    red.add(np.array([5, 1], np.int64), np.array([7, 9], np.uint64))
    assert red.keys.tolist() == [1, 5]
    assert red.nodes.tolist() == [9, 7]
    with pytest.raises(ValueError, match="twice"):
        red.add(np.array([5], np.int64), np.array([3], np.uint64))


@pytest.mark.parametrize("repeated", [[-3], [40], [7], [6, 7], [8, 8], [41, 41], [-9, -9]])
def test_redirects_add_finds_a_repeat_at_the_table_ends_and_among_new_keys(
    repeated: list[int]
) -> None:
    """A repeat of the first, the last or a middle key (alone, or beside a neighbour that
    is new), or a key given twice in one add (below, above or inside the table): raises, and
    the table keeps its keys and nodes; neighbours that are not equal do not raise."""
    red = Redirects()
    red.add(np.array([-3, 7, 40], np.int64), np.array([1, 2, 3], np.uint64))
    with pytest.raises(ValueError, match="twice"):
        red.add(np.array(repeated, np.int64), np.arange(len(repeated), dtype=np.uint64) + 9)
    assert red.keys.tolist() == [-3, 7, 40]
    assert red.nodes.tolist() == [1, 2, 3]
    red.add(np.array([-4, -2, 6, 8, 39, 41], np.int64), np.arange(6, dtype=np.uint64) + 9)
    assert red.keys.tolist() == [-4, -3, -2, 6, 7, 8, 39, 40, 41]
    assert red.nodes.tolist() == [9, 1, 10, 11, 2, 12, 13, 3, 14]


# -- a day's scoring reads the pooled entries' profile sums ------------------------------------


def test_forecaster_reads_the_pooled_profile_sums() -> None:
    """``PoolStats.kept`` (the W and S of entries pooled in one block), read at candidates'
    positions, equals what ``Forecaster.cache_profiles`` computes for them, bit for bit; a
    pool of more entries than a block keeps none and the forecaster computes them."""
    from aion_cli.engine.temporal import pooling
    from aion_cli.engine.temporal.forecast import Forecaster
    from tests.engine.test_temporal_blocks import _days, _learnt

    params = TemporalParams.from_config(ModelConfig())
    state = _learnt(params, 40, _days(params, 40, 4, seed=3))
    rows = np.arange(40, dtype=np.int64)
    groups = rows // 5
    at = np.array([0, 3, 7, 20, 21, 39])
    pool = pooling.PoolStats.of(params, state, rows, groups, 8)
    assert pool.kept is not None
    read = Forecaster(params, state, rows[at], groups[at], pool)
    read.cache_profiles(at)
    computed = Forecaster(params, state, rows[at], groups[at], pool)
    computed.cache_profiles()
    assert read._profiles is not None
    assert computed._profiles is not None
    for got, want in zip(read._profiles, computed._profiles, strict=True):
        assert got.dtype == want.dtype
        assert got.tobytes() == want.tobytes()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pooling, "_POOL_BLOCK", 16)
        assert pooling.PoolStats.of(params, state, rows, groups, 8).kept is None


def test_learning_with_and_without_the_pooled_profile_sums_is_the_same(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Four days learnt (scored, then absorbed) with the entries pooled in one block (the
    forecasters read the kept sums) and in blocks of 16 (they compute them): every
    accumulator and score equal, bit for bit."""
    from aion_cli.engine.temporal import pooling
    from tests.engine.test_temporal_blocks import ARRAYS, _days, _learnt

    params = TemporalParams.from_config(ModelConfig())
    days = _days(params, 40, 4, seed=11)
    kept = _learnt(params, 40, days)
    monkeypatch.setattr(pooling, "_POOL_BLOCK", 16)
    computed = _learnt(params, 40, days)
    assert float(kept.dir_scored.sum()) > 0
    for name in ARRAYS:
        got, want = getattr(kept, name), getattr(computed, name)
        assert np.asarray(got).tobytes() == np.asarray(want).tobytes(), name


# -- where node entries lie in the node table --------------------------------------------------


def _without_entry_memo(patch: pytest.MonkeyPatch) -> None:
    """Node tables that never carry ``entry_at`` (every ``apply_graph`` searches)."""
    from aion_cli.engine.nodes import NodeTable

    for name in ("_moved", "_same"):
        method = getattr(NodeTable, name)

        def dropped(self: NodeTable, *args: object, _method: object = method) -> NodeTable:
            table: NodeTable = _method(self, *args)  # type: ignore[operator]
            table.entry_at = None
            return table

        patch.setattr(NodeTable, name, dropped)


@pytest.mark.parametrize("robot", [False, True])
@pytest.mark.parametrize("seed", [1, 2, 5])
def test_node_entry_memo_builds_the_same_map(
    seed: int, robot: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Graphs whose nodes move, come and go, cells binding to them: the map built with the
    node tables' ``entry_at`` memo equals the map built searching at every graph, member
    for member, bit for bit, and the memo was carried to later graphs."""
    from aion_cli.engine.nodes import NodeTable
    from tests.engine.test_issue15_windows import _build

    carried = []
    moved = NodeTable._moved

    def watching(self: NodeTable, *args: object) -> NodeTable:
        table = moved(self, *args)  # type: ignore[arg-type]
        carried.append(table.entry_at is not None)
        return table

    with monkeypatch.context() as patch:
        patch.setattr(NodeTable, "_moved", watching)
        memo = _build(seed, robot)
    assert any(carried)
    with monkeypatch.context() as patch:
        _without_entry_memo(patch)
        plain = _build(seed, robot)
    assert sorted(memo) == sorted(plain)
    for name in memo:
        assert memo[name].dtype == plain[name].dtype, name
        assert memo[name].tobytes() == plain[name].tobytes(), name


@given(st.lists(st.tuples(st.sampled_from(["cells", "nodes", "delete", "ask", "pickle"]),
                          st.integers(0, 2**31 - 1)), min_size=1, max_size=25))
@settings(max_examples=150, deadline=None)
def test_node_index_memo_answers_as_a_fresh_sort(ops: list[tuple[str, int]]) -> None:
    """``EntryStore.node_index`` (kept while the cells version stays) equals the node
    entries' ids sorted and their rows computed afresh, after any sequence of allocations of
    cells and nodes (row reuse, growth), deletions and pickling (which drops the memo)."""
    import pickle

    store = EntryStore.empty(4, capacity=2)
    next_id = 1
    for op, seed in ops:
        rng = np.random.default_rng(seed)
        if op in ("cells", "nodes"):
            k = int(rng.integers(1, 5))
            is_node = op == "nodes"
            ids = np.arange(next_id, next_id + k, dtype=np.uint64) if is_node else np.zeros(
                k, np.uint64)
            next_id += k
            keys = np.full(k, -1, np.int64) if is_node else rng.integers(0, 10**6, k)
            store.allocate(1 if is_node else 0, keys, ids[rng.permutation(k)],
                           rng.uniform(0, 1, (k, 3)))
        elif op == "delete" and store.n:
            live = store.live_rows()
            if live.size:
                store.delete(np.unique(rng.choice(live, int(rng.integers(1, live.size + 1)))))
        elif op == "pickle":
            store.node_index()
            store = pickle.loads(pickle.dumps(store))
        ids, rows = store.node_index()
        fresh_rows = store.node_rows()
        fresh_ids = store.node_id[fresh_rows]
        order = np.argsort(fresh_ids)
        assert ids.tobytes() == fresh_ids[order].tobytes()
        assert rows.tobytes() == fresh_rows[order].tobytes()


def test_add_rows_equals_fancy_in_place_addition() -> None:
    """``entries.add_rows``: ``array[rows] += values`` for distinct rows in any order (2-D and
    1-D) and for a slice, bit for bit; rows not named are untouched."""
    from aion_cli.engine.entries import add_rows

    rng = np.random.default_rng(7)
    for shape in ((50, 8), (50,)):
        base = rng.normal(size=shape) * 1e3
        rows = rng.permutation(50)[:17]
        values = rng.normal(size=(17, *shape[1:]))
        got, want = base.copy(), base.copy()
        add_rows(got, rows, values)
        want[rows] += values
        assert got.tobytes() == want.tobytes()
        untouched = np.setdiff1d(np.arange(50), rows)
        assert got[untouched].tobytes() == base[untouched].tobytes()
        whole = rng.normal(size=(20, *shape[1:]))
        got, want = base.copy(), base.copy()
        add_rows(got, slice(0, 20), whole)
        want[:20] += whole
        assert got.tobytes() == want.tobytes()


def test_window_count_columns_equals_the_column_stack() -> None:
    """``EntryStore.window_count_columns``: the open window's per-bin counts and undirected
    count of any rows (none, some in any order, all) as ``column_stack`` of fancy gathers
    gives them, bit for bit."""
    store = _store(100, 8)
    rng = np.random.default_rng(3)
    store.window_counts[:100] = rng.integers(0, 5, (100, 8))
    store.window_nodir[:100] = rng.integers(0, 3, 100)
    for rows in (np.zeros(0, np.int64), np.array([5, 3, 99, 0]), np.arange(100)):
        got = store.window_count_columns(rows)
        want = np.column_stack([store.window_counts[rows], store.window_nodir[rows]])
        assert got.shape == want.shape
        assert got.dtype == want.dtype
        assert got.tobytes() == want.tobytes()
