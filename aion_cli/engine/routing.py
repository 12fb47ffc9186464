"""Routing of hash keys to entry rows: one sorted key index, searched with ``np.searchsorted``.

The table maps every key that has a home to an entry row: a live cell entry's own key, or a
redirected key φ(cell) -> the owning node's row. It is rebuilt after ownership changes (once per
graph update or window close) and extended in place when detections create new cells, so routing
a batch is one ``searchsorted`` plus one ``np.unique`` over the keys not seen before, or for a
large batch over a compact region one pass through a dense grid over its bounding box.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from aion_cli.engine.grouping import insert_sorted
from aion_cli.engine.spatial_hash import pack_keys_unchecked, unpack_keys
from aion_cli.engine.types import I64, BoolA

_DENSE_MIN_BATCH = 4096
"""Batches smaller than this use binary search (a dense grid would not pay off)."""
_DENSE_SLACK = 1 << 16
_DENSE_MAX_CELLS = 1 << 24
"""The dense grid may have at most 4 cells per key plus slack, and never more than 16 M."""


def _linear(offsets: I64, dims: I64) -> I64:
    """Row-major linear index of non-negative cell offsets inside a box of size ``dims``."""
    out: I64 = (offsets[:, 2] * dims[1] + offsets[:, 1]) * dims[0] + offsets[:, 0]
    return out


@dataclass
class RouteTable:
    """Sorted ``keys`` with the entry ``rows`` they route to."""

    keys: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    rows: I64 = field(default_factory=lambda: np.zeros(0, np.int64))

    @classmethod
    def build(cls, keys: I64, rows: I64) -> RouteTable:
        """Table from unsorted key/row pairs; keys must be unique."""
        order = np.argsort(keys, kind="stable")
        return cls(keys[order].astype(np.int64), rows[order].astype(np.int64))

    def lookup(self, keys: I64) -> tuple[I64, BoolA]:
        """Rows for ``keys`` and a mask of which keys were found (rows are -1 elsewhere)."""
        if len(self.keys) == 0:
            return np.full(len(keys), -1, np.int64), np.zeros(len(keys), bool)
        pos = np.searchsorted(self.keys, keys)
        pos_c = np.minimum(pos, len(self.keys) - 1)
        found = self.keys[pos_c] == keys
        rows = np.where(found, self.rows[pos_c], -1)
        return rows, found

    def route(self, keys: I64, ijk: I64, create: Callable[[I64], I64]) -> I64:
        """Rows for ``keys`` (cell indices ``ijk``); keys not in the table get rows from
        ``create(new_keys)`` (called once with the sorted distinct new keys) and are inserted.

        A large batch over a compact region goes through a dense grid over the batch's bounding
        box (cache-friendly, O(n), no sort: distinct new cells come from a ``np.bincount`` over
        grid cells); otherwise a binary search per key and one ``np.unique`` over the new keys.
        Both give the same rows.
        """
        if len(keys) >= _DENSE_MIN_BATCH:
            rows = self._dense_route(ijk, create)
            if rows is not None:
                return rows
        rows, found = self.lookup(keys)
        if not found.all():
            new_keys, inverse = np.unique(keys[~found], return_inverse=True)
            new_rows = create(new_keys)
            self.insert(new_keys, new_rows)
            rows[~found] = new_rows[inverse]
        return rows

    def _dense_route(self, ijk: I64, create: Callable[[I64], I64]) -> I64 | None:
        lo = ijk.min(axis=0)
        dims = ijk.max(axis=0) - lo + 1
        volume = int(np.prod(dims))
        if volume > _DENSE_MAX_CELLS or volume > 4 * len(ijk) + _DENSE_SLACK:
            return None
        grid = np.full(volume, -1, np.int64)
        if len(self.keys):
            table_ijk = unpack_keys(self.keys) - lo
            inside = np.all((table_ijk >= 0) & (table_ijk < dims), axis=1)
            grid[_linear(table_ijk[inside], dims)] = self.rows[inside]
        lin = _linear(ijk - lo, dims)
        rows = grid[lin]
        missing = rows < 0
        if missing.any():
            # linear order (z, y, x major to minor) is key order, so new keys come out sorted
            cells = np.flatnonzero(np.bincount(lin[missing], minlength=volume))
            offsets = np.stack(
                [cells % dims[0], (cells // dims[0]) % dims[1], cells // (dims[0] * dims[1])],
                axis=1,
            )
            new_keys = pack_keys_unchecked(offsets + lo)
            new_rows = create(new_keys)
            self.insert(new_keys, new_rows)
            grid[cells] = new_rows
            rows = grid[lin]
        return rows

    def reroute(self, keys: I64, old_rows: I64, new_rows: I64) -> bool:
        """Point ``keys``, which the table routes to ``old_rows``, to ``new_rows`` in place
        (entries moved without other changes). False, and the table unchanged, when it does
        not route every key so (the caller rebuilds it then)."""
        if len(self.keys) == 0:
            return len(keys) == 0
        at = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        if not ((self.keys[at] == keys).all() and (self.rows[at] == old_rows).all()):
            return False
        self.rows[at] = new_rows
        return True

    def insert(self, keys: I64, rows: I64) -> None:
        """Insert new keys (sorted, unique, not present) keeping the table sorted."""
        if len(keys) == 0:
            return
        pos = np.searchsorted(self.keys, keys)
        self.keys = insert_sorted(self.keys, pos, keys)
        self.rows = insert_sorted(self.rows, pos, rows)
