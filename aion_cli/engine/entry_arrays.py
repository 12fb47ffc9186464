"""An :class:`~aion_cli.engine.entries.EntryStore` rebuilt from the plain arrays of a map file
(:meth:`EntryStore.to_arrays`): every member checked (:class:`MapCorruptError` on a missing
one, a wrong shape or an unknown kind), and members just read adopted as they are where they
can be the store's arrays (:meth:`EntryStore.from_arrays`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aion_cli.engine.entries import CELL, HEADING_SUMS, NODE, EntryStore
from aion_cli.errors import MapCorruptError


def store_from_arrays(
    store_type: type[EntryStore],
    arrays: dict[str, np.ndarray],
    bins: int,
    prefix: str,
    adopt: bool,
) -> EntryStore:
    """:meth:`EntryStore.from_arrays` (its docstring says what ``adopt`` does)."""
    try:
        n = len(arrays[f"{prefix}kind"])
        members = {}
        for name in store_type._array_names():
            if name in HEADING_SUMS and f"{prefix}{name}" not in arrays:
                continue  # a map written before them: zeros (bin centres)
            members[name] = np.asarray(arrays[f"{prefix}{name}"])
    except KeyError as exc:
        raise MapCorruptError(f"map state is missing the entry array {exc}") from exc
    adopted = adopt and n >= 64 and len(members) == len(store_type._array_names())
    store = store_type.empty(bins, capacity=1)  # each array's dtype and row shape
    for name, src in members.items():
        dst = getattr(store, name)
        if src.shape != (n, *dst.shape[1:]):
            raise MapCorruptError(
                f"entry array {name} has shape {src.shape}, expected {(n, *dst.shape[1:])}"
            )
        adopted = adopted and _adoptable(src, dst.dtype)
    if not adopted:
        store = store_type.empty(bins, capacity=max(n, 64))
    for name, src in members.items():
        if adopted:
            setattr(store, name, src)
        else:
            getattr(store, name)[:n] = src.astype(getattr(store, name).dtype, copy=False)
    if adopted:
        store.window_mark = np.zeros(n, bool)
    if np.any((store.kind[:n] != CELL) & (store.kind[:n] != NODE)):
        raise MapCorruptError("map state has entries of unknown kind")
    store.n = n
    # every row's open-window total, from the arrays' first n rows as they lie (the
    # values of window_totals(arange(n)), without its gathered copy of every row)
    totals = store.window_counts[:n].sum(axis=1) + store.window_nodir[:n]
    store.window_mark[:n] = totals != 0
    return store


def _adoptable(src: np.ndarray, dtype: np.dtype[Any]) -> bool:
    """Whether a member can be a store's array as it is (:meth:`EntryStore.from_arrays`)."""
    flags = src.flags
    return bool(
        src.dtype == dtype and src.dtype.isnative and flags.c_contiguous and flags.writeable
        and flags.aligned
    )
