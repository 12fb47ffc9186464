"""Issue 15, a query's load of a big map: the entry members a query reads become the entry
store's arrays as they are (no copy), loaded exactly as a copy-load gives them, and a store
that grows afterwards copies them, leaving the members alone; the finiteness checks prove a
member finite by its sum and still find a NaN or an infinity (hypothesis)."""

from __future__ import annotations

import warnings

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.entries import CELL, EntryStore
from aion_cli.engine.state import MapState
from aion_cli.engine.state_checks import first_row_over
from aion_cli.engine.temporal.stored_layout import all_finite, first_nonfinite
from aion_cli.formats.mapfile import open_map, write_map

_NAMES = ("kind", "key", "node_id", "xyz", "counts", "window_counts", "speed_sum", "speed_n",
          "heading_cos", "heading_sin", "nodir", "window_nodir")


def _members(n: int, seed: int = 1) -> dict[str, np.ndarray]:
    """The entry members of ``n`` cells with random whole counts, some in the open window."""
    rng = np.random.default_rng(seed)
    store = EntryStore.empty(8, capacity=2)
    store.allocate(CELL, np.arange(n, dtype=np.int64) * 7, np.zeros(n, np.uint64),
                   rng.normal(size=(n, 3)))
    rows = rng.integers(0, n, 5 * n)
    bins = rng.integers(-1, 8, rows.size)
    store.accumulate(rows, bins, rng.uniform(0.5, 2.0, rows.size),
                     rng.uniform(-np.pi, np.pi, rows.size))
    store.clear_window()
    few = rng.integers(0, n, 7)
    store.accumulate(few, rng.integers(0, 8, few.size), np.full(few.size, 1.0))
    return store.to_arrays(store.canonical_order())


def _same(a: EntryStore, b: EntryStore) -> None:
    assert a.n == b.n
    for name in (*_NAMES, "window_mark"):
        np.testing.assert_array_equal(getattr(a, name)[: a.n], getattr(b, name)[: b.n])
    np.testing.assert_array_equal(a.window_rows(), b.window_rows())


def test_adopted_members_are_the_store_arrays_and_load_as_copies_do() -> None:
    members = _members(300)
    copied = EntryStore.from_arrays({k: v.copy() for k, v in members.items()}, 8)
    adopted = EntryStore.from_arrays(members, 8, adopt=True)
    for name in _NAMES:
        assert getattr(adopted, name) is members[f"entry_{name}"]
        assert not np.shares_memory(getattr(copied, name), members[f"entry_{name}"])
    assert adopted.capacity == 300
    assert copied.capacity == 300
    assert 0 < int(adopted.window_mark.sum()) <= 7
    _same(adopted, copied)


def test_a_grown_store_copies_what_it_adopted() -> None:
    members = _members(100)
    before = {k: v.copy() for k, v in members.items()}
    store = EntryStore.from_arrays(members, 8, adopt=True)
    rows = store.allocate(CELL, np.array([10**6, 10**6 + 1]), np.zeros(2, np.uint64),
                          np.zeros((2, 3)))
    np.testing.assert_array_equal(rows, [100, 101])
    assert store.capacity == 200
    store.accumulate(np.array([0, 100, 101]), np.array([1, 2, 3]), np.full(3, 1.0))
    for name in _NAMES:  # the members read are as they were
        np.testing.assert_array_equal(members[f"entry_{name}"], before[f"entry_{name}"])
    assert store.counts[0, 1] == before["entry_counts"][0, 1] + 1
    assert store.counts[100, 2] == 1.0
    assert store.kind[101] == CELL


def test_members_that_cannot_be_adopted_are_copied() -> None:
    small = _members(40)  # fewer than 64 rows: room is reserved as before
    store = EntryStore.from_arrays(small, 8, adopt=True)
    assert store.capacity == 64
    assert not np.shares_memory(store.counts, small["entry_counts"])
    for change in ("readonly", "dtype", "strided"):
        members = _members(120, seed=2)
        reference = EntryStore.from_arrays({k: v.copy() for k, v in members.items()}, 8)
        if change == "readonly":
            members["entry_speed_n"].flags.writeable = False
        elif change == "dtype":
            members["entry_nodir"] = members["entry_nodir"].astype(np.float32)
            reference = EntryStore.from_arrays({k: v.copy() for k, v in members.items()}, 8)
        else:
            members["entry_counts"] = np.asfortranarray(members["entry_counts"])
        store = EntryStore.from_arrays(members, 8, adopt=True)
        assert not any(np.shares_memory(getattr(store, n), members[f"entry_{n}"])
                       for n in _NAMES), change
        _same(store, reference)


def test_a_query_load_of_a_map_keeps_its_entry_members_and_a_writable_load_copies(
    tmp_path: object,
) -> None:
    from pathlib import Path

    path = Path(str(tmp_path)) / "m.aion"
    state = MapState.empty(ModelConfig())
    members = _members(200)
    entries = EntryStore.from_arrays(members, state.config.bins)
    state.allocate(CELL, entries.key[:200], entries.node_id[:200], entries.xyz[:200])
    arrays, meta = state.to_arrays()
    arrays.update(members)
    meta["accepted"] = int(members["entry_counts"].sum() + members["entry_nodir"].sum())
    write_map(path, arrays, {"state": meta})
    with open_map(path, in_place=True) as read:
        query = MapState.from_arrays(read, meta, writable=False, copy=False)
        assert query.entries.counts is read["entry_counts"]
    with open_map(path) as read:
        kept = MapState.from_arrays(read, meta, writable=True, copy=False)
        assert not np.shares_memory(kept.entries.counts, read["entry_counts"])
    _same(query.entries, kept.entries)


@settings(max_examples=80, deadline=None)
@given(
    st.lists(st.sampled_from([0.0, 1.5, -2.0, 1e308, -1e308, np.nan, np.inf, -np.inf]),
             min_size=0, max_size=12),
    st.sampled_from(["f8", "c16", "f4"]),
)
def test_all_finite_is_numpy_isfinite_all(values: list[float], dtype: str) -> None:
    """1e308 twice overflows the sum to infinity: the values are still all finite."""
    with np.errstate(over="ignore", invalid="ignore"):
        a = np.array(values, dtype=dtype)
    expected = bool(np.isfinite(a).all())
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a map's check says what is wrong, nothing else
        assert all_finite(a) is expected
    assert all_finite(a.reshape(-1, 1)) is expected
    assert first_nonfinite({"a": a}) == ([] if expected else ["a"])


def test_integers_are_finite() -> None:
    assert all_finite(np.array([2**63 - 1, 2**63 - 1], np.int64))  # its sum wraps around
    assert all_finite(np.zeros((0, 3)))
    assert all_finite(np.array([255, 255], np.uint8))


@settings(max_examples=60, deadline=None)
@given(
    st.integers(min_value=0, max_value=9000),
    st.lists(st.integers(min_value=0, max_value=8999), max_size=4),
    st.sampled_from([(), (3,)]),
)
def test_first_row_over_is_the_first_row_of_the_whole_comparison(
    n: int, bad: list[int], tail: tuple[int, ...]
) -> None:
    """Blocks of 4,096 rows: the first row found is the one the whole arrays' comparison
    finds, in any block (counts a little above their whole within the slack are not over)."""
    rng = np.random.default_rng(n)
    whole = rng.integers(0, 5, (n, *tail)).astype(np.float64)
    part = whole.copy()
    part += 1e-10  # within the slack
    for r in (r for r in bad if r < n):
        part[r] = whole[r] + 1.0
    over = part > whole + 1e-9
    rows = np.flatnonzero(over.reshape(n, -1).any(axis=1)) if n else np.zeros(0, np.int64)
    expected = int(rows[0]) if rows.size else None
    assert first_row_over(part, whole, 1e-9) == expected
