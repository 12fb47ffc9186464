"""What entries borrow from their parents, and the block-wise sums that pool them.

:class:`PoolStats` holds each group's periodic shape and direction histogram and the map's
shape (the :mod:`~aion_cli.engine.temporal.forecast` docstring gives the formulas); the small
array helpers here read accumulator rows without copying consecutive ones and sum whole
counts exactly in integer accumulators, for the pooling and for the forecaster alike.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.row_sums import row_sums
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.direction_prior import (
    FALLBACK,
    TIME_FALLBACK,
    entry_prior,
    group_prior,
    telling_rows,
    time_prior,
)
from aion_cli.engine.temporal.group_shift import GroupShift, group_hourly, hourly_priors
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pool_priors import PoolPriors
from aion_cli.engine.temporal.shape_prior import group_shapes, overdispersion, unseen_bins
from aion_cli.engine.types import F64, I64

_POOL_BLOCK = 1 << 13
"""Entries pooled together (a block's temporaries stay a few MB)."""


@dataclass(frozen=True)
class PoolStats:
    """What entries borrow from their parents: each group's periodic shape ``shape[G, H]``
    and direction histogram ``histogram[G, B]`` (formulas: :mod:`.forecast`)."""

    shape: F64
    histogram: F64
    map_shape: F64
    kept: tuple[F64, Any] | None = None
    """W[e, h] and S[e, h] of every pooled entry (observed windows and detections per profile
    bin, as :meth:`Forecaster.cache_profiles` computes them) when the entries were pooled in
    one block: a day's scoring then reads its candidates' rows instead of computing them a
    second time (issue 15). None for a map of more entries (no whole-map copies)."""
    kappa: float = FALLBACK
    """κ of the entries' direction histograms toward their group's (``direction_prior``: the
    configured number, or estimated from the pooled entries, :mod:`.direction_prior`)."""
    kappa_t: float = TIME_FALLBACK
    """κ_t of an hour's direction histogram toward the entry's static one
    (``direction_time_prior``: the configured number, or estimated from the pooled entries'
    profile bins, :func:`.direction_prior.time_prior`)."""
    unseen: npt.NDArray[np.bool_] | None = None
    """The profile bins of a kind of day the map never observed (no pooled entry had a window
    in them: a Saturday of a map of weekdays), bool[H], or None: an entry's ``profile`` takes
    its own counts and windows at the same hour of the kinds seen there
    (:func:`~aion_cli.engine.temporal.shape_prior.by_hour`), as the map's and groups' shapes do."""
    shift: GroupShift | None = None
    """The groups' hourly direction shift that an entry's time-varying direction histograms
    shrink toward (:mod:`.group_shift`), or None: no group's directions keep to the hour (or
    no time-varying direction family is enabled), and they shrink toward the static one."""

    @classmethod
    def of(
        cls,
        params: TemporalParams,
        state: TemporalState,
        rows: I64,
        groups: I64,
        n_groups: int,
        counts: F64 | None = None,
        totals: Any = None,
        priors: PoolPriors | None = None,
    ) -> PoolStats:
        """Pool the entries ``rows`` (all live entries) into their groups. ``counts``: their
        :func:`entry_counts`, when the caller has them already (a query's forecast needs them
        for every entry too; a day's scoring builds them block by block instead); ``totals``:
        their detections per profile bin S[e, h], when :func:`entry_sums` summed them with
        the counts; ``priors``: κ, κ_t and κ_G as estimated from these very accumulators
        (a map stores them: :mod:`.pool_priors`), taken instead of estimated again."""
        b, h = params.bins, params.n_profile
        s_g, w_g = np.zeros((n_groups, h)), np.zeros((n_groups, h))
        c_g = np.zeros((n_groups, b))
        timed = bool(params.direction_enabled[1:].any())  # families after ``static``
        if priors is not None and priors.kappa_g is None:
            timed = False  # no shift: the groups' hourly counts are not needed
        # every entry at once: one sort by group, not one per block (whole numbers: the same
        # sums in any grouping)
        hourly = None
        # a query's counts read narrow (whole numbers) and more entries than a block, with
        # their counts summed: the groups' counts per (value, hour) give the groups' S and
        # their directed counts too, exactly (integer sums), not block by block (issue 15)
        whole = (
            timed and counts is not None and rows.size > _POOL_BLOCK
            and state.cnt_profile.dtype.kind == "u"
        )
        if whole:
            every = group_hourly(state.cnt_profile, rows, groups, n_groups, params.values)
            hourly = np.ascontiguousarray(every[:, :b])
            s_g, c_g = every.sum(axis=1), hourly.sum(axis=2)
        elif timed:
            hourly = group_hourly(state.cnt_profile, rows, groups, n_groups, b)
        directed_blocks = []
        glob = state.glob.profile[0]
        kept = None
        for a in range(0, rows.size, _POOL_BLOCK):
            r, g = rows[a : a + _POOL_BLOCK], groups[a : a + _POOL_BLOCK]
            w_e = rows_of(state.obs.profile, r) + glob
            w_g += group_sums(g, n_groups, w_e)
            if whole:
                continue
            block = rows_of(state.cnt_profile, r) if totals is None or counts is None else None
            s_e = count_sums(block, 1) if totals is None else totals[a : a + _POOL_BLOCK]
            s_g += group_sums(g, n_groups, s_e)
            directed = (
                count_sums(block, 2)[:, :b] if counts is None else counts[a : a + _POOL_BLOCK, :b]
            )
            c_g += group_sums(g, n_groups, directed)
            if counts is None:  # kept for the direction prior's estimate (counts hold them)
                directed_blocks.append(np.asarray(directed, np.float64))
            if rows.size <= _POOL_BLOCK:
                kept = (w_e, s_e)
        phi = overdispersion(state.window_chi2)
        shapes, map_shape = group_shapes(s_g, w_g, phi, params.calendar.bins_per_day)
        histograms = _group_histograms(group_prior(params.config), c_g)
        unseen = unseen_bins(w_g.sum(axis=0), params.calendar.bins_per_day)

        def all_directed() -> F64:
            if counts is not None:
                return counts[:, :b]
            return np.concatenate(directed_blocks) if directed_blocks else np.zeros((0, b))

        pooled = (params, state, rows, groups, histograms, unseen, hourly)
        kappa, kappa_t, shift = _estimates(*pooled, all_directed, priors)
        return cls(shapes, histograms, map_shape, kept, kappa, kappa_t, unseen, shift)


def pooled_priors(
    params: TemporalParams, state: TemporalState, rows: I64, groups: I64, n_groups: int,
    counts: F64,
) -> PoolPriors:
    """κ, κ_t and κ_G as :meth:`PoolStats.of` estimates them over the same entries
    (``counts``: their :func:`entry_counts`), without what only a forecast reads: the
    groups' periodic shapes and their detections per profile bin (what a map's writer
    stores, :mod:`~aion_cli.engine.view_priors`; issue 15, stop 71). The groups' directed
    counts and the map's windows per profile bin are sums of whole numbers, the same in any
    grouping: summed here over all the entries at once, not per group and block."""
    b = params.bins
    timed = bool(params.direction_enabled[1:].any())  # families after ``static``
    hourly = group_hourly(state.cnt_profile, rows, groups, n_groups, b) if timed else None
    directed = counts[:, :b]
    c_g = group_sums(groups, n_groups, directed)
    histograms = _group_histograms(group_prior(params.config), c_g)
    windows = rows.size * state.glob.profile[0]
    for a in range(0, rows.size, _POOL_BLOCK):
        windows = windows + rows_of(state.obs.profile, rows[a : a + _POOL_BLOCK]).sum(axis=0)
    unseen = unseen_bins(windows, params.calendar.bins_per_day)
    pooled = (params, state, rows, groups, histograms, unseen, hourly)
    kappa, kappa_t, shift = _estimates(*pooled, lambda: directed, None)
    kappa_g = None if shift is None else shift.kappa
    return PoolPriors(kappa, kappa_t, kappa_g, int(rows.size), int(n_groups))


def _estimates(
    params: TemporalParams,
    state: TemporalState,
    rows: I64,
    groups: I64,
    histograms: F64,
    unseen: npt.NDArray[np.bool_] | None,
    hourly: F64 | None,
    directed: Callable[[], F64],
    priors: PoolPriors | None,
) -> tuple[float, float, GroupShift | None]:
    """κ, κ_t and the groups' shift (κ_G) of a pooling: taken from ``priors`` when given,
    else estimated from the entries' directed counts ``directed()`` (gathered only then)
    around their groups' ``histograms``, and the groups' ``hourly`` counts (None: no
    time-varying direction family, no shift)."""

    @cache  # gathered once for κ and κ_t's input
    def directed_counts() -> tuple[F64, F64]:
        return directed(), histograms[groups]

    @cache  # κ's rows are the entries of κ_t's input: chosen once (issue 15)
    def told() -> I64:
        return telling_rows(*directed_counts())

    kappa = (
        priors.kappa if priors is not None
        else entry_prior(params.config, directed_counts, lambda *_: told())
    )
    shift = None
    if hourly is not None:
        kappa_g = None if priors is None else priors.kappa_g
        shift = GroupShift.of(hourly, histograms, unseen, params.calendar.bins_per_day, kappa_g)

    def per_bin() -> tuple[F64, F64]:
        counts, parent = directed_counts()
        return per_bin_directed(state, rows, counts, parent, kappa, groups, shift, told())

    kappa_t = priors.kappa_t if priors is not None else time_prior(params.config, per_bin)
    return kappa, kappa_t, shift


def entry_counts(state: TemporalState, rows: I64, block: int = 1 << 10) -> F64:
    """N[e, v]: the detections of entries ``rows`` in each value bin (their profile bins
    summed, exactly), float64[E, V], block by block (no [E, V, H] temporary)."""
    return entry_sums(state, rows, block, totals=False)[0]


def entry_sums(
    state: TemporalState, rows: I64, block: int = 1 << 10, totals: bool = True
) -> tuple[F64, Any]:
    """:func:`entry_counts` and, for at most one pooling block of entries (no whole-map [E,
    H] array), S[e, h], their detections per profile bin (all value bins), as
    :meth:`PoolStats.of` sums them: each block of the counts summed both ways while it is in
    cache (issue 15: a day close read every entry's counts twice). S is None for more
    entries or without ``totals``."""
    out = np.empty((rows.size, state.cnt_profile.shape[1]))
    keep = totals and rows.size <= _POOL_BLOCK
    parts = []
    for a in range(0, rows.size, block):
        counts = rows_of(state.cnt_profile, rows[a : a + block])
        out[a : a + block] = count_sums(counts, 2)
        if keep:
            parts.append(count_sums(counts, 1))
    return out, np.concatenate(parts) if parts else None


def borrowed(r: F64, mean: F64) -> F64:
    """r / r̄ per pair, 1 where r̄ is ~0 (an entry observed nowhere its group is busy)."""
    ok = mean > 1e-12
    out: F64 = np.divide(r, mean, out=np.ones(np.broadcast(r, mean).shape), where=ok)
    return out


def rows_of(values: Any, rows: I64) -> Any:
    """``values[rows]`` for reading: a view (no copy) when ``rows`` are consecutive, as the
    rows of a map read back are (its entries are stored in canonical order), so preparing
    a forecast does not copy the largest accumulators block by block."""
    n = rows.size
    if n and int(rows[-1]) - int(rows[0]) == n - 1 and (n == 1 or bool(np.all(np.diff(rows) == 1))):
        return values[int(rows[0]) : int(rows[-1]) + 1]
    return values[rows]


def count_sums(counts: Any, axis: int) -> Any:
    """Sums of whole counts along ``axis``: counts held as small unsigned integers (a query's,
    read narrow) are summed in a 32- or 64-bit integer accumulator, which is exact and
    faster than widening them first; float counts as they are (whole numbers: exact too)."""
    if counts.dtype.kind == "u":
        wide = np.uint32 if counts.dtype.itemsize <= 2 else np.uint64
        return counts.sum(axis=axis, dtype=wide)
    if counts.ndim == 3 and counts.dtype == np.float64:
        # whole numbers below 2^53 sum to the same float in any order: einsum's plain loops
        # (about twice as fast as sum's here, issue 15) give the bits sum gives. Fractional
        # counts (the STeF-style grid's in `aion evaluate atc`) may differ from sum's
        # pairwise order in the last bit (its NLL moved by 2e-16 at stop 64)
        return np.einsum(_SUBSCRIPTS[axis], counts)
    return counts.sum(axis=axis)


_SUBSCRIPTS = {0: "evh->vh", 1: "evh->eh", 2: "evh->ev"}


def group_sums(groups: I64, n_groups: int, values: F64) -> F64:
    """Σ of the rows of ``values`` per group, float64[G, C]: each group's rows added in row
    order from zero, as the sparse indicator product this replaces added them (so the sums
    are the same to the bit), in one ``bincount`` over (group, column) keys and without
    importing ``scipy.sparse`` (a fifth of a second, for a query)."""
    c = values.shape[1]
    keys = (groups[:, None] * c + np.arange(c, dtype=np.int64)).reshape(-1)
    weights = np.ascontiguousarray(values, dtype=np.float64).reshape(-1)
    sums = np.bincount(keys, weights=weights, minlength=n_groups * c)
    out: F64 = sums.astype(np.float64, copy=False).reshape(n_groups, c)
    return out


def _group_histograms(kappa: float, c_g: F64) -> F64:
    b = c_g.shape[1]
    total = c_g.sum(axis=0)
    p_map = (total + 1.0) / (total.sum() + b)
    return posterior(c_g, np.broadcast_to(p_map, c_g.shape), kappa)


def normalised(counts: F64) -> F64:
    """Rows divided by their sums (zeros where a row has no count)."""
    total = row_sums(counts, keepdims=True)
    out: F64 = np.divide(counts, total, out=np.zeros_like(counts), where=total > 0)
    return out


def per_bin_directed(
    state: TemporalState,
    rows: I64,
    directed: F64,
    parent: F64,
    kappa: float,
    groups: I64 | None = None,
    shift: GroupShift | None = None,
    tell: I64 | None = None,
) -> tuple[F64, F64]:
    """The input of κ_t's estimate: N[(e, h), b], the directed detections of entry ``e``
    (of ``rows``) in profile bin ``h``, and the prior its hour's histogram shrinks toward on
    each of its rows: the entry's static histogram (``directed`` under ``kappa``
    pseudo-detections of ``parent``, as ``Forecaster.histogram``), modulated by its group's
    (``groups``) hourly ``shift`` when there is one (:func:`.group_shift.hour_prior`); for
    about ``MAX_ENTRIES`` of the entries with two directed detections or more, chosen by
    their counts (any order of the entries gives the same rows): ``tell``, the rows
    :func:`.direction_prior.telling_rows` chooses, when the caller has them."""
    b = directed.shape[1]
    if tell is None:
        tell = telling_rows(directed, parent)
    per_bin = np.asarray(rows_of(state.cnt_profile, rows[tell]), np.float64)[:, :b]
    static = posterior(directed[tell], parent[tell], kappa)
    if shift is not None and groups is not None:
        prior = hourly_priors(static, shift, groups[tell])
    else:
        prior = np.repeat(static, per_bin.shape[2], 0)
    return per_bin.transpose(0, 2, 1).reshape(-1, b), prior


def posterior(counts: F64, prior: F64, kappa: float) -> F64:
    """Dirichlet posterior mean (counts + κ·prior) / (N + κ); with κ = 0 the raw proportions
    where there are counts, the prior elsewhere."""
    total = row_sums(counts, keepdims=True)
    if kappa > 0:
        out: F64 = (counts + kappa * prior) / (total + kappa)
        return out
    return np.where(total > 0, normalised(counts), prior)
