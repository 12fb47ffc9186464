"""Closing time windows: turn the open window's counts into FreMEn observations.

Closing the open window ``w0`` when time reaches window ``stop`` (> w0):

1. ownership is settled first (:func:`bind_cells` at the end of ``w0``), so the window is
   recorded on the entry that will own it;
2. per live entry an observation mask per window in ``[w0, stop)`` that some source covers
   (robot poses within ``sensor_range``, or a fixed-sensor interval); an entry with detections
   in ``w0`` was observed whatever the sources say;
3. activity rows get ``1 - exp(-n / activity_scale)`` for ``w0`` and real zeros for the
   following empty windows — the whole run in one ``FremenModel.update`` call per chunk of
   windows, not a loop per entry; unobserved entries are skipped;
4. direction rows get ``count_b / Σ count`` for ``w0`` only where the entry had directed
   detections (headings known); empty windows say nothing about directions;
5. ``windows_observed`` grows, the open-window counts are cleared, poses before ``stop`` are
   forgotten, and ``stop`` becomes the open window.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.entries import fremen_rows
from aion_cli.engine.fremen import to_model_seconds
from aion_cli.engine.ownership import bind_cells
from aion_cli.engine.types import F64, I64, BoolA
from aion_cli.engine.windows import window_centre_ns, window_ns, window_start_ns

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState

WINDOW_CHUNK = 256
"""Windows per FreMEn update call when a long run of empty windows is closed at once."""


def close_windows(state: MapState, stop: int) -> None:
    """Close every window from the open one up to (not including) window ``stop``."""
    w0 = state.open_window
    if w0 is None or stop <= w0:
        return
    delta = window_ns(state.config.window_s)
    bind_cells(state, int(window_start_ns(w0 + 1, delta)))
    rows = state.entries.live_rows()
    totals = state.entries.window_totals(rows)
    covered = np.union1d(
        state.observation.covered_windows(w0, stop, delta), np.array([w0], np.int64)
    )
    for start in range(0, len(covered), WINDOW_CHUNK):
        _update_activity(state, rows, totals, covered[start : start + WINDOW_CHUNK], w0, delta)
    _update_directions(state, rows, w0, delta)
    state.entries.clear_window()
    state.open_window = int(stop)
    state.observation.prune(int(window_start_ns(stop, delta)))


def activity_values(counts: F64, activity_scale: float) -> F64:
    """The saturating activity state of a window with ``counts`` detections."""
    out: F64 = -np.expm1(-np.asarray(counts, dtype=np.float64) / activity_scale)
    return out


def _observed_matrix(state: MapState, rows: I64, windows: I64, delta: int) -> BoolA:
    xy = state.entries.xyz[rows, :2]
    cols = [
        state.observation.observed(xy, int(w), delta, state.config.sensor_range) for w in windows
    ]
    return np.stack(cols, axis=1) if cols else np.zeros((len(rows), 0), bool)


def _update_activity(
    state: MapState, rows: I64, totals: F64, windows: I64, w0: int, delta: int
) -> None:
    if len(rows) == 0 or len(windows) == 0:
        return
    observed = _observed_matrix(state, rows, windows, delta)
    values = np.zeros(observed.shape)
    first = windows == w0
    if first.any():
        col = int(np.flatnonzero(first)[0])
        observed[:, col] |= totals > 0
        values[:, col] = activity_values(totals, state.config.activity_scale)
    t_s = to_model_seconds(window_centre_ns(windows, delta))
    act_rows = fremen_rows(rows, state.bins)[:, 0]
    state.model.update(state.fremen, act_rows, t_s, values, observed)
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
    state.model.update(state.fremen, dir_rows, t_s, values, np.ones(values.shape, bool))
