"""Spatial hash keys: exact packing, ordering, and clear errors instead of silent wraps."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from aion_cli.engine.spatial_hash import (
    INDEX_MAX,
    INDEX_MIN,
    cell_centres,
    cell_indices,
    hashable_indices,
    keys_for_points,
    pack_keys,
    packable_mask,
    unpack_keys,
)
from aion_cli.errors import CoordinateRangeError

index_arrays = arrays(
    np.int64, st.tuples(st.integers(1, 40), st.just(3)), elements=st.integers(INDEX_MIN, INDEX_MAX)
)


@given(index_arrays)
@settings(max_examples=200)
def test_pack_unpack_round_trip(ijk: np.ndarray) -> None:
    np.testing.assert_array_equal(unpack_keys(pack_keys(ijk)), ijk)


@given(index_arrays)
@settings(max_examples=200)
def test_distinct_cells_get_distinct_keys(ijk: np.ndarray) -> None:
    keys = pack_keys(ijk)
    assert len(np.unique(keys)) == len(np.unique(ijk, axis=0))
    assert np.all(keys >= 0)


@given(index_arrays)
@settings(max_examples=100)
def test_keys_sort_like_z_y_x_tuples(ijk: np.ndarray) -> None:
    by_key = ijk[np.argsort(pack_keys(ijk), kind="stable")]
    by_tuple = ijk[np.lexsort((ijk[:, 0], ijk[:, 1], ijk[:, 2]))]
    np.testing.assert_array_equal(by_key, by_tuple)


def test_known_key_layout() -> None:
    bias = 1 << 20
    key = pack_keys(np.array([[1, -2, 3]]))[0]
    assert key == ((3 + bias) << 42) | ((-2 + bias) << 21) | (1 + bias)
    assert pack_keys(np.array([[INDEX_MIN] * 3]))[0] == 0


def test_cell_indices_floor_negative_coordinates() -> None:
    idx = cell_indices(np.array([[-0.01, 0.0, 0.49], [0.5, -0.5, -0.51]]), 0.5)
    np.testing.assert_array_equal(idx, [[-1, 0, 0], [1, -1, -2]])


def test_cell_centres_contain_their_points() -> None:
    pts = np.array([[1.2, -3.7, 0.1], [-100.26, 5.0, 2.2]])
    centres = cell_centres(keys_for_points(pts, 0.5), 0.5)
    assert np.all(np.abs(centres - pts) <= 0.25)
    np.testing.assert_allclose(centres[0], [1.25, -3.75, 0.25])


def test_out_of_range_coordinate_names_axis_and_range_in_metres() -> None:
    pts = np.array([[0.0, 0.0, 0.0], [0.0, 1e6, 0.0]])
    with pytest.raises(CoordinateRangeError) as err:
        keys_for_points(pts, 0.5)
    msg = str(err.value)
    assert "y=" in msg
    assert "1000000" in msg
    assert "[-524288, 524288) m" in msg


def test_non_finite_coordinate_is_an_error() -> None:
    with pytest.raises(CoordinateRangeError, match="x=nan"):
        keys_for_points(np.array([[np.nan, 0.0, 0.0]]), 0.5)
    with pytest.raises(CoordinateRangeError, match="z=inf"):
        keys_for_points(np.array([[0.0, 0.0, np.inf]]), 0.5)


def test_index_outside_21_bits_is_an_error_not_a_wrap() -> None:
    with pytest.raises(CoordinateRangeError, match="outside the packable range"):
        pack_keys(np.array([[INDEX_MAX + 1, 0, 0]]))
    with pytest.raises(CoordinateRangeError):
        unpack_keys(np.array([-5]))


def test_packable_mask_flags_exactly_the_bad_rows() -> None:
    pts = np.array([[0, 0, 0], [np.nan, 0, 0], [0, -524288.0, 0], [0, -524288.5, 0], [1e300, 0, 0]])
    np.testing.assert_array_equal(packable_mask(pts, 0.5), [True, False, True, False, False])


def test_bad_shapes_and_cell_size() -> None:
    with pytest.raises(ValueError, match="shape"):
        pack_keys(np.zeros((2, 2), np.int64))
    with pytest.raises(CoordinateRangeError, match="cell size"):
        cell_indices(np.zeros((1, 3)), 0.0)


def test_hashable_indices_masks_bad_rows_and_matches_cell_indices() -> None:
    good = np.array([[0.2, -0.7, 3.0], [1e5, 2.0, -1e5]])
    ijk, finite, ok = hashable_indices(good, 0.5)  # fast path
    np.testing.assert_array_equal(ijk, cell_indices(good, 0.5))
    assert finite.all()
    assert ok.all()
    mixed = np.array([[0.2, -0.7, 3.0], [np.nan, 0, 0], [1e9, 0, 0], [1e5, 2.0, -1e5]])
    ijk, finite, ok = hashable_indices(mixed, 0.5)
    np.testing.assert_array_equal(finite, [True, False, True, True])
    np.testing.assert_array_equal(ok, [True, False, False, True])
    np.testing.assert_array_equal(ijk[ok], cell_indices(good, 0.5))


def test_both_ends_of_the_index_range_are_packable_and_one_beyond_is_not() -> None:
    """Indices -2^20 and 2^20 − 1 are the packable range's ends, inclusive, on every axis and
    in every entry point (hashable_indices' fast path, all rows fine, and its slow path)."""
    d = 0.5
    lo, hi = INDEX_MIN * d, (INDEX_MAX + 1) * d  # the range in metres: [lo, hi)
    edge = np.array([[lo, 0.0, 0.0], [0.0, hi - d / 4, 0.0], [0.0, 0.0, hi - d], [lo, lo, lo]])
    beyond = np.array([[hi, 0.0, 0.0], [0.0, lo - d / 4, 0.0], [0.0, 0.0, hi + d]])
    expected = np.array([[INDEX_MIN, 0, 0], [0, INDEX_MAX, 0], [0, 0, INDEX_MAX],
                         [INDEX_MIN] * 3])  # fmt: skip
    np.testing.assert_array_equal(cell_indices(edge, d), expected)
    np.testing.assert_array_equal(unpack_keys(keys_for_points(edge, d)), expected)
    assert packable_mask(edge, d).all()
    assert not packable_mask(beyond, d).any()
    ijk, finite, ok = hashable_indices(edge, d)  # every row fine: the fast path
    np.testing.assert_array_equal(ijk, expected)
    assert ok.all()
    ijk, finite, ok = hashable_indices(np.vstack([edge, beyond]), d)  # the slow path
    np.testing.assert_array_equal(ok, [True] * 4 + [False] * 3)
    assert finite.all()
    np.testing.assert_array_equal(ijk[:4], expected)
    for row in beyond:
        with pytest.raises(CoordinateRangeError, match="cannot be hashed"):
            cell_indices(row[None, :], d)
    with pytest.raises(CoordinateRangeError, match="cell size"):
        cell_centres(keys_for_points(edge, d), 0.0)
