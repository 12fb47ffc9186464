"""FreMEn observations of closed windows, held back so several windows are absorbed at once.

Every closed window gives each observed entry one activity observation and B direction
observations. Absorbing them one window at a time touches every observed state's accumulators
(about 1 KB each) once per window, which dominates a build. :class:`PendingUpdates` collects the
``FremenModel.update`` calls of consecutive windows and :func:`combine` merges them into one call
over the union of their rows (a row missing from a call is simply unobserved in its windows).
``FremenModel.update`` gives the same result whatever the batching, so deferring changes no
number; :class:`~aion_cli.engine.state.MapState` flushes before anything reads or moves FreMEn
rows (its ``fremen`` property), so no one ever sees a state with windows missing.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aion_cli.engine.types import F64, I64, BoolA

MAX_PENDING_CELLS = 1 << 23
"""Flush once the pending calls hold this many (row, window) cells (~75 MB of values and
masks when combined)."""

MAX_PENDING_WINDOWS = 36
"""Flush once this many distinct windows (6 h of 10-minute windows) are pending."""


@dataclass
class PendingUpdates:
    """Deferred ``update`` calls (rows, window times, values, observed), in time order."""

    calls: list[tuple[I64, F64, F64, BoolA]] = field(default_factory=list)
    cells: int = 0
    times: set[float] = field(default_factory=set)

    def __bool__(self) -> bool:
        return bool(self.calls)

    def accepts(self, rows: I64, t_s: F64) -> bool:
        """Whether the call can join the pending ones: its windows are not earlier than any
        pending one, and a window already pending is not given again for the same rows."""
        if not self.calls:
            return True
        latest = max(self.times)
        if float(t_s[0]) > latest:
            return True
        if float(t_s[0]) < latest:
            return False
        probe = _sorted(rows)
        return not any(
            _overlap(_sorted(r), probe) for r, t, _, _ in self.calls if float(t[-1]) == latest
        )

    def add(self, rows: I64, t_s: F64, values: F64, observed: BoolA) -> None:
        self.calls.append((rows, t_s, values, observed))
        self.cells += int(values.size)
        self.times.update(float(x) for x in t_s)

    def full(self) -> bool:
        return self.cells >= MAX_PENDING_CELLS or len(self.times) >= MAX_PENDING_WINDOWS

    def take(self) -> list[tuple[I64, F64, F64, BoolA]]:
        """The pending calls (and forget them)."""
        calls, self.calls, self.cells, self.times = self.calls, [], 0, set()
        return calls


def _sorted(a: I64) -> I64:
    return a if a.size < 2 or bool(np.all(a[1:] >= a[:-1])) else np.sort(a)


def _overlap(a: I64, b: I64) -> bool:
    """Whether two sorted arrays share a value (binary search: no hashing of either)."""
    if a.size == 0 or b.size == 0:
        return False
    pos = np.minimum(np.searchsorted(a, b), a.size - 1)
    return bool(np.any(a[pos] == b))


def combine(calls: list[tuple[I64, F64, F64, BoolA]]) -> tuple[I64, F64, F64, BoolA]:
    """One call equal to ``calls`` in sequence: the sorted union of their rows and of their
    window times, each call's values in its block, unobserved elsewhere."""
    if len(calls) == 1:
        return calls[0]
    top = max((int(c[0].max()) for c in calls if c[0].size), default=-1)
    seen = np.zeros(top + 1, dtype=bool)
    for r, _, _, _ in calls:  # a mask over the row space: no sort or hash of every call's rows
        seen[r] = True
    rows = np.flatnonzero(seen)
    slot = np.cumsum(seen) - 1  # row index -> its position in ``rows`` (no binary search)
    t = np.unique(np.concatenate([c[1] for c in calls]))
    values = np.zeros((rows.size, t.size))
    observed = np.zeros((rows.size, t.size), dtype=bool)
    for r, ts, v, o in calls:
        ri = slot[r]
        ti = np.searchsorted(t, ts)
        if ti.size == 1:
            values[ri, ti[0]] = v[:, 0]
            observed[ri, ti[0]] = o[:, 0]
        else:
            values[np.ix_(ri, ti)] = v
            observed[np.ix_(ri, ti)] = o
    return rows, t, values, observed
