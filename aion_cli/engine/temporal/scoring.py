"""Closing a day: score its windows against the forecast made before it, then absorb them.

For every entry observed on the day and observed at least once before it, with λ_f(t) each
flow family's forecast from the accumulators *without* the day and n_w the window counts:

    flow_score_f += Σ_w [n_w log max(λ_f, ε) − max(λ_f, ε)]       (Poisson, ε = rate_floor)
    flow_chi2_f  += Σ_w min((n_w − λ_f)² / max(λ_f, ε), K²)         (Pearson, for the spread)
    flow_scored  += the number of windows w
    dir_score_d  += Σ_{w,b} n_{w,b} log q_{d,b}(t_w)                 (direction bins)

over the entry's observed windows (under ``ModelConfig.exposure`` λ_f is the forecast times
the share of its window the entry was watched; ``flow_scored`` still counts each window once,
as its Pearson term has mean φ whatever that share: φ = χ² / windows, not χ² / Σ share, which
for Poisson counts watched a tenth of each window would say 10). Each window's squared Pearson
residual is capped at K² = :data:`PEARSON_CAP` (a Huber-type bound): one day forecast from
an empty day before it (λ at the floor ε, hundreds of people) gave residuals of 10^9 and a
spread whose 90th percentile was 0 beside a forecast of 600; Poisson noise and real
over-dispersion (|r| up to 10) pass unchanged. Empty windows are not capped (their term is λ,
summed in closed form). (The sum of λ over the many empty windows is taken in closed form per
profile bin, and for FreMEn from the day's Fourier sums wherever its lower
bound shows the floor cannot bite; only the rest is evaluated window by window). An entry with
fewer directed detections before the day than κ_t (``direction_time_prior``, or its estimate from
the state before the day: ``Forecaster.kappa_t``), in a group without an hourly direction shift
of κ_G detections or more (:mod:`~aion_cli.engine.temporal.group_shift`), scores its
time-varying direction families as its static one (their histograms cannot differ much from it;
:mod:`~aion_cli.engine.temporal.direction_scoring` scores the directions). The
accumulators then absorb the day (:mod:`~aion_cli.engine.temporal.absorption`). Candidates
are scored in blocks of ``_ENTRIES``, each entry's pairs in their order, so the scores do not
depend on the block size.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.grouping import cut_by_key
from aion_cli.engine.row_sums import row_sums
from aion_cli.engine.temporal.absorption import absorb_day, slot_times, slot_utc_seconds
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.calendar_view import pooled_view
from aion_cli.engine.temporal.direction_scoring import direction_day_scores
from aion_cli.engine.temporal.forecast import Forecaster
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.temporal.pooling import PoolStats, entry_sums
from aion_cli.engine.temporal.shape_prior import pooled_week_bins
from aion_cli.engine.temporal.slot_sums import FixedSlots, sum_in_order
from aion_cli.engine.types import F64, I64

C128 = npt.NDArray[np.complex128]
_PAIRS = 1 << 15
_ENTRIES = 1 << 12
"""Candidates scored together: a block's temporaries stay tens of MB whatever the map's size
(whole-map temporaries of GB cost more in fresh pages than in arithmetic)."""
PEARSON_CAP = 100.0
"""K²: a window's squared Pearson residual counts at most this in ``flow_chi2`` (|r| ≤ 10)."""


def close_day(
    params: TemporalParams,
    state: TemporalState,
    day: DayWindows,
    live_rows: I64,
    groups: I64,
    n_groups: int,
    window_ns: int,
) -> None:
    """Score the day's windows (see the module docstring), then absorb them into ``state``."""
    if day.windows.size == 0:
        return
    t_s, h = slot_times(params, day, window_ns)
    _score(params, state, day, live_rows, groups, n_groups, t_s, h)
    absorb_day(params, state, day, t_s, h, slot_utc_seconds(day, window_ns))


def score_day(
    params: TemporalParams,
    state: TemporalState,
    day: DayWindows,
    live_rows: I64,
    groups: I64,
    n_groups: int,
    window_ns: int,
) -> I64:
    """Only the scoring half of :func:`close_day`: the day's scores are added to ``state``'s
    score arrays, its accumulators are left as they are. Returns the rows scored."""
    if day.windows.size == 0:
        return np.zeros(0, np.int64)
    t_s, h = slot_times(params, day, window_ns)
    return _score(params, state, day, live_rows, groups, n_groups, t_s, h)


# -- scoring ------------------------------------------------------------------------------------
def _score(
    params: TemporalParams,
    state: TemporalState,
    day: DayWindows,
    live_rows: I64,
    groups: I64,
    n_groups: int,
    t_s: F64,
    h: I64,
) -> I64:
    """Score the day for every live entry observed on it and before it; returns those rows.
    A ``week`` map scores with the calendar its evidence before the day gives
    (:mod:`.calendar_view`: pooled into weekdays and weekends where it does not ask for the
    week); the scores land in ``state``."""
    written = state
    params, state = pooled_view(params, state)
    if state is not written:
        h = pooled_week_bins(h, params.calendar.bins_per_day)
    if day.fixed.any():
        candidates = live_rows
    else:
        candidates = np.intersect1d(np.union1d(day.obs_entry, day.cnt_entry), live_rows)
    position = np.searchsorted(live_rows, candidates)
    prior = state.windows_observed(candidates) > 0
    candidates, position = candidates[prior], position[prior]
    if candidates.size == 0:
        return candidates
    # every live entry's detections per value bin, summed once: the pooling and each block's
    # forecaster read them (the same sums, row by row, as each would compute)
    counts, totals = entry_sums(state, live_rows)
    pool = PoolStats.of(params, state, live_rows, groups, n_groups, counts, totals)
    obs_order, obs_cut = _pairs_by_block(candidates, day.obs_entry)
    cnt_order, cnt_cut = _pairs_by_block(candidates, day.cnt_entry)
    rot = np.exp(-1j * np.multiply.outer(t_s, params.omega))  # (S, K): e^{−iωt}, once a day
    for k, a in enumerate(range(0, candidates.size, _ENTRIES)):
        o = obs_order[obs_cut[k] : obs_cut[k + 1]]
        c = cnt_order[cnt_cut[k] : cnt_cut[k + 1]]
        block = day.select(o, c)
        rows = candidates[a : a + _ENTRIES]
        at = position[a : a + _ENTRIES]
        fc = Forecaster(params, state, rows, groups[at], pool, counts=counts[at])
        fc.cache_profiles(at)  # every profile bin of every candidate is asked for
        fc.use_rotations(t_s, rot)  # its FreMEn terms at the day's pairs: the same table
        _score_block(params, state, block, rows, fc, t_s, h, rot)
    if state is not written:
        written.touch(candidates)  # the view's generation is its own
    return candidates


def _pairs_by_block(candidates: I64, entries: I64) -> tuple[I64, I64]:
    """The pairs of ``entries`` that belong to candidates, in candidate order (stable: each
    entry's pairs keep their order, so per-entry sums are unchanged), and the cut of every
    block of ``_ENTRIES`` candidates in that order."""
    at = np.searchsorted(candidates, entries)
    hit = (at < candidates.size) & (candidates[np.minimum(at, candidates.size - 1)] == entries)
    pairs = np.flatnonzero(hit)
    blocks = -(-candidates.size // _ENTRIES)
    order, cut = cut_by_key(at[pairs], np.arange(blocks + 1) * _ENTRIES)
    return pairs[order], cut


def _score_block(
    params: TemporalParams,
    state: TemporalState,
    day: DayWindows,
    candidates: I64,
    fc: Forecaster,
    t_s: F64,
    h: I64,
    rot: C128,
) -> None:
    """Score one block of candidates (sorted; ``day`` holds only their pairs, as
    :func:`_pairs_by_block` cut them, so every pair's entry is found among them); ``rot``:
    e^{−iω_k t} of the day's slots."""
    # observed windows of each candidate: the fixed slots plus its own pairs, each own pair
    # weighed by its exposure (the part of its window observed: expected detections λ·w),
    # each fixed slot by the share of its window the logs recorded
    obs_e, obs_s, obs_w = day.own_pairs()
    obs_e = np.searchsorted(candidates, obs_e)
    fixed_slots, fixed_share = day.fixed_slots()
    n_prof = params.n_profile
    per_bin = np.zeros((candidates.size, n_prof))
    per_bin += np.bincount(h[fixed_slots], fixed_share, minlength=n_prof)[None, :]
    if obs_e.size:  # a fixed sensor's day has none: adding their zeros changes no bit (x ≥ +0)
        per_bin += np.bincount(
            obs_e * n_prof + h[obs_s], obs_w, minlength=candidates.size * n_prof
        ).reshape(candidates.size, n_prof)
    windows = row_sums(per_bin)
    # the windows themselves, whole: one Pearson term each, so φ = χ² / windows stays ~1
    # for Poisson counts however little of each window an entry was watched
    terms = fixed_slots.size + np.bincount(obs_e, minlength=candidates.size)
    # count pairs, by candidate position
    ce, cs, cv = np.searchsorted(candidates, day.cnt_entry), day.cnt_slot, day.cnt_values
    cw = day.count_weights()
    n_total = row_sums(cv)
    floor = params.config.rate_floor
    day_score = np.zeros((candidates.size, len(params.flow)))
    pair_h, pair_t = h[cs], t_s[cs]  # the same arrays for every family (memoised FreMEn terms)
    fixed = (fixed_slots, fixed_share)
    fremen = _fremen_sums(fc, per_bin, windows, fixed, (obs_e, obs_s, obs_w), rot, floor)
    observed_bins = np.flatnonzero(per_bin.any(axis=0))  # the same for every family
    bin_windows = per_bin.T[observed_bins]  # (bin × entry), gathered once for every family
    for f, name in enumerate(params.flow):
        if not params.flow_enabled[f]:
            continue
        lam_pairs = np.maximum(fc.flow(name, ce, pair_h, pair_t), floor)
        lam_pairs *= cw
        sum_lam = _observed_sum(fc, name, per_bin, floor, fremen, observed_bins, bin_windows)
        log_part = np.bincount(ce, n_total * np.log(lam_pairs), minlength=candidates.size)
        # Σ min((n − λ)² / λ, K²) over the windows with detections, λ over the empty ones:
        # the pairs' capped terms less their λ, plus every observed window's λ
        capped = np.minimum((n_total - lam_pairs) ** 2 / lam_pairs, PEARSON_CAP) - lam_pairs
        chi_part = np.bincount(ce, capped, minlength=candidates.size)
        day_score[:, f] = log_part - sum_lam
        state.flow_chi2[candidates, f] += np.maximum(chi_part + sum_lam, 0.0)  # rounding
    _add_day(
        day_score,
        params.flow.index("static"),
        windows > 0,
        candidates,
        state.flow_score,
        state.flow_gain_sq,
        state.flow_days,
    )
    state.flow_scored[candidates] += terms
    directions = direction_day_scores(params, fc, candidates, ce, cs, cv, t_s, h)
    if directions is not None:
        dir_day, detections = directions
        _add_day(
            dir_day,
            params.direction.index("static"),
            detections > 0,
            candidates,
            state.dir_score,
            state.dir_gain_sq,
            state.dir_days,
        )
        state.dir_scored[candidates] += detections
    state.touch(candidates)


def _observed_sum(
    fc: Forecaster,
    name: str,
    per_bin: F64,
    floor: float,
    fremen: F64,
    bins: I64 | None = None,
    bin_windows: F64 | None = None,
) -> F64:
    """Σ over each entry's observed windows of max(λ, floor): in closed form per profile bin
    for the periodic families, from ``fremen`` (:func:`_fremen_sums`) for FreMEn. ``bins``:
    the profile bins some entry was observed in, when the caller found them already, and
    ``bin_windows`` = ``per_bin.T[bins]`` (a strided gather of every entry's windows, the
    same for every family: issue 15, once per day instead of once per family)."""
    if name.startswith("fremen"):
        out: F64 = fremen[int(name.removeprefix("fremen")) - 1]
        return out
    n = per_bin.shape[0]
    if bins is None:
        bins = np.flatnonzero(per_bin.any(axis=0))
    if bins.size == 0:
        return np.zeros(n)
    # every (bin, entry) pair in one evaluation, bins down and entries across (indices that
    # broadcast: no repeated pair arrays, the same values; static: one row for every bin),
    # times the windows, then the bins added in order, one row after the other (a reduction
    # over the outer axis, as the running total per bin added them: every term is ≥ +0, so
    # starting from the first term instead of 0.0 + it changes no bit)
    at_h, at_e = bins[:, None], np.arange(n)[None, :]
    lam = np.maximum(fc.flow(name, at_e, at_h, np.zeros((1, 1))), floor)
    weights = per_bin.T[bins] if bin_windows is None else bin_windows
    terms = np.ascontiguousarray(lam * weights)
    return sum_in_order(terms)


def _fremen_sums(
    fc: Forecaster,
    per_bin: F64,
    windows: F64,
    fixed: tuple[I64, F64 | None],
    own: tuple[I64, I64, F64],
    rot: C128,
    floor: float,
) -> F64:
    """Σ over each entry's observed windows of max(λ_m, floor) (times the window's exposure,
    ``own``: entry positions, slots and exposures of the own pairs; ``fixed``: the
    fixed-sensor slots and their recorded shares, None: whole; ``windows``: the row sums of
    ``per_bin``; ``rot``: e^{−iω_k t} of the day's slots) for every FreMEn order m,
    float64[M, E]. Closed form (the rate's sum plus the day's Fourier sums at the entry's
    periods) where the lower bound μ − Σ 2|γ| shows the floor cannot bite; window by window
    for the other entries, every order in one cumulative pass."""
    m_max = fc.params.max_order
    e = per_bin.shape[0]
    out = np.zeros((m_max, e))
    if m_max == 0 or e == 0:
        return out
    idx = fc.period_idx  # (E, M)
    fixed_slots, fixed_share = fixed
    fixed_rot = rot[fixed_slots] if fixed_share is None else rot[fixed_slots] * fixed_share[:, None]
    picked = fixed_rot.sum(axis=0)[idx]  # Σ e^{−iωt} at each entry's periods
    obs_e, obs_s, obs_w = own
    weighed = bool(np.any(obs_w != 1.0))
    for a in range(0, obs_e.size, _PAIRS):
        pe, ps = obs_e[a : a + _PAIRS], obs_s[a : a + _PAIRS]
        vals = rot[ps[:, None], idx[pe]]  # (P, M)
        if weighed:
            vals *= obs_w[a : a + _PAIRS, None]
        for j in range(m_max):
            picked[:, j] += np.bincount(pe, vals[:, j].real, minlength=e)
            picked[:, j] += 1j * np.bincount(pe, vals[:, j].imag, minlength=e)
    closed = np.cumsum(2.0 * (fc.coef_total * picked).real, axis=1)  # (E, M)
    out[:] = (fc.rate_total * windows)[None, :] + closed.T
    bound = fc.rate_total[:, None] - np.cumsum(2.0 * np.abs(fc.coef_total), axis=1)
    risky = np.flatnonzero((bound[:, -1] < floor) & (windows > 0))  # the largest risky set
    if risky.size == 0:
        return out
    per_window = _per_window_sums(fc, risky, fixed, own, rot, floor)  # (M, r)
    for j in range(m_max):
        use = bound[risky, j] < floor
        out[j, risky[use]] = per_window[j, use]
    return out


def _per_window_sums(
    fc: Forecaster,
    entries: I64,
    fixed: tuple[I64, F64 | None],
    own: tuple[I64, I64, F64],
    rot: C128,
    floor: float,
) -> F64:
    """Σ max(λ_m, floor) over each of ``entries``' observed windows for every order m (an
    own pair's times its exposure, a fixed slot's times its recorded share), evaluated
    window by window: float64[M, len(entries)].

    The (entry, window) pairs are every entry with every fixed-sensor slot (entry-major),
    then the entries' own pairs, summed in chunks of ``_PAIRS`` pairs, each chunk's sums
    (pair order) added to the total. The fixed-sensor pairs of a chunk are evaluated as one
    (order × slot × entry) block (:class:`~aion_cli.engine.temporal.slot_sums.FixedSlots`:
    the slots' phasors gathered once per block and order, no per-pair copies of
    coefficients and rates, sums along the slot axis), which gives the same floating-point
    sums as adding pair by pair (issue 15: this was the largest part of closing a day under
    a fixed sensor, where every entry has every window)."""
    fixed_slots, fixed_share = fixed
    slot_of = np.full(fc.rows.size, -1, np.int64)
    slot_of[entries] = np.arange(entries.size)
    obs_e, obs_s, obs_w = own
    mine = slot_of[obs_e] >= 0
    own_e, own_s, own_w = obs_e[mine], obs_s[mine], obs_w[mine]
    m_max = fc.params.max_order
    n_fixed = fixed_slots.size
    fixed_pairs = entries.size * n_fixed
    n_pairs = fixed_pairs + own_e.size
    block = FixedSlots(
        rot[fixed_slots], fixed_share, fc.period_idx[entries], fc.coef_total[entries],
        fc.rate_total[entries],
    )
    total = np.zeros((m_max, entries.size))
    for a in range(0, n_pairs, _PAIRS):
        b = min(a + _PAIRS, n_pairs)
        if b <= fixed_pairs:  # fixed pairs only: the chunk's sums touch entries [i0, i1)
            i0, i1 = a // n_fixed, (b - 1) // n_fixed + 1
            before, upto = a - i0 * n_fixed, b - (i1 - 1) * n_fixed  # of the end entries
            # added where they fall (the other entries' +0.0 would change no bit: sums ≥ +0)
            total[:, i0:i1] += block.sums(i0, i1, before, upto, floor)
            continue
        chunk = np.zeros((m_max, entries.size))
        if a < fixed_pairs:  # entries [i0, i1) have fixed pairs in [a, min(b, fixed_pairs))
            fb = min(b, fixed_pairs)
            i0, i1 = a // n_fixed, (fb - 1) // n_fixed + 1
            before, upto = a - i0 * n_fixed, fb - (i1 - 1) * n_fixed  # of the end entries
            chunk[:, i0:i1] = block.sums(i0, i1, before, upto, floor)
        if b > fixed_pairs:
            e = own_e[max(a, fixed_pairs) - fixed_pairs : b - fixed_pairs]
            s = own_s[max(a, fixed_pairs) - fixed_pairs : b - fixed_pairs]
            w = own_w[max(a, fixed_pairs) - fixed_pairs : b - fixed_pairs]
            z = rot[s[:, None], fc.period_idx[e]]  # (P, M), as the fixed slots' terms
            coef_e = fc.coef_total[e]
            terms = np.cumsum(coef_e.real * (2.0 * z.real) - coef_e.imag * (2.0 * z.imag), axis=1)
            lam_own = np.maximum(fc.rate_total[e][:, None] + terms, floor)  # (P, M)
            lam_own *= w[:, None]
            local = slot_of[e]
            for j in range(m_max):
                np.add.at(chunk[j], local, lam_own[:, j])  # in pair order, after the fixed
        total += chunk
    return total


def _add_day(
    day_score: F64,
    static: int,
    scored: npt.NDArray[np.bool_],
    candidates: I64,
    score: F64,
    gain_sq: F64,
    days: F64,
) -> None:
    """Add one day's scores, the squares of the day's gains over ``static`` and the day."""
    score[candidates] += day_score
    gain_sq[candidates] += squared_gains(day_score, static)
    days[candidates] += scored


def squared_gains(day_score: F64, static: int) -> F64:
    """One day's squared gain of every family over ``static``, per row: what ``*_gain_sq``
    adds for the day (and what a map's stored provisional scores derive it from)."""
    gain = day_score - day_score[:, static : static + 1]
    out: F64 = gain**2
    return out
