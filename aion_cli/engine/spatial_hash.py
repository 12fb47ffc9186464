"""Sparse spatial hash: exact, collision-free int64 keys for 3D grid cells.

A point ``p`` lies in cell ``floor(p / δ)`` (per axis). Each cell index is biased by 2^20 into
an unsigned 21-bit field and the three fields are packed z-major, then y, then x::

    key = (k + 2^20) << 42 | (j + 2^20) << 21 | (i + 2^20)

so keys are non-negative int64, unpack exactly, never collide, and sort deterministically
(by z, then y, then x — the paper's "global vector order"). Indices outside [-2^20, 2^20) and
non-finite coordinates raise :class:`CoordinateRangeError` instead of wrapping silently; callers
that must keep going (the mapper) use :func:`packable_mask` first and count the drops.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from aion_cli.engine.row_masks import all_columns
from aion_cli.engine.types import F64, I64, BoolA
from aion_cli.errors import CoordinateRangeError

BITS = 21
BIAS = 1 << (BITS - 1)
INDEX_MIN = -BIAS
INDEX_MAX = BIAS - 1
_MASK = (1 << BITS) - 1
_AXES = ("x", "y", "z")


def pack_keys(ijk: npt.ArrayLike) -> I64:
    """Pack integer cell indices int64[n,3] into int64[n] keys (exact, order-preserving)."""
    idx = np.asarray(ijk)
    if idx.ndim != 2 or idx.shape[1] != 3:
        raise ValueError(f"cell indices must have shape (n, 3), got {idx.shape}")
    if idx.size and not np.issubdtype(idx.dtype, np.integer):
        raise CoordinateRangeError("cell indices must be integers", hint="use cell_indices()")
    idx = idx.astype(np.int64, copy=False)
    _check_index_range(idx)
    return pack_keys_unchecked(idx)


def pack_keys_unchecked(ijk: I64) -> I64:
    """:func:`pack_keys` for int64[n,3] indices the caller already knows are in range."""
    biased = ijk + BIAS
    out: I64 = (biased[:, 2] << (2 * BITS)) | (biased[:, 1] << BITS) | biased[:, 0]
    return out


def unpack_keys(keys: npt.ArrayLike) -> I64:
    """Inverse of :func:`pack_keys`: int64[n] keys -> int64[n,3] cell indices."""
    k = np.asarray(keys, dtype=np.int64).reshape(-1)
    if np.any(k < 0) or np.any(k >= (1 << (3 * BITS))):
        raise CoordinateRangeError("spatial-hash key outside the packable range")
    out = np.empty((len(k), 3), dtype=np.int64)
    out[:, 0] = (k & _MASK) - BIAS
    out[:, 1] = ((k >> BITS) & _MASK) - BIAS
    out[:, 2] = ((k >> (2 * BITS)) & _MASK) - BIAS
    return out


def packable_mask(xyz: npt.ArrayLike, cell_size: float) -> BoolA:
    """True for rows whose three coordinates are finite and inside the packable range."""
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    with np.errstate(invalid="ignore", over="ignore"):
        scaled = np.floor(p / cell_size)
        ok = np.isfinite(scaled) & (scaled >= INDEX_MIN) & (scaled <= INDEX_MAX)
    return all_columns(ok)


def hashable_indices(xyz: npt.ArrayLike, cell_size: float) -> tuple[I64, BoolA, BoolA]:
    """Cell indices of many points without raising: ``(ijk, finite, in_range)``.

    ``ijk`` is ``floor(p / δ)`` where both masks hold and 0 elsewhere; ``finite`` flags rows
    with three finite coordinates, ``in_range`` finite rows inside the packable range. One
    pass with a fast path for the usual batch where every row is fine.
    """
    _check_cell_size(cell_size)
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    with np.errstate(invalid="ignore", over="ignore"):
        scaled = np.floor(p / cell_size)
    n = len(p)
    if n and scaled.min() >= INDEX_MIN and scaled.max() <= INDEX_MAX:  # NaN fails both
        ok = np.ones(n, dtype=bool)
        return scaled.astype(np.int64), ok, ok
    finite: BoolA = all_columns(np.isfinite(p))
    with np.errstate(invalid="ignore"):
        inside = all_columns((scaled >= INDEX_MIN) & (scaled <= INDEX_MAX))
    in_range: BoolA = finite & inside
    ijk = np.where(in_range[:, None], scaled, 0.0).astype(np.int64)
    return ijk, finite, in_range


def cell_indices(
    xyz: npt.ArrayLike, cell_size: float, name_of: Callable[[int], str] | None = None
) -> I64:
    """``floor(p / δ)`` per axis as int64[n,3]; :class:`CoordinateRangeError` if unpackable,
    naming the point by ``name_of(row)`` (default: its row)."""
    _check_cell_size(cell_size)
    p = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    with np.errstate(invalid="ignore", over="ignore"):
        scaled = np.floor(p / cell_size)
    bad = ~(np.isfinite(scaled) & (scaled >= INDEX_MIN) & (scaled <= INDEX_MAX))
    if bad.any():
        row, axis = np.argwhere(bad)[0]
        lo, hi = INDEX_MIN * cell_size, (INDEX_MAX + 1) * cell_size
        what = f"(row {row})" if name_of is None else f"of {name_of(int(row))}"
        raise CoordinateRangeError(
            f"coordinate {_AXES[axis]}={float(p[row, axis])!r} {what} cannot be hashed: "
            f"the packable range is [{lo:.6g}, {hi:.6g}) m for cell size {cell_size} m",
            hint="check the map frame and units of the input, or use a larger cell_size",
        )
    return scaled.astype(np.int64)


def keys_for_points(xyz: npt.ArrayLike, cell_size: float) -> I64:
    """Hash keys of the cells containing each point."""
    return pack_keys(cell_indices(xyz, cell_size))


def cell_centres(keys: npt.ArrayLike, cell_size: float) -> F64:
    """Centres ``(ijk + 0.5) δ`` of the cells with the given keys, float64[n,3]."""
    _check_cell_size(cell_size)
    centres: F64 = (unpack_keys(keys).astype(np.float64) + 0.5) * cell_size
    return centres


def _check_index_range(idx: I64) -> None:
    bad = (idx < INDEX_MIN) | (idx > INDEX_MAX)
    if bad.any():
        row, axis = np.argwhere(bad)[0]
        raise CoordinateRangeError(
            f"cell index {_AXES[axis]}={idx[row, axis]} (row {row}) is outside the packable "
            f"range [{INDEX_MIN}, {INDEX_MAX}]"
        )


def _check_cell_size(cell_size: float) -> None:
    if not (np.isfinite(cell_size) and cell_size > 0):
        raise CoordinateRangeError(f"cell size must be a positive number, got {cell_size!r}")
