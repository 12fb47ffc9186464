"""``engine.row_sums.row_sums`` equals numpy's ``sum(axis=1)`` to the bit.

The temporal model's scores and forecasts are compared bit for bit between builds (a parallel
build against a sequential one, a map continued against one built at once), and some of its
row sums are still numpy's: the faster sums must add in numpy's very order, or the same
quantity computed in two places would differ in its last bits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from aion_cli.engine.row_sums import row_sums

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=300, deadline=None)
@given(
    hnp.arrays(
        np.float64, hnp.array_shapes(min_dims=2, max_dims=2, max_side=40), elements=finite
    )
)
def test_any_finite_array_sums_as_numpy_does(a: np.ndarray) -> None:
    with np.errstate(over="ignore", invalid="ignore"):  # huge values overflow in both
        expected = a.sum(axis=1)
        got = row_sums(a)
    assert got.dtype == np.float64
    assert got.shape == expected.shape
    assert got.tobytes() == expected.tobytes()


@pytest.mark.parametrize("width", [*range(1, 40), 63, 64, 65, 127, 128, 129, 300])
def test_widths_around_numpy_block_sizes(width: int) -> None:
    """Every width up to the 8-wide unrolled loop and past it, the 128-element pairwise block
    (and beyond, where numpy itself sums), on values of very different magnitudes (where the
    order of additions shows in the last bits)."""
    rng = np.random.default_rng(width)
    a = rng.standard_normal((500, width)) * 10.0 ** rng.uniform(-8, 8, (500, width))
    for view in (a, a[:, ::-1], a[::2]):  # contiguous, reversed columns, every other row
        assert row_sums(view).tobytes() == view.sum(axis=1).tobytes()
        kept = row_sums(view, keepdims=True)
        assert kept.tobytes() == view.sum(axis=1, keepdims=True).tobytes()
        assert kept.shape == (view.shape[0], 1)


def test_order_matters_and_is_numpys() -> None:
    """Values where a left-to-right sum differs from numpy's pairwise one: the test above would
    fail for a plain column-by-column sum."""
    a = np.array([[1e16, 1.0, -1e16, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]])
    left_to_right = 0.0
    for x in a[0]:
        left_to_right += x
    assert left_to_right != a.sum(axis=1)[0]
    assert row_sums(a)[0] == a.sum(axis=1)[0]


def test_signed_zeros_and_specials() -> None:
    a = np.array(
        [
            [-0.0] * 9,
            [-0.0, 0.0, -0.0],
            [np.inf, 1.0, -np.inf],
            [np.nan, 1.0, 2.0],
            [np.inf] * 12,
        ],
        dtype=object,
    )
    for row in a:
        values = np.asarray([row], dtype=np.float64)
        with np.errstate(invalid="ignore"):  # inf - inf
            expected, got = values.sum(axis=1), row_sums(values)
        assert np.array_equal(np.signbit(got), np.signbit(expected))
        assert np.array_equal(got, expected, equal_nan=True)


def test_other_dtypes_and_shapes_go_to_numpy() -> None:
    ints = np.arange(12, dtype=np.uint16).reshape(3, 4)
    assert row_sums(ints).dtype == ints.sum(axis=1).dtype  # numpy widens small ints
    assert np.array_equal(row_sums(ints), ints.sum(axis=1))
    single = np.arange(5.0).reshape(5, 1)
    assert np.array_equal(row_sums(single), single.sum(axis=1))
    empty = np.zeros((0, 8))
    assert row_sums(empty).shape == (0,)


@pytest.mark.parametrize("width", [2, 3, 8, 9, 31, 128])
@pytest.mark.parametrize("block_bytes", [8, 8 * 40 * 8 + 8, 1 << 19])
def test_tall_arrays_summed_in_blocks_of_rows(
    width: int, block_bytes: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Arrays taller than a block of rows (one row a block, blocks that do not divide the
    rows, the default 512 KiB) sum as numpy does, every row including the last partial
    block's; views of every other row and of reversed columns too."""
    import aion_cli.engine.row_sums as module

    monkeypatch.setattr(module, "_BLOCK_BYTES", block_bytes)
    rng = np.random.default_rng(width)
    rows = 3 * (1 << 19) // (8 * width) + 7  # three default blocks and a part
    a = rng.standard_normal((rows, width)) * 10.0 ** rng.uniform(-8, 8, (rows, width))
    if block_bytes == 8:
        a = a[:301]  # a block per row: keep it short
    for view in (a, a[:, ::-1], a[::2]):
        assert row_sums(view).tobytes() == view.sum(axis=1).tobytes()
        kept = row_sums(view, keepdims=True)
        assert kept.tobytes() == view.sum(axis=1, keepdims=True).tobytes()
        assert kept.shape == (view.shape[0], 1)
