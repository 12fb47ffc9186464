"""Issue 15, per-batch costs: ``EntryStore.accumulate``'s path for batches whose every
detection has a heading and a speed gives exactly what the general code gave (a verbatim copy
of it below), bit for bit, on random inputs (hypothesis)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.entries import EntryStore
from aion_cli.engine.grouping import unique_inverse

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
