"""Closing time windows: turn the open window's counts into FreMEn observations.

Closing the run of windows ``[w0, stop)`` (``w0`` the open window) when time reaches ``stop``:

1. the *recorded* windows are ``w0`` if any entry has detections in it, plus every window some
   observation source covers (robot poses within ``sensor_range``, or a fixed-sensor interval);
   other windows teach nothing and are skipped;
2. ownership is checked at the end of each recorded window, before that window is recorded
   (so a window is recorded on the entry that owns it from then on). The node table does not
   change during a run, so the set of stable nodes only grows: the check is re-run only when it
   has grown, and FreMEn updates are split only where a check actually binds cells;
3. activity rows get ``1 - exp(-n / activity_scale)`` for ``w0`` and real zeros for the
   following empty windows — consecutive recorded windows in one ``FremenModel.update`` call
   (per chunk of windows), with an observation mask per entry and window; an entry with
   detections in ``w0`` was observed in it whatever the sources say; unobserved entries are
   skipped;
4. direction rows get ``count_b / Σ count`` for ``w0`` only where the entry had directed
   detections (headings known); empty windows say nothing about directions;
5. ``windows_observed`` grows, the open-window counts are cleared, poses before ``stop`` are
   forgotten, and ``stop`` becomes the open window.

Because bind checks happen only at recorded-window ends (and at graph updates), closing
``[w0, k)`` and later ``[k, stop)`` gives the same state as closing ``[w0, stop)`` at once: a
build can stop anywhere and continue.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.entries import fremen_rows
from aion_cli.engine.fremen import to_model_seconds
from aion_cli.engine.ownership import apply_binds, plan_binds, stable_nodes
from aion_cli.engine.types import F64, I64, BoolA
from aion_cli.engine.windows import window_centre_ns, window_ns, window_start_ns

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState

WINDOW_CHUNK = 256
"""Windows per FreMEn update call when a long run of recorded windows is closed at once."""


def close_windows(state: MapState, stop: int) -> None:
    """Close every window from the open one up to (not including) window ``stop``."""
    w0 = state.open_window
    if w0 is None or stop <= w0:
        return
    delta = window_ns(state.config.window_s)
    rows = state.entries.live_rows()
    had_detections = bool(np.any(state.entries.window_totals(rows) > 0))
    recorded = state.observation.covered_windows(w0, stop, delta)
    if had_detections:
        recorded = np.union1d(recorded, np.array([w0], np.int64))
    segment: list[int] = []
    stable_seen = -1
    for w in recorded.tolist():
        end = int(window_start_ns(w + 1, delta))
        n_stable = int(np.count_nonzero(stable_nodes(state, end)))
        if n_stable != stable_seen:
            stable_seen = n_stable
            plan = plan_binds(state, end)
            if plan is not None:
                _record(state, np.array(segment, np.int64), w0, delta)
                segment = []
                apply_binds(state, plan)
        segment.append(w)
    _record(state, np.array(segment, np.int64), w0, delta)
    state.entries.clear_window()
    state.open_window = int(stop)
    state.observation.prune(int(window_start_ns(stop, delta)))


def activity_values(counts: F64, activity_scale: float) -> F64:
    """The saturating activity state of a window with ``counts`` detections."""
    out: F64 = -np.expm1(-np.asarray(counts, dtype=np.float64) / activity_scale)
    return out


def _record(state: MapState, windows: I64, w0: int, delta: int) -> None:
    """Record consecutive recorded windows on the current entries (FreMEn + windows observed)."""
    rows = state.entries.live_rows()
    if len(rows) == 0 or len(windows) == 0:
        return
    totals = state.entries.window_totals(rows)
    for start in range(0, len(windows), WINDOW_CHUNK):
        chunk = windows[start : start + WINDOW_CHUNK]
        _update_activity(state, rows, totals, chunk, w0, delta)
    if windows[0] == w0:
        _update_directions(state, rows, w0, delta)


def _observed_matrix(state: MapState, rows: I64, windows: I64, delta: int) -> BoolA:
    xy = state.entries.xyz[rows, :2]
    cols = [
        state.observation.observed(xy, int(w), delta, state.config.sensor_range) for w in windows
    ]
    return np.stack(cols, axis=1) if cols else np.zeros((len(rows), 0), bool)


def _update_activity(
    state: MapState, rows: I64, totals: F64, windows: I64, w0: int, delta: int
) -> None:
    observed = _observed_matrix(state, rows, windows, delta)
    values = np.zeros(observed.shape)
    if windows[0] == w0:
        observed[:, 0] |= totals > 0
        values[:, 0] = activity_values(totals, state.config.activity_scale)
    t_s = to_model_seconds(window_centre_ns(windows, delta))
    act_rows = fremen_rows(rows, state.bins)[:, 0]
    state.defer_update(act_rows, t_s, values, observed)
    state.entries.windows_observed[rows] += observed.sum(axis=1)


def _update_directions(state: MapState, rows: I64, w0: int, delta: int) -> None:
    counts = state.entries.window_counts[rows]
    directed = counts.sum(axis=1)
    has = directed > 0
    if not has.any():
        return
    fractions = counts[has] / directed[has, None]
    dir_rows = fremen_rows(rows[has], state.bins)[:, 1:].reshape(-1)
    t_s = to_model_seconds(window_centre_ns(np.array([w0]), delta))
    values = fractions.reshape(-1, 1)
    state.defer_update(dir_rows, t_s, values, np.ones(values.shape, bool))
