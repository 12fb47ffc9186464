"""How the temporal accumulators are stored in a map file: sparse, narrowed, and checked.

:meth:`~aion_cli.engine.temporal.accumulators.TemporalState.to_arrays` writes only the rows
and (entry, value bin) pairs that hold something, with integral tallies in the narrowest
exact unsigned type; :meth:`~aion_cli.engine.temporal.accumulators.TemporalState.from_arrays`
reads them back through the helpers here, which check every index and member (a map file is
untrusted input) and read the dense layout of older maps as a sparse one.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from aion_cli.engine.types import F64, I64, RowTake
from aion_cli.errors import MapCorruptError

ROW_BLOCK = 1 << 14
"""Rows gathered at a time when storing (bounded temporaries)."""
_UINT32_MAX = float(np.iinfo(np.uint32).max)


@dataclass(frozen=True)
class Pairs:
    """(entry, value bin) pairs: flat positions ``pos·V + v`` and flat state rows."""

    positions: I64
    rows: I64


def nonzero_pairs(flat_profile: F64, rows: I64, values: int) -> Pairs:
    """The (entry, value bin) pairs of ``rows`` whose profile counts are not all zero. Which
    rows of the state hold a count is found over the whole array where it lies, block by
    block, and looked up for ``rows`` (stop 70: gathering the pairs' counts first copied
    every count once, twice the time on the 10^5-entry benchmark state)."""
    held = np.empty(flat_profile.shape[0], np.bool_)
    step = ROW_BLOCK * values
    for a in range(0, held.size, step):
        np.any(flat_profile[a : a + step], axis=1, out=held[a : a + step])
    flat = (rows[:, None] * values + np.arange(values, dtype=np.int64)[None, :]).reshape(-1)
    keep = held[flat]
    return Pairs(np.flatnonzero(keep).astype(np.int64), flat[keep])


def narrowed(source: F64, rows: I64) -> RowTake:
    """``RowTake`` of ``source[rows]``, stored as the narrowest of uint8 / uint16 / uint32 that
    holds every value exactly when all are whole numbers (window tallies and detection counts
    are), else as float64."""
    top = 0.0
    for a in range(0, rows.size, ROW_BLOCK):
        block = source[rows[a : a + ROW_BLOCK]]
        if not block.size:
            continue
        if not (block.min() >= 0.0 and np.all(block == np.rint(block))):
            return RowTake(source, rows)
        top = max(top, float(block.max()))
    if top > _UINT32_MAX:
        return RowTake(source, rows)
    narrow = next(t for t in (np.uint8, np.uint16, np.uint32) if top <= np.iinfo(t).max)
    return RowTake(source, rows, cast=np.dtype(narrow))


def narrowest_whole(values: np.ndarray) -> np.ndarray:
    """``values`` as the narrowest of uint8 / uint16 / uint32 that holds each exactly when all
    are whole numbers >= 0 (indices, slots, detection counts), else unchanged: lossless,
    readers widen them (a robot's pending day holds one (entry, window) pair per place it saw
    in every window of the day, which int64 and float64 stored at eight bytes each)."""
    if values.size == 0:
        return values
    if not (values.min() >= 0 and np.all(values == np.rint(values))):
        return values
    top = float(values.max())
    for kind in (np.uint8, np.uint16, np.uint32):
        if top <= np.iinfo(kind).max:
            return values.astype(kind)
    return values


def stored_positions(index: I64, limit: int) -> I64:
    """A stored index as uint32 when every position fits (lossless: readers widen it), else
    int64."""
    return index.astype(np.uint32) if limit <= np.iinfo(np.uint32).max + 1 else index


def stored_index(arrays: Mapping[str, np.ndarray], name: str, limit: int) -> I64:
    """A stored index member: int64, strictly increasing, within [0, limit)."""
    if name not in arrays:
        raise MapCorruptError(f"temporal state incomplete, missing: {name}")
    value = np.asarray(arrays[name])
    if value.ndim != 1 or value.dtype.kind not in "iu":
        raise MapCorruptError(f"temporal member {name} must be a 1-D integer array")
    out = value.astype(np.int64)
    if out.size and (out[0] < 0 or out[-1] >= limit or np.any(np.diff(out) <= 0)):
        raise MapCorruptError(f"temporal member {name} holds positions out of order or range")
    return out


def stored_member(
    arrays: Mapping[str, np.ndarray],
    name: str,
    shape: tuple[int, ...],
    copy: bool = True,
    keep_narrow: bool = False,
) -> Any:
    """A stored temporal member as a float64/complex128 array of ``shape`` that the state
    may own and change: a copy, unless ``copy`` is False (the caller hands over freshly read
    arrays) and the member is already native, contiguous and writable. ``keep_narrow``: a
    member stored as unsigned integers stays so (a query's counts: exact, and widening the
    largest member to float64 would cost more than the rest of the query)."""
    if name not in arrays:
        raise MapCorruptError(f"temporal state incomplete, missing: {name}")
    value = np.asarray(arrays[name])
    if value.shape != shape or value.dtype.kind not in "fcu":
        raise MapCorruptError(
            f"temporal member {name} has shape {value.shape} and dtype {value.dtype}, "
            f"expected {shape}"
        )
    if keep_narrow and value.dtype.kind == "u" and value.dtype.isnative:
        return value if not copy and value.flags.writeable else np.array(value)
    if value.dtype != np.float64 and value.dtype.kind in "fu":
        return value.astype(np.float64)  # a fresh copy already
    if not copy and value.flags.writeable and value.flags.c_contiguous and value.dtype.isnative:
        return value  # a member freshly read from a map: no second copy
    return np.array(value)


def sparse_layout(
    arrays: Mapping[str, np.ndarray], prefix: str, rows: int, values: int
) -> Mapping[str, np.ndarray]:
    """The members in the sparse layout: a map written before the layout was sparse (format
    2.0 of aion before 2026-12-01: every row stored, ``cnt_fourier`` as [R, V, K], no
    ``*stored_index`` members) reads as one whose indices list every row and pair."""
    fourier = prefix + "cnt_fourier"
    if prefix + "obs_index" in arrays or fourier not in arrays:
        return arrays
    from collections import ChainMap

    dense: dict[str, np.ndarray] = {
        prefix + "obs_index": np.arange(rows, dtype=np.int64),
        prefix + "cnt_index": np.arange(rows * values, dtype=np.int64),
        prefix + "score_index": np.arange(rows, dtype=np.int64),
    }
    for name in (fourier, prefix + "cnt_profile"):
        value = np.asarray(arrays[name])
        if value.ndim == 3 and value.shape[:2] == (rows, values):
            dense[name] = value.reshape(rows * values, value.shape[2])
    # reads go through to ``arrays`` (a lazily read map stays lazy)
    return ChainMap(dense, cast(dict[str, np.ndarray], arrays))


def lists_all(index: I64, size: int) -> bool:
    """Whether a stored index (strictly increasing, in range) lists every position."""
    return bool(index.size == size)


def first_nonfinite(named: dict[str, Any]) -> list[str]:
    """Names of the arrays holding a NaN or an infinity (:func:`all_finite`)."""
    return [name for name, v in named.items() if not all_finite(v)]


def all_finite(values: np.ndarray) -> bool:
    """Whether every value is finite. A finite sum proves it (NaN and infinities propagate)
    without a boolean temporary of the array's size (on a 10^5-entry map's checks, ~37 MB
    of fresh pages a query used to fault in); only an infinite sum (a NaN, an infinity, or
    an overflow) is checked value by value. Integers and booleans are always finite."""
    v = np.asarray(values)
    if v.size == 0 or v.dtype.kind in "biu":
        return True
    with np.errstate(over="ignore", invalid="ignore"):  # inf - inf, an overflow: no warning
        total = v.sum()
    return bool(np.isfinite(total) or np.isfinite(v).all())
