"""What a map's manifest says about its forecasts (``aion info``, the forecast notes): how
many entries forecast with each family, whether the map's total is reconciled, how much was
scored, which profile bins were observed at all, and which calendar the data asks for."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.closing import open_window_record
from aion_cli.engine.temporal import query_state
from aion_cli.engine.temporal.absorption import view_week_sums
from aion_cli.engine.temporal.choice import CHOICE_RULES
from aion_cli.engine.temporal.week_evidence import calendar_choice

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def family_summary(state: MapState) -> dict[str, Any]:
    """How many entries forecast with each family (flow and direction), whether the map's
    total is reconciled to its own forecast, the days and windows scored, and the profile
    bins (hour of day × kind of day) in which anything was observed, pending day and open
    window included (:func:`~aion_cli.engine.temporal.query_state.observed_bins`: a forecast in
    another bin is extrapolated). The choice depends only on the day-ahead scores, so no
    forecast is prepared. ``calendar``: the hours of the week or of weekdays and weekends, as
    the map totals judge them day ahead, the pending day and open window absorbed as a
    query absorbs them (:func:`~aion_cli.engine.temporal.week_evidence.calendar_choice`; the
    calendar a ``week`` map's forecasts use, :mod:`~aion_cli.engine.temporal.calendar_view`)."""
    rows = state.entries.canonical_order()
    groups, n_groups = state.groups(rows)
    t = state.scored_temporal()
    params = state.params
    flow, direction, map_flow = query_state.choose(params, t, rows, groups, n_groups)
    reconciled = state.config.reconcile and params.flow[map_flow] != "static"
    parts = [state.pending.consolidated()] if state.pending else []
    if (open_window := open_window_record(state)) is not None:
        parts.append(open_window)
    observed = query_state.observed_bins(params, state.temporal, rows, parts, state.window_ns)
    # the calendar a query's view chooses (pending day and open window absorbed), which a
    # ``week`` map's forecasts use: the closed days' alone may say another
    week_sums = view_week_sums(params, state.temporal, parts, state.window_ns)
    return {
        "flow": _tally(np.asarray(params.flow)[flow]),
        "direction": _tally(np.asarray(params.direction)[direction]),
        "reconciled": bool(reconciled),
        "scored_windows": float(t.flow_scored[rows].sum()),
        "scored_days": _scored_days(state, t, rows),
        "last_day_provisional": state.provisional_scores() is not None,  # cached
        "observed_bins": observed.tolist(),
        "rules": CHOICE_RULES,
        "calendar": calendar_choice(week_sums, state.config.family_margin),
    }


def _scored_days(state: MapState, t: Any, rows: Any) -> int:
    """The days the map scored: the most any entry counts, but never more than the local days
    its observation spans less the first (which nothing before it forecasts). An entry that
    absorbed another over the same days (a cell bound to a node, places merged) counts their
    days twice — its day-ahead test pools the two entries' days as separate samples — which is
    no figure for the map."""
    most = int(t.flow_days[rows].max(initial=0.0))
    if most == 0 or rows.size == 0:
        return most
    from aion_cli.engine.windows import EPOCH_NS

    first = np.fmin(t.obs.first[rows], t.glob.first[0])  # the observation's ends only
    last = np.fmax(t.obs.last[rows], t.glob.last[0])
    if not np.isfinite(first).any():
        return most
    ends = [EPOCH_NS + round(float(np.nanmin(first)) * 1e9)]
    if np.isfinite(last).any():
        ends.append(EPOCH_NS + round(float(np.nanmax(last)) * 1e9))
    days = [int(d) for d in state.params.calendar.day(np.array(ends, np.int64))]
    if state.pending is not None and state.pending.day is not None:
        days.append(int(state.pending.day))  # scored provisionally, in no observation yet
    return min(most, max(max(days) - min(days), 0))


def _tally(names: np.ndarray) -> dict[str, int]:
    values, counts = np.unique(names, return_counts=True)
    return {str(v): int(c) for v, c in zip(values, counts, strict=True)}
