"""The pooling's prior strengths of a map as its queries will see it, computed when the map
is written (:mod:`~aion_cli.engine.temporal.pool_priors`).

A query of a map file absorbs the pending day and the open window into the accumulators it
read, unscored (``MapState.query_temporal``), and pools its forecasts over that view. The
writer computes the same view's κ, κ_t and κ_G without copying the accumulators (a build's
are dense, 1.2 GB on a map of 10^5 entries): it saves the cells the pending day and the open
window add to, absorbs them in place, pools, and puts every saved value back, so the state
it writes, and goes on learning with, is unchanged to the bit (tested).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.closing import open_window_record
from aion_cli.engine.temporal.absorption import absorb_parts, slot_times
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.calendar_view import pooled_view
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.temporal.pool_priors import PoolPriors
from aion_cli.engine.temporal.pooling import entry_counts, pooled_priors

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def view_priors(state: MapState) -> PoolPriors:
    """κ, κ_t and κ_G as a query of ``state`` written to a file estimates them: over its
    live entries in canonical order, pending day and open window absorbed, on the calendar
    the forecast reads (a ``week`` map may pool its weeks: ``calendar_view.pooled_view``)."""
    rows = state.entries.canonical_order()
    groups, n_groups = state.groups(rows)
    parts = [state.pending.consolidated()] if state.pending else []
    if (open_window := open_window_record(state)) is not None:
        parts.append(open_window)
    t = state.temporal
    with absorbed(state.params, t, parts, state.window_ns):
        params, view = pooled_view(state.params, t)  # the calendar the forecast reads
        # the pooling's priors alone: not the groups' shapes, which they do not read
        return pooled_priors(params, view, rows, groups, n_groups, entry_counts(view, rows))


@contextmanager
def absorbed(
    params: TemporalParams, t: TemporalState, parts: list[DayWindows], window_ns: int
) -> Iterator[None]:
    """``parts`` absorbed into ``t`` in place while the block runs, then taken out again.

    Only what absorbing writes is saved and put back: the count cells (entry, value bin,
    profile bin) and the observation cells (entry, profile bin) the parts hold, their
    entries' windows and ends, the global block and the map-wide sums (in the very arrays,
    should absorbing have put new ones in their place), with the state's generation and
    high-water mark. The Fourier sums are set aside meanwhile (absorbed as a query's state
    without them absorbs: the pooling never reads them), so nothing of them is copied: the
    cells saved are a day's, not whole rows (a build's counts are dense, 12 KB an entry)."""
    if not parts:
        yield
        return
    v, h = params.values, params.n_profile
    cells, rows, seen = [], [], []
    for part in parts:
        bins = slot_times(params, part, window_ns)[1]
        pair, value = np.nonzero(part.cnt_values)
        cells.append((part.cnt_entry[pair] * v + value) * h + bins[part.cnt_slot[pair]])
        own, slot, _ = part.own_pairs()
        rows.append(own)
        seen.append(own * h + bins[slot])
    # not made unique: a cell listed twice is saved twice with the same value and put back
    # twice with it (``np.unique`` of a day's 373,281 cells cost 0.27 s of CPU at 10^5
    # entries, a quarter of the priors' write; stop 70)
    count_cells, own_rows, own_cells = (
        np.concatenate(c).astype(np.int64) for c in (cells, rows, seen)
    )
    counts, obs, glob = t.cnt_profile, t.obs, t.glob
    flat_counts, flat_profile = _flat(counts), _flat(obs.profile)
    saved_counts, saved_profile = flat_counts[count_cells], flat_profile[own_cells]
    saved_obs = {name: getattr(obs, name)[own_rows] for name in ("n", "first", "last")}
    saved_glob = glob.take([0])
    sums = {name: getattr(t, name) for name in _MAP_SUMS}
    saved_sums = {name: array.copy() for name, array in sums.items()}
    fourier, obs_fourier, loaded = t.cnt_fourier, obs.fourier, t.fourier_loaded
    generation, high_water = t.generation, t.high_water
    t.cnt_fourier = np.zeros((t.n_rows, v, 0), np.complex128)
    obs.fourier, t.fourier_loaded = np.zeros((t.n_rows, 0), np.complex128), False
    try:
        absorb_parts(params, t, parts, window_ns)  # as a query's view absorbs them
        yield
    finally:  # the very arrays back (a writer may hold them), their values put back in place
        t.cnt_profile, t.obs, t.glob = counts, obs, glob
        t.cnt_fourier, obs.fourier, t.fourier_loaded = fourier, obs_fourier, loaded
        flat_counts[count_cells] = saved_counts
        flat_profile[own_cells] = saved_profile
        for name, values in saved_obs.items():
            getattr(obs, name)[own_rows] = values
        glob.put(np.zeros(1, np.int64), saved_glob)
        for name, array in sums.items():
            setattr(t, name, array)
            array[...] = saved_sums[name]
        t.generation, t.high_water = generation, high_water


def _flat(values: np.ndarray) -> np.ndarray:
    """``values`` as one axis, a view (absorbing writes the counts through such a view)."""
    flat = values.reshape(-1)
    if not np.shares_memory(flat, values):
        raise ValueError("the accumulators are not contiguous")
    return flat


_MAP_SUMS = ("window_chi2", "day_level", "week_sums")
"""The map-wide sums a day's absorption adds to (in place or into new arrays)."""
