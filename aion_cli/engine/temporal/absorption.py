"""Absorbing closed windows into the temporal accumulators (after scoring, or for a query).

The fixed-sensor windows go into the global observation block, other observed windows into
the entries' own blocks, and the counts into ``cnt_fourier`` / ``cnt_profile`` — sparse, by
(entry, value bin) pairs with detections, in blocks of ``_ROWS`` consecutive rows so that a
block's temporaries (a K-vector per (row, value bin)) stay small on any map. Every sum is
taken per row in the pairs' order, so the accumulators do not depend on the block size. How
bursty the day's window totals were is added to ``window_chi2``
(:mod:`~aion_cli.engine.temporal.shape_prior`), and its level per profile bin to
``day_level`` (:mod:`~aion_cli.engine.temporal.day_level`); the day's totals per hour of
the week, scored against the map's before they are added, to ``week_sums``
(:mod:`~aion_cli.engine.temporal.week_evidence`).
Scoring a day before it is absorbed is :mod:`~aion_cli.engine.temporal.scoring`'s job.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.grouping import split_by_key, unique_inverse
from aion_cli.engine.temporal.accumulators import ObsBlock, TemporalState
from aion_cli.engine.temporal.day_level import add_sums, day_sums
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows, joined
from aion_cli.engine.temporal.shape_prior import day_chi2
from aion_cli.engine.temporal.week_evidence import add_day, week_bins
from aion_cli.engine.types import F64, I64
from aion_cli.engine.windows import to_model_seconds, window_centre_ns

C128 = npt.NDArray[np.complex128]
_ROWS = 1 << 12
"""Consecutive rows absorbed together."""


def slot_times(params: TemporalParams, day: DayWindows, window_ns: int) -> tuple[F64, I64]:
    """Each window slot's model time (the window's centre on FreMEn's clock,
    ``TemporalParams.model_seconds``) and profile bin: what absorbing and scoring a day index
    its slots by."""
    centres = window_centre_ns(day.windows, window_ns)
    return params.model_seconds(centres), params.calendar.profile_bin(centres)


def slot_utc_seconds(day: DayWindows, window_ns: int) -> F64:
    """Each window slot's centre in model seconds on UTC: the observed ends
    (``ObsBlock.first`` / ``last``) and spans, which reports show as times."""
    return to_model_seconds(window_centre_ns(day.windows, window_ns))


def absorb(
    params: TemporalParams,
    state: TemporalState,
    day: DayWindows,
    window_ns: int,
    map_sums: bool = True,
) -> None:
    """Absorb the day's windows without scoring them (a query's view of the state);
    ``map_sums`` false: the entries' and the global block's sums alone (:func:`absorb_day`),
    the day being part of a day whose map-wide sums :func:`absorb_parts` adds once."""
    if day.windows.size == 0:
        return
    t_s, h = slot_times(params, day, window_ns)
    absorb_day(params, state, day, t_s, h, slot_utc_seconds(day, window_ns), map_sums)


def absorb_parts(
    params: TemporalParams, state: TemporalState, parts: list[DayWindows], window_ns: int
) -> None:
    """A query's ``parts`` (the pending day, then the open window) absorbed in turn
    (``query_state.query_view``): parts of one local day (:func:`_local_days`) are one day of
    the map-wide sums (``week_sums``, ``window_chi2``, ``day_level``), added once for the
    day they make (``pending.joined``), as closing the window and the day will add it: each
    part had added a day of its own, so the open window of a map's pending day was a second
    day of the level sample (``day_level``: its cells' days observed 2, the spread between
    the two parts' rates taken for a spread between days), of the week sums (a day of the
    week seen once passed for two, ``week_evidence.MIN_DAYS``, and the open window was
    scored against sums holding its own day's windows), and of the burstiness (its slot
    compared with no other slot of its profile bin). The entries' sums are added part by
    part, as before (the stored FreMEn components are taken so)."""
    for day in _local_days(params, parts, window_ns):
        for part in day:
            absorb(params, state, part, window_ns, map_sums=len(day) == 1)
        if len(day) > 1:
            whole = joined(day)
            _, h = slot_times(params, whole, window_ns)
            _add_map_sums(params, state, whole, h, slot_utc_seconds(whole, window_ns))


def view_week_sums(
    params: TemporalParams, state: TemporalState, parts: list[DayWindows], window_ns: int
) -> F64:
    """``state.week_sums`` as a query's view holds them (:func:`absorb_parts`), without
    absorbing anything else: each local day of the parts scored against the sums and the
    burstiness before it and added, as :func:`absorb_day` adds it. What a ``week`` map's
    forecasts choose their calendar by (:mod:`.calendar_view`); ``state`` is unchanged."""
    sums, chi2 = state.week_sums, state.window_chi2
    for day in _local_days(params, parts, window_ns):
        whole = joined(day)
        _, h = slot_times(params, whole, window_ns)
        utc_s = slot_utc_seconds(whole, window_ns)
        sums, chi2 = _week_step(params, sums, chi2, whole, h, utc_s)
    return sums


def _local_days(
    params: TemporalParams, parts: list[DayWindows], window_ns: int
) -> list[list[DayWindows]]:
    """The ``parts`` with windows in runs of one local day each: a part that begins on the
    local day the part before it ended on is more of that day."""
    days: list[list[DayWindows]] = []
    last = None
    for part in parts:
        if part.windows.size == 0:
            continue
        ends = params.calendar.day(window_centre_ns(part.windows[[0, -1]], window_ns))
        if days and int(ends[0]) == last:
            days[-1].append(part)
        else:
            days.append([part])
        last = int(ends[-1])
    return days


def _week_step(
    params: TemporalParams, sums: F64, chi2: F64, day: DayWindows, h: I64, utc_s: F64
) -> tuple[F64, F64]:
    """The week sums with ``day`` scored against them and added, and the burstiness sums
    with the day's added (new arrays)."""
    week = week_bins(params.calendar, h, utc_s)
    sums = add_day(sums, day, week, chi2, params.calendar.bins_per_day)
    return sums, chi2 + day_chi2(day, h, params.n_profile)


def _add_map_sums(
    params: TemporalParams, state: TemporalState, day: DayWindows, h: I64, utc_s: F64
) -> None:
    """The day's map-wide sums added: its totals per hour of the week scored against the
    week's bins, then added; how bursty its window totals are; and their level."""
    state.week_sums, chi2 = _week_step(params, state.week_sums, state.window_chi2, day, h, utc_s)
    state.window_chi2[...] = chi2  # in place: a writer may hold the array
    state.day_level = add_sums(state.day_level, day_sums(day, h, params.n_profile))


def absorb_day(
    params: TemporalParams,
    state: TemporalState,
    day: DayWindows,
    t_s: F64,
    h: I64,
    utc_s: F64,
    map_sums: bool = True,
) -> None:
    """Absorb the day's windows (model times ``t_s``, profile bins ``h``, UTC model seconds
    ``utc_s`` per slot: :func:`slot_times`, :func:`slot_utc_seconds`); ``map_sums`` false:
    all but the map-wide sums (:func:`absorb_parts`). A query's state read without its
    per-entry Fourier sums (``TemporalState.fourier_loaded`` false) absorbs everything else:
    its FreMEn components were computed with the windows when the map was written
    (:mod:`~aion_cli.engine.temporal.components`)."""
    n_prof = params.n_profile
    phasor = np.exp(1j * np.multiply.outer(t_s, params.omega))  # (S, K): e^{iωt}
    fixed, share = day.fixed_slots()
    if fixed.size:
        # each window for the share of it the logs recorded (whole where they all are)
        block = ObsBlock(
            np.array([day.fixed_windows()]),
            (phasor[fixed] if share is None else phasor[fixed] * share[:, None]).sum(
                axis=0, keepdims=True
            ),
            np.bincount(h[fixed], share, minlength=n_prof)[None, :].astype(np.float64),
            np.array([utc_s[fixed].min()]),
            np.array([utc_s[fixed].max()]),
        )
        state.glob.add_block(np.array([0]), block)
    if map_sums:
        _add_map_sums(params, state, day, h, utc_s)
    obs_e, obs_s, obs_w = day.own_pairs()
    for o in _row_blocks(obs_e):
        _absorb_observed(params, state, obs_e[o], obs_s[o], obs_w[o], utc_s, h, phasor)
    for c in _row_blocks(day.cnt_entry):
        values = np.take(day.cnt_values, c, axis=0)  # rows of V values: take is ~2x faster
        _absorb_counts(params, state, day.cnt_entry[c], day.cnt_slot[c], values, h, phasor)
    state.touch(obs_e if obs_e.size else None)


def _row_blocks(rows: I64) -> list[I64]:
    """Indices of ``rows`` grouped by blocks of ``_ROWS`` consecutive row numbers, each
    row's pairs in their order (a stable sort: sums per row are unchanged), so one block's
    temporaries — e.g. a K-vector per (row, value bin) — stay small on any map."""
    return split_by_key(rows // _ROWS)


def _absorb_observed(
    params: TemporalParams,
    state: TemporalState,
    obs_e: I64,
    obs_s: I64,
    obs_w: F64,
    utc_s: F64,
    h: I64,
    phasor: C128,
) -> None:
    """The entries' own observed windows into their observation blocks, each weighed by its
    exposure (a window observed in part adds that part of a window); their ends at the slots'
    UTC model seconds ``utc_s``."""
    n_prof = params.n_profile
    rows, inverse = unique_inverse(obs_e)
    n: F64 = np.bincount(inverse, obs_w, minlength=rows.size).astype(np.float64, copy=False)
    if state.fourier_loaded:
        fourier = _sum_phasors(inverse, obs_s, obs_w, rows.size, phasor)
    else:
        fourier = np.zeros((rows.size, 0), np.complex128)
    flat_bins = inverse * n_prof + h[obs_s]
    prof: F64 = np.bincount(flat_bins, obs_w, minlength=rows.size * n_prof).astype(
        np.float64, copy=False
    )
    prof = prof.reshape(rows.size, n_prof)
    first = np.full(rows.size, np.inf)
    np.minimum.at(first, inverse, utc_s[obs_s])
    last = np.full(rows.size, -np.inf)
    np.maximum.at(last, inverse, utc_s[obs_s])
    state.obs.add_block(rows, ObsBlock(n, fourier, prof, first, last))


def _absorb_counts(
    params: TemporalParams,
    state: TemporalState,
    cnt_entry: I64,
    cnt_slot: I64,
    cnt_values: F64,
    h: I64,
    phasor: C128,
) -> None:
    """Counts into ``cnt_fourier`` / ``cnt_profile``, by (entry, value bin) with detections."""
    n_prof = params.n_profile
    pair, value = np.nonzero(cnt_values)
    counts = cnt_values[pair, value]
    rows = cnt_entry[pair]
    slots = cnt_slot[pair]
    fresh_from = state.high_water * params.values  # the flat (entry, value) rows never written
    targets, which = unique_inverse(rows * params.values + value)
    if state.fourier_loaded:
        flat_fourier = state.cnt_fourier.reshape(-1, state.n_periods)
        _add_at(
            flat_fourier,
            targets,
            _sum_phasors(which, slots, counts, targets.size, phasor),
            targets >= fresh_from,
        )
    keys, inverse = _profile_keys(targets, which, h[slots], n_prof)
    added: F64 = np.bincount(inverse, counts, minlength=keys.size).astype(np.float64)
    flat_profile = _profile_for(state, keys, added)
    _add_at(
        flat_profile,
        keys,
        added.astype(flat_profile.dtype, copy=False),
        keys >= fresh_from * n_prof,
    )
    state.touch(rows)


def _profile_keys(targets: I64, which: I64, hours: I64, n_prof: int) -> tuple[I64, I64]:
    """``unique_inverse(targets[which] * n_prof + hours)`` (the flat profile cells of a day's
    counts; ``targets`` sorted and distinct, ``hours`` in [0, ``n_prof``)): the same sorted
    keys and inverse from each pair's rank ``which`` among the targets and its hour, which
    order the keys alike, over a range a day's few hours keep narrow enough for a bitmap
    instead of a sort (issue 15: ~80,000 keys a day at 25 people per message)."""
    if which.size == 0:
        return unique_inverse(targets[which] * n_prof + hours)
    low = int(hours.min())
    span = int(hours.max()) - low + 1
    local, inverse = unique_inverse(which * span + (hours - low))
    rank, hour = np.divmod(local, span)
    return targets[rank] * n_prof + (hour + low), inverse


def _add_at(flat: np.ndarray, at: I64, added: np.ndarray, fresh: npt.NDArray[np.bool_]) -> None:
    """``flat[at] += added`` (``at`` unique), written without reading where ``fresh`` (rows
    never written, zeros): a first query of a big map scatters counts over rows it has not
    read yet, and reading a page before writing it costs the kernel a second fault. ``0 +
    x`` is ``x + 0`` to the bit (a −0 sum becomes +0 either way)."""
    if not fresh.any():
        _add_unique(flat, at, added)
        return
    flat[at[fresh]] = added[fresh] + flat.dtype.type(0)
    old = ~fresh
    if old.any():
        _add_unique(flat, at[old], added[old])


def _add_unique(flat: np.ndarray, at: I64, added: np.ndarray) -> None:
    """``flat[at] += added`` for unique ``at``: the same additions (``flat[i] + added[j]``,
    once each). A 1-D array (the profile counts) by ``np.add.at``, one pass where the fancy
    form gathers a copy, adds and scatters it back (issue 15: several times faster on a day's
    few thousand counts); rows (the Fourier sums) by the fancy form, faster for rows."""
    if flat.ndim == 1:
        np.add.at(flat, at, added)
    else:
        flat[at] += added


def _profile_for(state: TemporalState, keys: I64, added: F64) -> F64:
    """``state.cnt_profile`` flat, ready to add ``added`` at ``keys``: a query's counts read
    narrow (``TemporalState.from_arrays`` without Fourier sums) are widened to float64 first
    when a sum would not be a whole number that fits their type."""
    profile: np.ndarray = state.cnt_profile
    if profile.dtype.kind == "u":
        top = float(profile.reshape(-1)[keys].max(initial=0)) + float(added.max(initial=0.0))
        whole = bool(np.all(added == np.rint(added))) and bool(np.all(added >= 0))
        if not whole or top > int(np.iinfo(profile.dtype).max):
            state.cnt_profile = profile = profile.astype(np.float64)
    out: F64 = profile.reshape(-1)
    return out


_SPARSE_PAIRS = 1 << 13
"""A day of more (row, slot) pairs than this sums its phasors by ``scipy.sparse``, faster than
numpy there by more than the import costs (issue 15: ~6 against ~0.7 ms for 19,000 pairs)."""


def _sum_phasors(row: I64, slot: I64, weight: F64, n_rows: int, phasor: C128) -> C128:
    """Σ over pairs (row, slot) of weight·phasor[slot] per row, complex[n_rows, K], as the
    sparse (rows × slots) matrix times the day's (slots × K) phasors computes it: each
    row's pairs in ascending slot order, each term weight·phasor added to a running sum from
    0. A day of few pairs (at most :data:`_SPARSE_PAIRS`) is summed in numpy
    (:func:`_sum_phasors_in_numpy`), so that a build of such days does not import
    ``scipy.sparse`` (0.1–0.2 s of CPU in every fresh process, issue 15); the sums are the
    same to the bit either way."""
    if row.size > _SPARSE_PAIRS:
        return _sum_phasors_sparse(row, slot, weight, n_rows, phasor)
    return _sum_phasors_in_numpy(row, slot, weight, n_rows, phasor)


def _sum_phasors_in_numpy(
    row: I64, slot: I64, weight: F64, n_rows: int, phasor: C128
) -> C128:
    """:func:`_sum_phasors` in numpy, one pass per position within a row (every row's first
    pair, then its second ones, ...: a day's rows hold few pairs). Pairs that repeat a (row,
    slot) — which a day's consolidated pairs do not — go to the sparse product, whose order
    of summing duplicates is its own."""
    out = np.zeros((n_rows, phasor.shape[1]), np.complex128)
    if row.size == 0:
        return out
    order = np.lexsort((slot, row))  # by row, each row's pairs by slot
    r, s = row[order], slot[order]
    new_row = np.empty(r.size, dtype=bool)
    new_row[0] = True
    np.not_equal(r[1:], r[:-1], out=new_row[1:])
    if bool(np.any(~new_row[1:] & (s[1:] == s[:-1]))):
        return _sum_phasors_sparse(row, slot, weight, n_rows, phasor)
    w = weight[order]
    starts = np.flatnonzero(new_row)
    position = np.arange(r.size) - np.repeat(starts, np.diff(np.append(starts, r.size)))
    by_position = np.argsort(position, kind="stable")  # rows ascending within a position
    cut = np.searchsorted(position[by_position], np.arange(int(position.max()) + 2))
    for j in range(cut.size - 1):
        at = by_position[cut[j] : cut[j + 1]]  # distinct rows: one term each
        term = phasor[s[at]]
        term *= w[at][:, None]  # phasor · weight: the product weight · phasor, to the bit
        if j == 0:  # each row's first term onto its zeros: 0 + term
            out[r[at]] = term + 0.0
        else:
            out[r[at]] += term
    return out


def _sum_phasors_sparse(row: I64, slot: I64, weight: F64, n_rows: int, phasor: C128) -> C128:
    """:func:`_sum_phasors` by one sparse (rows × slots) matrix times the phasors."""
    from scipy.sparse import csr_matrix

    matrix = csr_matrix((weight, (row, slot)), shape=(n_rows, phasor.shape[0]))
    out: C128 = np.asarray(matrix @ phasor, dtype=np.complex128)
    return out
