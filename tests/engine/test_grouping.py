"""Grouping by key: every index once, equal keys together, each group in its own order."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from aion_cli.engine.grouping import (
    contained,
    cut_by_key,
    distinct,
    lexicographic_ranks,
    split_by_key,
)

KEYS = st.lists(st.integers(min_value=-5, max_value=5), max_size=60)


@given(KEYS)
def test_split_by_key_groups_equal_keys_in_order(values: list[int]) -> None:
    keys = np.asarray(values, dtype=np.int64)
    groups = split_by_key(keys)
    assert sorted(np.concatenate(groups).tolist() if groups else []) == list(range(keys.size))
    assert [int(keys[g[0]]) for g in groups] == sorted(set(values))
    for g in groups:
        assert np.all(keys[g] == keys[g[0]])
        assert np.all(np.diff(g) > 0)  # the rows' own order within a group


@given(KEYS)
def test_cut_by_key_slices_every_bound_even_empty_ones(values: list[int]) -> None:
    keys = np.asarray(values, dtype=np.int64)
    bounds = np.arange(-6, 8, 2)  # groups [-6,-4), [-4,-2), ... [4,6); some empty
    order, cut = cut_by_key(keys, bounds)
    for k in range(bounds.size - 1):
        part = order[cut[k] : cut[k + 1]]
        expect = np.flatnonzero((keys >= bounds[k]) & (keys < bounds[k + 1]))
        np.testing.assert_array_equal(np.sort(part), expect)
        for key in np.unique(keys[part]).tolist():  # equal keys keep their own order
            assert np.all(np.diff(part[keys[part] == key]) > 0)


@given(
    st.lists(
        st.tuples(st.integers(0, 1), st.integers(-3, 3), st.integers(-2**62, 2**62)),
        max_size=60,
    )
)
def test_lexicographic_ranks_equal_unique_rows(rows: list[tuple[int, int, int]]) -> None:
    """The group numbering equals ``np.unique(axis=0)``'s inverse and count, signed keys
    included."""
    keys = np.array(rows, dtype=np.int64).reshape(-1, 3)
    inverse, count = lexicographic_ranks(keys)
    if len(keys) == 0:
        assert count == 0
        return
    distinct, expected = np.unique(keys, axis=0, return_inverse=True)
    np.testing.assert_array_equal(inverse, expected.reshape(-1))
    assert count == len(distinct)


@given(KEYS, KEYS, st.booleans())
def test_contained_equals_numpy_isin(values: list[int], queries: list[int], ordered: bool) -> None:
    """Sorted values (a map's keys, read back) and any others (sorted first) alike."""
    v = np.asarray(sorted(values) if ordered else values, dtype=np.int64)
    q = np.asarray(queries, dtype=np.int64)
    np.testing.assert_array_equal(contained(v, q), np.isin(q, v))
    unsigned = np.asarray([x + 5 for x in values], dtype=np.uint64)  # node ids are uint64
    q_unsigned = np.asarray([x + 5 for x in queries], dtype=np.uint64)
    np.testing.assert_array_equal(contained(unsigned, q_unsigned), np.isin(q_unsigned, unsigned))


@given(KEYS, st.sampled_from([0, 1 << 20, -(1 << 40)]))
def test_distinct_equals_numpy_unique(values: list[int], offset: int) -> None:
    """Narrow keys (the bitmap) and keys spread far apart (the sort) alike."""
    keys = np.asarray(values, dtype=np.int64)
    spread = np.concatenate([keys, keys + offset])
    for k in (keys, spread):
        got = distinct(k)
        assert got.dtype == k.dtype
        np.testing.assert_array_equal(got, np.unique(k))

