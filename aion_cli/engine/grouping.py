"""Grouping rows by a key, keeping each group's rows in their order.

A stable sort by the key puts equal keys together without reordering them, so sums taken
group by group run in the rows' own order (and equal what one pass over all rows gives per
group). :func:`split_by_key` returns the non-empty groups; :func:`cut_by_key` returns the
sorted order and where each of given key bounds falls in it, so groups without rows (a block
of candidates none of whose entries has a pair) are slices of length 0;
:func:`lexicographic_ranks` numbers rows of several keys (the temporal pooling groups);
:func:`insert_sorted` is ``np.insert`` at ascending positions (a sorted table growing);
:func:`unique_inverse` is ``np.unique(..., return_inverse=True)`` without a sort for keys of a
narrow range (a block's rows, the entries a batch of detections touched); :func:`distinct` is
``np.unique(keys)`` the same way; :func:`contained` is ``np.isin`` for keys that are usually
stored in increasing order (a map's, read back). Neither calls ``np.unique``, whose first call
imports ``numpy.ma`` (10 ms of every query process).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import I64, BoolA


def split_by_key(keys: npt.NDArray[np.integer]) -> list[I64]:
    """Indices of ``keys`` per distinct key, keys ascending, each group's in their order."""
    if keys.size == 0:
        return []
    order = np.argsort(keys, kind="stable")
    cuts = np.flatnonzero(np.diff(keys[order])) + 1
    return np.split(order, cuts)


def insert_sorted(base: np.ndarray, at: I64, values: npt.ArrayLike) -> np.ndarray:
    """``np.insert(base, at, values, axis=0)`` for ascending ``at`` (a sorted table taking
    the rows of new keys; equal positions keep the new rows' order): the same array, without
    ``np.insert``'s general handling, which costs about three times as much for the few rows
    a batch of detections or a bind adds (issue 15: twice per new cell of a build)."""
    k = len(at)
    out = np.empty((len(base) + k, *base.shape[1:]), dtype=base.dtype)
    new = at + np.arange(k)
    old = np.ones(len(out), dtype=bool)
    old[new] = False
    out[new] = values
    out[old] = base
    return out


def cut_by_key(keys: npt.NDArray[np.integer], bounds: npt.ArrayLike) -> tuple[I64, I64]:
    """Indices of ``keys`` sorted stably by key, and the position in that order of every
    bound (the first key not below it): group k is ``order[cut[k] : cut[k + 1]]``."""
    order = np.argsort(keys, kind="stable")
    cut: I64 = np.searchsorted(keys[order], bounds)
    return order, cut


def lexicographic_ranks(keys: I64) -> tuple[I64, int]:
    """Per row of ``keys[n, k]``, the index of its distinct row in lexicographic order, and the
    number of distinct rows: ``np.unique(keys, axis=0, return_inverse=True)``, with one
    ``lexsort`` instead of sorting rows as structured values (~10x faster on 10^5 rows; a
    query of a large map pays it once)."""
    n = len(keys)
    if n == 0:
        return np.zeros(0, np.int64), 0
    order = np.lexsort(keys.T[::-1])
    ranked = keys[order]
    new = np.ones(n, dtype=bool)
    new[1:] = np.any(ranked[1:] != ranked[:-1], axis=1)
    ids = np.cumsum(new) - 1
    inverse = np.empty(n, dtype=np.int64)
    inverse[order] = ids
    return inverse, int(ids[-1]) + 1


def unique_inverse(keys: I64) -> tuple[I64, I64]:
    """``np.unique(keys, return_inverse=True)`` (sorted distinct keys and each key's index),
    without a sort when the keys span a range a few times their number (one block's rows)."""
    if keys.size == 0:
        return keys, keys
    narrow = _narrow_range(keys)
    if narrow is None:
        distinct, inverse = np.unique(keys, return_inverse=True)
        return distinct, inverse.reshape(-1)
    low, span = narrow
    local = keys - low
    present = np.zeros(span, dtype=bool)
    present[local] = True
    found = np.flatnonzero(present)
    lookup = np.empty(span, dtype=np.int64)
    lookup[found] = np.arange(found.size)
    return found + low, lookup[local]


def contained(values: npt.NDArray[np.integer], queries: npt.NDArray[np.integer]) -> BoolA:
    """``np.isin(queries, values)``: one binary search per query in ``values``, which a map
    read back holds in increasing order (checked with one comparison of neighbours; anything
    else is sorted first). ``np.isin`` sorts both arrays (and its ``np.unique`` imports
    ``numpy.ma``): a fifth of the checks of a 10^5-entry map as ``predict`` loads it."""
    if values.size == 0 or queries.size == 0:
        return np.zeros(queries.shape, dtype=bool)
    if values.size > 1 and not bool(np.all(values[1:] >= values[:-1])):
        values = np.sort(values)
    at = np.minimum(np.searchsorted(values, queries), values.size - 1)
    found: BoolA = values[at] == queries
    return found


def distinct(keys: I64) -> I64:
    """``np.unique(keys)`` (sorted distinct integer keys): a bitmap over a range a few times
    the keys' number (entry positions of one block), else a sort and a comparison of
    neighbours."""
    if keys.size == 0:
        return keys.copy()
    narrow = _narrow_range(keys)
    if narrow is None:
        ordered = np.sort(keys)
        keep = np.ones(ordered.size, dtype=bool)
        keep[1:] = ordered[1:] != ordered[:-1]
        return ordered[keep]
    low, span = narrow
    present = np.zeros(span, dtype=bool)
    present[keys - low] = True
    out: I64 = (np.flatnonzero(present) + low).astype(keys.dtype, copy=False)
    return out


def _narrow_range(keys: I64) -> tuple[int, int] | None:
    """(lowest key, span) of non-empty ``keys`` when the span is a few times their number
    (a bitmap over it beats a sort), else None."""
    low = int(keys.min())
    span = int(keys.max()) - low + 1
    return None if span > 8 * keys.size + (1 << 16) else (low, span)
