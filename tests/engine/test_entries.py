"""Entry store: paper bins, vectorized accumulation, free-row reuse, routing table."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.descriptors import bin_of
from aion_cli.engine.entries import CELL, FREE, NODE, EntryStore, direction_bins, held_detections
from aion_cli.engine.routing import RouteTable
from aion_cli.engine.spatial_hash import pack_keys
from aion_cli.engine.state import MapState
from aion_cli.errors import MapCorruptError


def _store(n: int, bins: int = 8) -> EntryStore:
    store = EntryStore.empty(bins, capacity=2)
    keys = np.arange(n, dtype=np.int64) * 10
    store.allocate(CELL, keys, np.zeros(n, np.uint64), np.zeros((n, 3)))
    return store


def test_direction_bins_follow_the_paper_convention() -> None:
    theta = np.array([-np.pi, -np.pi + 1e-9, -3 * np.pi / 4, 0.0, np.pi / 4 - 1e-9, np.pi - 1e-12])
    np.testing.assert_array_equal(direction_bins(theta, 8), [0, 0, 1, 4, 4, 7])
    np.testing.assert_array_equal(direction_bins(np.array([np.pi, np.nan]), 8), [0, -1])
    np.testing.assert_array_equal(direction_bins(np.array([0.1, -0.1]), 2), [1, 0])


def test_entry_row_e_is_accumulator_row_e_and_a_freed_row_is_forgotten() -> None:
    state = MapState.empty(ModelConfig())
    keys = np.arange(100, dtype=np.int64) * 10
    rows = state.allocate(CELL, keys, np.zeros(100, np.uint64), np.zeros((100, 3)))
    assert state.temporal.n_rows == state.entries.capacity >= 100
    tmp = state.temporal
    tmp.touch(rows)
    tmp.cnt_profile[rows, 0, 0] = rows  # mark each temporal row with its entry row
    tmp.obs.n[rows] = 1.0
    state.delete(rows[[3, 50]])
    assert tmp.cnt_profile[rows[[3, 50]]].sum() == 0
    assert tmp.obs.n[rows[[3, 50]]].sum() == 0
    again = state.allocate(NODE, np.full(2, -1, np.int64), np.array([7, 8], np.uint64),
                           np.zeros((2, 3)))
    np.testing.assert_array_equal(again, rows[[3, 50]])  # freed rows are reused ...
    assert tmp.cnt_profile[again].sum() == 0  # ... with empty temporal rows
    kept = np.setdiff1d(rows, rows[[3, 50]])
    np.testing.assert_array_equal(tmp.cnt_profile[kept, 0, 0], kept)
    more = state.allocate(CELL, np.arange(1, 200, dtype=np.int64) * 7 + 10_000,
                          np.zeros(199, np.uint64), np.zeros((199, 3)))
    assert state.temporal.n_rows == state.entries.capacity >= 301  # grown with the store
    np.testing.assert_array_equal(state.temporal.cnt_profile[kept, 0, 0], kept)  # kept
    assert state.temporal.cnt_profile[more].sum() == 0


@given(
    st.lists(
        st.tuples(st.integers(0, 29), st.integers(-1, 7), st.floats(0, 3) | st.just(np.nan)),
        min_size=1,
        max_size=200,
    )
)
@settings(max_examples=60, deadline=None)
def test_accumulate_matches_a_per_detection_reference(det: list[tuple[int, int, float]]) -> None:
    rows = np.array([d[0] for d in det], np.int64)
    bins = np.array([d[1] for d in det], np.int64)
    speed = np.array([d[2] for d in det])
    for n_entries in (30, 3000):  # dense and sparse histogram paths
        store = _store(n_entries)
        store.accumulate(rows, bins, speed)
        counts = np.zeros((n_entries, 8))
        nodir = np.zeros(n_entries)
        ssum = np.zeros((n_entries, 8))
        sn = np.zeros((n_entries, 8))
        for r, b, s in det:
            if b < 0:
                nodir[r] += 1
                continue
            counts[r, b] += 1
            if np.isfinite(s):
                ssum[r, b] += s
                sn[r, b] += 1
        np.testing.assert_array_equal(store.counts[:n_entries], counts)
        np.testing.assert_array_equal(store.window_counts[:n_entries], counts)
        np.testing.assert_array_equal(store.nodir[:n_entries], nodir)
        np.testing.assert_allclose(store.speed_sum[:n_entries], ssum)
        np.testing.assert_array_equal(store.speed_n[:n_entries], sn)
        assert store.total_count() == len(det)


def test_clear_window_keeps_cumulative_counts() -> None:
    store = _store(2)
    store.accumulate(np.array([0, 1, 1]), np.array([3, -1, 5]), np.full(3, 1.0))
    np.testing.assert_array_equal(store.window_totals(np.array([0, 1])), [1, 2])
    store.clear_window()
    np.testing.assert_array_equal(store.window_totals(np.array([0, 1])), [0, 0])
    assert store.total_count() == 3


def test_held_detections_counts_directed_and_undirected_of_any_entries() -> None:
    """One sum for an entry's detections, for a store and for entries that are not one (the
    DSG export's checks are given such entries: a method of the store failed there)."""
    from types import SimpleNamespace

    from aion_cli.mapquery import entries_with_detections

    store = _store(4)
    # row 0: two directed; row 1: one undirected; row 2: one of each; row 3: none
    store.accumulate(np.array([0, 0, 1, 2, 2]), np.array([1, 6, -1, 3, -1]), np.full(5, 1.0))
    store.clear_window()  # the cumulative counts, not the open window's
    rows = np.array([3, 2, 1, 0])
    np.testing.assert_array_equal(held_detections(store, rows), [0, 2, 1, 2])
    assert held_detections(store, slice(0, 4)).sum() == store.total_count() == 5
    plain = SimpleNamespace(counts=store.counts[:4].copy(), nodir=store.nodir[:4].copy())
    np.testing.assert_array_equal(held_detections(plain, rows), [0, 2, 1, 2])
    assert entries_with_detections(store, rows) == entries_with_detections(plain, rows) == 3


def test_delete_frees_rows_for_reuse_and_grows_by_doubling() -> None:
    store = _store(5)
    assert store.capacity == 8
    store.accumulate(np.array([1, 3]), np.array([0, 0]), np.array([1.0, 1.0]))
    store.delete(np.array([3, 1]))
    np.testing.assert_array_equal(store.live_rows(), [0, 2, 4])
    assert store.kind[1] == FREE
    assert store.counts[1].sum() == 0
    ids = np.arange(1, 5, dtype=np.uint64)
    rows = store.allocate(NODE, np.full(4, -1, np.int64), ids, np.zeros((4, 3)))
    np.testing.assert_array_equal(rows, [1, 3, 5, 6])
    assert store.counts[rows].sum() == 0
    assert store.n == 7
    assert store.capacity == 8


def test_add_into_adds_counts_speeds_and_the_open_window() -> None:
    store = _store(3)
    store.accumulate(np.array([0, 0, 1, 2]), np.array([1, 2, 1, -1]), np.full(4, 2.0))
    store.add_into(np.array([0, 1]), np.array([2, 2]))
    np.testing.assert_array_equal(store.counts[2, :3], [0, 2, 1])
    np.testing.assert_array_equal(store.window_counts[2, :3], [0, 2, 1])
    np.testing.assert_array_equal(store.speed_sum[2, :3], [0, 4, 2])
    np.testing.assert_array_equal(store.speed_n[2, :3], [0, 2, 1])
    assert store.nodir[2] == 1
    assert store.window_nodir[2] == 1


def test_canonical_order_and_array_round_trip() -> None:
    store = EntryStore.empty(4)
    store.allocate(NODE, np.array([-1, -1]), np.array([9, 3], np.uint64), np.ones((2, 3)))
    store.allocate(CELL, np.array([50, 7]), np.zeros(2, np.uint64), np.zeros((2, 3)))
    order = store.canonical_order()
    np.testing.assert_array_equal(order, [3, 2, 1, 0])
    again = EntryStore.from_arrays(store.to_arrays(order), 4)
    np.testing.assert_array_equal(again.key[: again.n], [7, 50, -1, -1])
    np.testing.assert_array_equal(again.node_id[: again.n], [0, 0, 3, 9])


def test_from_arrays_rejects_inconsistent_members() -> None:
    store = _store(3)
    arrays = store.to_arrays(store.canonical_order())
    arrays["entry_counts"] = arrays["entry_counts"][:, :2]
    with pytest.raises(MapCorruptError, match="counts"):
        EntryStore.from_arrays(arrays, 8)
    del arrays["entry_kind"]
    with pytest.raises(MapCorruptError):
        EntryStore.from_arrays(arrays, 8)


def test_route_table_lookup_and_insert() -> None:
    table = RouteTable.build(np.array([30, 10, 20]), np.array([3, 1, 2]))
    rows, found = table.lookup(np.array([20, 25, 10, 99]))
    np.testing.assert_array_equal(found, [True, False, True, False])
    np.testing.assert_array_equal(rows, [2, -1, 1, -1])
    table.insert(np.array([5, 25]), np.array([7, 8]))
    np.testing.assert_array_equal(table.keys, [5, 10, 20, 25, 30])
    np.testing.assert_array_equal(table.lookup(np.array([25, 5]))[0], [8, 7])
    assert RouteTable().lookup(np.array([1]))[1].tolist() == [False]


@given(st.lists(st.floats(-10, 10) | st.just(np.pi) | st.just(np.nan), min_size=1, max_size=50))
@settings(max_examples=100)
def test_direction_bins_fast_path_agrees_with_the_general_rule(theta: list[float]) -> None:
    th = np.array(theta)
    finite_in_range = th[np.isfinite(th) & (th >= -np.pi) & (th < np.pi)]
    expected = np.floor((finite_in_range + np.pi) / (2 * np.pi / 8)).astype(np.int64) % 8
    np.testing.assert_array_equal(direction_bins(finite_in_range, 8), expected)
    np.testing.assert_array_equal(direction_bins(th, 8), bin_of(th, 8))


@given(
    st.lists(st.tuples(st.integers(-30, 30), st.integers(-30, 30), st.integers(-2, 2)),
             min_size=1, max_size=300, unique=True),
    st.integers(0, 2**31),
    st.sampled_from([5000, 300]),  # dense-grid path and binary-search path
)
@settings(max_examples=40, deadline=None)
def test_route_finds_known_cells_and_creates_each_new_cell_once(
    cells: list[tuple[int, int, int]], seed: int, n: int
) -> None:
    rng = np.random.default_rng(seed)
    table_ijk = np.array(cells, np.int64)
    known = pack_keys(table_ijk)
    table = RouteTable.build(known, np.arange(len(cells), dtype=np.int64))
    query = np.c_[rng.integers(-35, 35, (n, 2)), rng.integers(-3, 3, n)]
    query[: min(n, len(cells))] = table_ijk[: min(n, len(cells))]
    keys = pack_keys(query)
    created: list[np.ndarray] = []

    def create(new_keys: np.ndarray) -> np.ndarray:
        assert np.all(np.diff(new_keys) > 0)  # sorted and distinct
        assert not np.isin(new_keys, known).any()
        created.append(new_keys)
        return 1000 + np.arange(len(new_keys), dtype=np.int64)

    rows = table.route(keys, query, create)
    assert len(created) <= 1
    new_keys = created[0] if created else np.zeros(0, np.int64)
    np.testing.assert_array_equal(new_keys, np.setdiff1d(keys, known))
    order = np.argsort(known)  # a known key's row is its position in ``cells``
    pos = np.searchsorted(known[order], keys).clip(0, len(known) - 1)
    is_known = known[order][pos] == keys
    expected = np.where(is_known, order[pos], 1000 + np.searchsorted(new_keys, keys))
    np.testing.assert_array_equal(rows, expected)
    again, found = table.lookup(keys)
    assert found.all()
    np.testing.assert_array_equal(again, rows)
