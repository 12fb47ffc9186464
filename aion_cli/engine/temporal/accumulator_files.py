"""Reading and writing :class:`~aion_cli.engine.temporal.accumulators.TemporalState` as map
members: sparse (only entries and value bins that saw anything), integral tallies narrowed,
indices as ``uint32`` when they fit, large members gathered block by block when written."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from aion_cli.engine.temporal import day_level, shape_prior, week_evidence
from aion_cli.engine.temporal.accumulators import _SCORES, _TALLIES, TemporalState
from aion_cli.engine.temporal.observation_block import ObsBlock
from aion_cli.engine.temporal.stored_layout import (
    first_nonfinite,
    lists_all,
    narrowed,
    nonzero_pairs,
    sparse_layout,
    stored_index,
    stored_member,
    stored_positions,
)
from aion_cli.engine.types import I64, RowTake
from aion_cli.engine.zeros import lazy_zeros
from aion_cli.errors import MapCorruptError


def state_to_arrays(state: TemporalState, prefix: str, rows: I64) -> dict[str, Any]:
    """Members ``prefix + name`` for rows ``rows``, sparse and gathered block by block
    when written (no second copy of the state):

    * ``obs_index`` — positions (in ``rows``) of entries with windows of their own, and
      their observation blocks (a fixed sensor's map has none: its windows are global);
    * ``cnt_index`` — flat positions ``pos·V + v`` of the (entry, value bin) pairs that
      ever counted a detection, with their ``cnt_fourier`` and ``cnt_profile`` rows (a
      direction nobody walked costs nothing);
    * ``score_index`` — positions of entries with day-ahead scores, and the scores.

    Integral counts and window tallies (profiles, windows, detections and days scored)
    are stored as ``uint8``, ``uint16`` or ``uint32`` (lossless; float64 when a value is
    not a whole number below 2^32), indices as ``uint32`` when they fit."""
    if not state.fourier_loaded:
        raise ValueError(
            "a temporal state read for queries (without its Fourier sums) cannot be stored"
        )
    r = np.asarray(rows, dtype=np.int64)
    pos = np.arange(r.size, dtype=np.int64)
    out: dict[str, Any] = state.glob.to_arrays(prefix + "glob_")
    out[prefix + shape_prior.MEMBER] = state.window_chi2.copy()
    level = state.day_level
    out[prefix + day_level.MEMBER] = level.copy() if level.size else day_level.empty_sums(
        state.n_bins
    )
    if state.week_sums.size:  # none before a closed day (the map reads as no evidence)
        out[prefix + week_evidence.MEMBER] = state.week_sums.copy()
    own = state.obs.n[r] > 0
    out[prefix + "obs_index"] = stored_positions(pos[own], r.size)
    out.update(state.obs.to_arrays(prefix + "obs_", r[own]))
    out[prefix + "obs_profile"] = narrowed(state.obs.profile, r[own])
    v, k, h = state.n_values, state.n_periods, state.n_bins
    flat_profile = state.cnt_profile.reshape(-1, h)
    pairs = nonzero_pairs(flat_profile, r, v)
    out[prefix + "cnt_index"] = stored_positions(pairs.positions, r.size * v)
    out[prefix + "cnt_fourier"] = RowTake(state.cnt_fourier.reshape(-1, k), pairs.rows)
    out[prefix + "cnt_profile"] = narrowed(flat_profile, pairs.rows)
    scored = (state.flow_days[r] > 0) | (state.dir_days[r] > 0)
    scored |= (state.flow_scored[r] > 0) | (state.dir_scored[r] > 0)
    out[prefix + "score_index"] = stored_positions(pos[scored], r.size)
    for name in _SCORES:
        source = getattr(state, name)
        tally = name in _TALLIES  # windows, detections and days scored: whole numbers
        out[prefix + name] = (
            narrowed(source, r[scored]) if tally else RowTake(source, r[scored])
        )
    return out


def state_from_arrays(
    arrays: Mapping[str, np.ndarray],
    prefix: str,
    rows: int,
    values: int,
    periods: int,
    bins: int,
    flow_families: int,
    dir_families: int,
    copy: bool = True,
    fourier: bool = True,
) -> TemporalState:
    """Inverse of :func:`state_to_arrays`; :class:`MapCorruptError` on missing or
    inconsistent members (shapes must match the config, indices must be in range).

    ``copy=False``: the members are fresh arrays the state may keep (a map just read);
    members that cover every row (a dense map) then become the state's arrays as they
    are, without a scatter into zeros or a second copy. Without ``fourier`` the
    per-entry Fourier sums (``cnt_fourier``, ``obs_fourier``: most of a map's bytes) are
    not read, and the state is a query's (:attr:`fourier_loaded`): its ``cnt_profile``
    keeps the unsigned integer type it was stored in (exact whole counts; absorbing a
    day widens it only when a count would not fit)."""
    arrays = sparse_layout(arrays, prefix, rows, values)
    own_periods = periods if fourier else 0
    out = TemporalState.empty(rows, values, own_periods, bins, flow_families, dir_families)
    out.glob = ObsBlock.from_arrays(arrays, prefix + "glob_", 1, periods, bins)
    out.window_chi2 = shape_prior.stored_window_chi2(arrays, prefix)
    out.day_level = day_level.stored_sums(arrays, prefix, bins)
    out.week_sums = week_evidence.stored_sums(arrays, prefix, bins)
    own = stored_index(arrays, prefix + "obs_index", rows)
    block = ObsBlock.from_arrays(
        arrays, prefix + "obs_", own.size, periods, bins, copy, fourier
    )
    if lists_all(own, rows):
        out.obs = block
    else:
        out.obs.put(own, block)
    pairs = stored_index(arrays, prefix + "cnt_index", rows * values)
    profile = stored_member(
        arrays, prefix + "cnt_profile", (pairs.size, bins), copy, keep_narrow=not fourier
    )
    stored: dict[str, Any] = {"cnt_profile": profile}
    dense_pairs = lists_all(pairs, rows * values)
    if fourier:
        sums = stored_member(arrays, prefix + "cnt_fourier", (pairs.size, periods), copy)
        if sums.dtype != np.complex128:
            raise MapCorruptError(f"{prefix}cnt_fourier must be complex128")
        stored["cnt_fourier"] = sums
        if dense_pairs:  # every pair counted: the members are the arrays
            out.cnt_fourier = sums.reshape(rows, values, periods)
        else:
            out.cnt_fourier.reshape(-1, periods)[pairs] = sums
    else:
        out.fourier_loaded = False
    if dense_pairs:
        out.cnt_profile = profile.reshape(rows, values, bins)
    else:
        if profile.dtype != out.cnt_profile.dtype:  # a query's narrow counts stay narrow
            out.cnt_profile = lazy_zeros(out.cnt_profile.shape, profile.dtype)
        out.cnt_profile.reshape(-1, bins)[pairs] = profile
    scored = stored_index(arrays, prefix + "score_index", rows)
    shapes = {
        "flow_score": (flow_families,),
        "flow_chi2": (flow_families,),
        "flow_scored": (),
        "flow_days": (),
        "flow_gain_sq": (flow_families,),
        "dir_score": (dir_families,),
        "dir_scored": (),
        "dir_days": (),
        "dir_gain_sq": (dir_families,),
    }
    dense = lists_all(scored, rows)
    for name, tail in shapes.items():
        value = stored_member(arrays, prefix + name, (scored.size, *tail), copy)
        if value.dtype.kind != "f":
            raise MapCorruptError(f"{prefix}{name} must be real")
        stored[name] = value
        if dense:
            setattr(out, name, value)
        else:
            getattr(out, name)[scored] = value
    # the stored values are checked (the rows not stored are zeros)
    bad = first_nonfinite(stored)
    # unsigned counts (how maps store them) cannot be negative: no pass over the largest
    # member for it (its boolean temporary was 43 MB of fresh pages on a 10^5-entry map)
    negative = profile.dtype.kind != "u" and bool(np.any(profile < 0))
    if bad or negative or np.any(block.n < 0) or out.glob.n[0] < 0:
        raise MapCorruptError(
            f"temporal state holds non-finite or negative values ({', '.join(bad) or 'counts'})"
        )
    # rows past every stored one hold zeros (sorted indices: each one's last is its largest)
    last_pair = int(pairs[-1]) // values if pairs.size else -1
    stored_rows = [int(i[-1]) for i in (own, scored) if i.size]
    out.high_water = max([last_pair, *stored_rows]) + 1
    return out
