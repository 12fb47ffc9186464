"""engine.hierarchy.aggregate: sums per parent, parent 0 skipped."""

from __future__ import annotations

import numpy as np

from aion_cli.engine.hierarchy import aggregate


def test_sums_per_parent_and_skips_parent_zero() -> None:
    room_a, room_b = (ord("R") << 56) | 7, (ord("R") << 56) | 2
    parent = np.array([room_a, 0, room_b, room_a, room_b, 0], dtype=np.uint64)
    values = np.arange(12, dtype=float).reshape(6, 2)  # rows: [0,1] [2,3] [4,5] [6,7] [8,9] ..
    ids, sums = aggregate(parent, values)
    assert ids.dtype == np.uint64
    assert ids.tolist() == [room_b, room_a]  # increasing id order
    np.testing.assert_array_equal(sums, [[4 + 8, 5 + 9], [0 + 6, 1 + 7]])


def test_one_dimensional_values_and_no_parents() -> None:
    ids, sums = aggregate(np.array([3, 3, 3], np.uint64), np.array([1.0, 2.0, 4.5]))
    assert ids.tolist() == [3]
    assert sums.tolist() == [7.5]
    ids, sums = aggregate(np.zeros(2, np.uint64), np.ones((2, 8)))
    assert ids.size == 0
    assert sums.shape == (0, 8)
