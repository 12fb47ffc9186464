"""``stored_layout.nonzero_pairs``: the (entry, value bin) pairs a map stores are those of
the entries written whose profile counts are not all zero, in the entries' order (stop 70:
found over the state's whole array in place instead of over a gathered copy), checked
against a plain loop over the pairs, with entries in any order and rows never written."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.temporal import stored_layout
from aion_cli.engine.temporal.stored_layout import nonzero_pairs


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), capacity=st.integers(1, 40),
       values=st.integers(1, 5), bins=st.integers(1, 6), block=st.integers(1, 4))
def test_nonzero_pairs_are_the_pairs_holding_a_count(
    seed: int, capacity: int, values: int, bins: int, block: int
) -> None:
    rng = np.random.default_rng(seed)
    profile = rng.integers(0, 3, (capacity, values, bins)).astype(np.float64)
    profile[rng.random((capacity, values, bins)) < 0.6] = 0.0  # pairs all zero, some
    profile[rng.random(capacity) < 0.2] = np.nan  # a row that is not written may hold anything
    rows = rng.permutation(capacity)[: int(rng.integers(0, capacity + 1))]
    profile[rows] = np.nan_to_num(profile[rows])
    positions, state_rows = [], []
    for k, row in enumerate(rows):
        for v in range(values):
            if any(profile[row, v, h] != 0 for h in range(bins)):
                positions.append(k * values + v)
                state_rows.append(row * values + v)
    old_block = stored_layout.ROW_BLOCK
    stored_layout.ROW_BLOCK = block  # several blocks of the whole array
    try:
        pairs = nonzero_pairs(profile.reshape(-1, bins), rows.astype(np.int64), values)
    finally:
        stored_layout.ROW_BLOCK = old_block
    assert pairs.positions.dtype == pairs.rows.dtype == np.int64
    assert pairs.positions.tolist() == positions
    assert pairs.rows.tolist() == state_rows
