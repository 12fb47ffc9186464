"""The pooling's prior strengths of a map as its queries will see it, computed when the map
is written (:mod:`~aion_cli.engine.temporal.pool_priors`).

A query of a map file absorbs the pending day and the open window into the accumulators it
read, unscored (``MapState.query_temporal``), and pools its forecasts over that view. The
writer computes the same view's κ, κ_t and κ_G without copying the accumulators (a build's
are dense, 1.2 GB on a map of 10^5 entries): it saves the rows the pending day and the open
window touch, absorbs them in place, pools, and puts every touched value back, so the state
it writes, and goes on learning with, is unchanged to the bit (tested).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.closing import open_window_record
from aion_cli.engine.temporal.absorption import absorb
from aion_cli.engine.temporal.accumulators import _ADDITIVE, TemporalState
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.temporal.pool_priors import PoolPriors
from aion_cli.engine.temporal.pooling import PoolStats, entry_sums

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def view_priors(state: MapState) -> PoolPriors:
    """κ, κ_t and κ_G as a query of ``state`` written to a file estimates them: over its
    live entries in canonical order, pending day and open window absorbed."""
    rows = state.entries.canonical_order()
    groups, n_groups = state.groups(rows)
    parts = [state.pending.consolidated()] if state.pending else []
    if (open_window := open_window_record(state)) is not None:
        parts.append(open_window)
    t = state.temporal
    with absorbed(state.params, t, parts, state.window_ns):
        counts, totals = entry_sums(t, rows)
        pool = PoolStats.of(state.params, t, rows, groups, n_groups, counts, totals)
    kappa_g = None if pool.shift is None else pool.shift.kappa
    return PoolPriors(pool.kappa, pool.kappa_t, kappa_g, int(rows.size), int(n_groups))


@contextmanager
def absorbed(
    params: TemporalParams, t: TemporalState, parts: list[DayWindows], window_ns: int
) -> Iterator[None]:
    """``parts`` absorbed into ``t`` in place while the block runs, then taken out again:
    the rows they touch, the global block and the map-wide sums are saved before and put
    back after (the arrays themselves too, should absorbing have widened one), with the
    state's generation and high-water mark."""
    if not parts:
        yield
        return
    touched = np.unique(np.concatenate([np.concatenate([p.obs_entry, p.cnt_entry]) for p in parts]))
    touched = touched.astype(np.int64, copy=False)
    saved = t.take(touched)  # copies of the rows, the global block and the map-wide sums
    arrays = {name: getattr(t, name) for name in (*_ADDITIVE, *_MAP_SUMS)}
    obs, glob, generation, high_water = t.obs, t.glob, t.generation, t.high_water
    try:
        for part in parts:
            absorb(params, t, part, window_ns)
        yield
    finally:  # the very arrays back (a writer may hold them), their values put back in place
        for name, array in arrays.items():
            setattr(t, name, array)
        t.obs, t.glob = obs, glob
        t.put_rows(touched, saved, np.arange(touched.size))
        glob.put(np.zeros(1, np.int64), saved.glob)
        for name in _MAP_SUMS:
            getattr(t, name)[...] = getattr(saved, name)
        t.generation, t.high_water = generation, high_water


_MAP_SUMS = ("window_chi2", "day_level", "week_sums")
"""The map-wide sums a day's absorption adds to (in place or into new arrays)."""
