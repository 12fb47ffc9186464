"""What a query reads from the temporal accumulators before it forecasts: the state with the
pending day and the open window absorbed (:func:`query_view`), the profile bins the map
observed (:func:`observed_bins`), and the family each entry chooses from its day-ahead
scores (:func:`choose`).

Split from :mod:`aion_cli.engine.temporal.model`, whose ``Predictor`` forecasts with these."""

from __future__ import annotations

import numpy as np

from aion_cli.engine.temporal.absorption import absorb_parts, slot_times
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.choice import choose_families
from aion_cli.engine.temporal.components import FremenComponents
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows, PendingDay
from aion_cli.engine.types import I64


def query_view(
    params: TemporalParams,
    state: TemporalState,
    pending: PendingDay,
    open_window: DayWindows | None,
    window_ns: int,
    in_place: bool,
) -> TemporalState:
    """The state with the pending day and the open window (as closing it would record it)
    absorbed, unscored (a copy unless ``in_place``; ``pending`` is cleared when absorbed in
    place)."""
    day = pending.consolidated() if pending else None
    if day is None and open_window is None:
        return state
    view = state if in_place else state.copy()
    absorb_parts(params, view, [p for p in (day, open_window) if p is not None], window_ns)
    if in_place:
        pending.clear()
    return view


def observed_bins(
    params: TemporalParams,
    state: TemporalState,
    rows: I64,
    parts: list[DayWindows],
    window_ns: int,
) -> I64:
    """The profile bins (hour of day × kind of day) in which the map observed anything: a
    window of the fixed sensor, any of ``rows``' own windows, or a window of ``parts`` (the
    pending day, the open window: every window they hold was observed by something). A
    forecast in any other bin is extrapolated from the bins observed, not measured."""
    seen = state.glob.profile[0] > 0
    # a row never observed on its own (n = 0) has an empty profile (n is the sum of its
    # bins, of the same non-negative weights): only the others are read, so a fixed
    # sensor's map does not touch (or copy) an E x bins array of zeros
    own = rows[state.obs.n[rows] > 0]
    if own.size:
        seen = seen | (state.obs.profile[own] > 0).any(axis=0)
    for part in parts:
        if part.windows.size:
            seen[slot_times(params, part, window_ns)[1]] = True
    return np.flatnonzero(seen).astype(np.int64)


def choose(
    params: TemporalParams,
    state: TemporalState,
    rows: I64,
    groups: I64,
    n_groups: int,
    components: FremenComponents | None = None,
) -> tuple[I64, I64, int]:
    """Each entry's flow and direction family and the map's flow family, from the day-ahead
    scores (``choice.choose_families``). A state read without its Fourier sums chooses
    FreMEn only for the entries whose ``components`` the map stores (those that chose it
    when the map was written: the same entries, unless the map predates a change of the
    rules)."""
    fremen_rows = None
    if not state.fourier_loaded:
        fremen_rows = np.zeros(rows.size, dtype=bool)
        if components is not None:
            fremen_rows[components.total_pos] = True
    return choose_families(
        params,
        state.flow_score[rows],
        state.dir_score[rows],
        groups,
        n_groups,
        (state.flow_gain_sq[rows], state.flow_days[rows]),
        (state.dir_gain_sq[rows], state.dir_days[rows]),
        fremen_rows,
    )
