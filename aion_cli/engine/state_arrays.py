"""A :class:`~aion_cli.engine.state.MapState` to plain arrays and back (a map file's members).

:func:`map_state_to_arrays` gathers the entries in canonical order with their temporal rows,
FreMEn components, the pooling's prior strengths, provisional scores, pending day, held days,
node table, redirects, observation source and graph; :func:`map_state_from_arrays` checks
and reads them back.
``MapState.to_arrays`` / ``MapState.from_arrays`` call these. They are apart from
``state.py`` because persistence is one job (which members, in which order, checked how)
that the state's build and query methods never call: ``state.py`` keeps what a state does,
this module what a state is on disk.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from aion_cli.engine.entries import EntryStore
from aion_cli.engine.graph_arrays import graph_from_arrays, graph_to_arrays
from aion_cli.engine.nodes import NodeTable, Redirects
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.state_checks import (
    STATE_VERSION,
    check_loaded,
    check_member_shapes,
    check_ownership,
    parse_state_meta,
)
from aion_cli.engine.temporal import components as fremen_components
from aion_cli.engine.temporal import week_evidence
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.held_days import DeferredDays
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import PendingDay
from aion_cli.engine.temporal.pool_priors import PoolPriors
from aion_cli.engine.temporal.provisional import ProvisionalScores
from aion_cli.engine.view_priors import view_priors
from aion_cli.errors import MapCorruptError

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def map_state_to_arrays(
    state: MapState, lazy: bool = False, priors: bool = True
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Plain arrays and a JSON-serialisable meta dict (config, counters, window, graph).

    The temporal members are gathered block by block when written (``lazy`` is kept for
    callers; every large member is streamed), so writing needs no second copy of the
    largest part of the state. ``priors=False``: without the ``forecast_priors`` member
    (a copy of the state that is not written, such as a merge's inputs: a writable state
    read back never uses them, and estimating them cost 0.8 s of CPU at 10^5 entries)."""
    del lazy
    # the query view's priors first: computing them absorbs and restores the pending day and
    # the open window in place, before any member is gathered
    stored = {} if state.deferred is not None or not priors else view_priors(state).to_arrays()
    order = state.entries.canonical_order()
    arrays: dict[str, Any] = state.entries.to_arrays(order)
    arrays.update(state.temporal.to_arrays("temporal_", order))
    position = np.full(state.entries.capacity, -1, np.int64)
    position[order] = np.arange(order.size)
    if state.deferred is None:  # a part map forecasts nothing
        arrays.update(state.forecast_components(order).to_arrays(state.params.n_periods))
        arrays.update(stored)  # computed afresh on every write
        provisional = state.provisional_scores()
        if provisional is not None:
            arrays.update(provisional.to_arrays(position))
    pending_arrays, pending_day = state.pending.to_arrays("pending_", position)
    arrays.update(pending_arrays)
    deferred_meta = None
    if state.deferred is not None:  # a part map (aion build --part): its held days
        held_arrays, deferred_meta = state.deferred.to_arrays(position)
        arrays.update(held_arrays)
    arrays.update(state.nodes.to_arrays())
    arrays.update(state.redirects.to_arrays())
    arrays.update(state.observation.to_arrays())
    graph_arrays, graph_meta = graph_to_arrays(state.graph)
    arrays.update(graph_arrays)
    meta: dict[str, Any] = {
        "state_version": STATE_VERSION,
        "config": state.config.to_dict(),
        "open_window": state.open_window,
        "log_time_ns": state.log_time_ns,
        "accepted": int(state.accepted),
        "dropped": {k: int(v) for k, v in state.dropped.items()},
        "graph": graph_meta,
        "pending_day": pending_day,
    }
    if deferred_meta is not None:
        meta["deferred"] = deferred_meta
    return arrays, meta


def map_state_from_arrays(
    cls: type[MapState],
    arrays: Mapping[str, np.ndarray],
    meta: dict[str, Any],
    writable: bool = True,
    copy: bool = True,
    forecast_only: bool = False,
    stored_forecasts: bool = True,
    stored_priors: bool = True,
) -> MapState:
    """Inverse of :func:`map_state_to_arrays`; :class:`MapCorruptError` for inconsistent input.

    ``forecast_only`` (a query's state, not ``writable``): when the map stores its FreMEn
    components, the per-entry Fourier sums are not read (most of a map's bytes); the
    forecasts are the same.

    ``arrays`` may be any mapping (e.g. a map file's lazily read members). ``copy=False``:
    the arrays are fresh (just read from a file) and the state may keep them instead of
    copying. A state that is not ``writable`` (a query's) keeps its temporal rows as
    stored: no room is reserved for new entries (``EntryStore`` capacity), which would
    copy every accumulator once more.

    ``stored_forecasts`` / ``stored_priors`` False: the map's FreMEn components and
    provisional scores / its pooling priors are not its own (``aion_cli.derived_seal``):
    they are left unread, and the state computes them from its accumulators (the Fourier
    sums read, whatever ``forecast_only`` asks), as a map written without them."""
    from aion_cli.engine.state import DROP_REASONS  # state.py imports this module

    head = parse_state_meta(meta)
    config = head.config
    # the components' readers only look members up by name: any mapping will do
    arrays = cast(dict[str, np.ndarray], arrays)
    check_member_shapes(arrays)  # what the components' readers index without checking
    entries = EntryStore.from_arrays(arrays, config.bins, adopt=not writable and not copy)
    params = TemporalParams.from_config(config)
    components = None
    if forecast_only and stored_forecasts and not writable and meta.get("deferred") is None:
        components = fremen_components.FremenComponents.from_arrays(arrays, entries.n, params)
    temporal = TemporalState.from_arrays(
        arrays,
        "temporal_",
        entries.n,
        params.values,
        params.n_periods,
        params.n_profile,
        len(params.flow),
        len(params.direction),
        copy=copy,
        fourier=components is None,
    )
    week_evidence.check_width(temporal.week_sums, params.calendar.bins_per_day, "temporal_")
    if writable:
        temporal.resize(entries.capacity)
    pending = PendingDay.from_arrays(arrays, "pending_", head.pending_day, params.values, entries.n)
    deferred = None
    if meta.get("deferred") is not None:
        deferred = DeferredDays.from_arrays(arrays, meta["deferred"], params.values, entries.n)
    try:
        state = cls(
            config=config,
            entries=entries,
            temporal=temporal,
            pending=pending,
            nodes=NodeTable.from_arrays(arrays),
            redirects=Redirects.from_arrays(arrays),
            observation=ObservationSource.from_arrays(arrays),
            graph=graph_from_arrays(arrays, head.graph),
            open_window=head.open_window,
            log_time_ns=head.log_time_ns,
            accepted=head.accepted,
            dropped={**dict.fromkeys(DROP_REASONS, 0), **head.dropped},
            writable=writable,
            deferred=deferred,
            components=components,
        )
    except (KeyError, ValueError) as exc:
        raise MapCorruptError(f"map state arrays are incomplete or invalid: {exc}") from exc
    provisional = ProvisionalScores.from_arrays(arrays, entries.n, params)
    if provisional is not None and state.pending and deferred is None and stored_forecasts:
        state._provisional = (state._view_key(), provisional)
    priors = PoolPriors.from_arrays(arrays)
    if priors is not None and not writable and deferred is None and stored_priors:
        state._priors = (state._view_key(), priors)
    check_ownership(state)
    check_loaded(state, arrays)
    state.rebuild_routes()
    return state
