"""Routing of hash keys to entry rows: one sorted key index, searched with ``np.searchsorted``.

The table maps every key that has a home to an entry row: a live cell entry's own key, or a
redirected key φ(cell) -> the owning node's row. It is rebuilt after ownership changes (once per
graph update or window close) and extended in place when detections create new cells, so routing
a batch is one ``searchsorted`` plus one ``np.unique`` over the keys not seen before.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aion_cli.engine.types import I64, BoolA


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

    def insert(self, keys: I64, rows: I64) -> None:
        """Insert new keys (sorted, unique, not present) keeping the table sorted."""
        if len(keys) == 0:
            return
        pos = np.searchsorted(self.keys, keys)
        self.keys = np.insert(self.keys, pos, keys)
        self.rows = np.insert(self.rows, pos, rows)
