"""An hour's direction shift borrowed from the entry's group (issue 12, stop 68).

When one place is split over several map cells, each cell holds too few directed detections
an hour to learn that the place is walked east in the morning and west in the evening: its
time-varying histogram stays near its static one. The cell's group (room or neighbourhood,
:mod:`~aion_cli.engine.temporal.groups`) sees the whole place, so the time-varying direction
families shrink toward the entry's static histogram *modulated by its group's hour*:

    ĝ[g, h, b] = (C[g, h, b] + κ_G p[g, b]) / (C[g, h] + κ_G)     (the group's hour, shrunk)
    m[g, h, b] = ĝ[g, h, b] / p[g, b]                              (its shift, 1 without one)
    π[e, h, b] = h[e, b] m[g, h, b] / Σ_b' h[e, b'] m[g, h, b']    (the entry's prior there)

with C the group's directed detections per profile bin (its entries' counts summed, whole
numbers: exact in any order), p its static histogram (``PoolStats.histogram``) and h the
entry's static one. The time-varying families then give (c_b + κ_t π_b) / (Σ c + κ_t) where
they gave (c_b + κ_t h_b) / (Σ c + κ_t) (:mod:`.forecast`). A multiplicative shift keeps
each entry's own directions: a cell of the group's east-west corridor takes the morning's
east, a cell of its north-south one the morning's north.

κ_G is the Dirichlet-multinomial estimate of :func:`.direction_prior.fitted_kappa` over the
(group, profile bin) rows around their group's histogram, as κ_t is over an entry's: over the
rows observed only. A kind of day no window observed takes, for its shift, the counts of its
hour on the kinds that were (:func:`.shape_prior.by_hour`), but those are the same
detections again (a copy, or a sum of the seen rows), not draws of their own: the marginal
likelihood of a bin without windows is 1 (no counts), and counting the copies would weigh the
copied hours twice and let a map pass :data:`.direction_prior.MIN_ENTRIES` on half as many
rows as it holds (stop 71). Where no
group's directions keep to the hour the likelihood keeps rising to the top of the range: the
map then has no shift (``None``) and every forecast is the one before (the static histogram
is the prior, as it was). The shift is recomputed from the accumulators wherever the groups'
shapes are, so continuation and merges stay exact; only κ_G's estimate is kept with a map
when it is written (:mod:`.pool_priors`), so a query does not search for it again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.row_sums import row_sums
from aion_cli.engine.temporal.direction_prior import KAPPA_RANGE, TIME_KAPPA_LOW, fitted_kappa
from aion_cli.engine.temporal.shape_prior import by_hour
from aion_cli.engine.types import F64, I64

_NO_SHIFT = KAPPA_RANGE[1] * 0.999
"""κ_G at (the golden-section search's tolerance below) the top of its range: the groups'
hours do not differ from their histograms, so there is no shift."""


@dataclass(frozen=True)
class GroupShift:
    """The groups' hourly direction shift m[G, H, B] (module docstring), κ_G, and which
    groups hold at least κ_G directed detections (whose shift can move an entry's prior)."""

    ratio: F64
    kappa: float
    telling: npt.NDArray[np.bool_]

    @classmethod
    def of(
        cls,
        hourly: F64,
        histogram: F64,
        unseen: npt.NDArray[np.bool_] | None,
        bins_per_day: int,
        kappa: float | None = None,
    ) -> GroupShift | None:
        """From C[g, b, h] (:func:`group_hourly`) and the groups' histograms p[g, b]; None
        where κ_G says no group's hours differ (or too few (group, bin) rows tell).
        ``kappa``: κ_G as estimated from these counts before (a map stores it:
        :mod:`.pool_priors`), or None to estimate it."""
        g, b, h = hourly.shape
        parent = np.repeat(histogram, h, axis=0)
        if kappa is None:
            # the rows observed only: an unseen bin's copy of the seen hours (``by_hour``)
            # is no draw of its own, and would count them twice (module docstring)
            own = hourly.transpose(0, 2, 1).reshape(-1, b)
            kappa = fitted_kappa(own, parent, fallback=KAPPA_RANGE[1], low=TIME_KAPPA_LOW)
        if kappa >= _NO_SHIFT:
            return None
        counts = by_hour(hourly, unseen, bins_per_day).transpose(0, 2, 1)  # [G, H, B]
        rows = counts.reshape(-1, b)
        total = row_sums(rows, keepdims=True)
        shrunk = (rows + kappa * parent) / (total + kappa)
        ratio = np.divide(shrunk, parent, out=np.ones_like(shrunk), where=parent > 0)
        # the groups' own detections: not ``counts``, whose unseen bins repeat the seen ones
        return cls(ratio.reshape(g, h, b), kappa, hourly.sum(axis=(1, 2)) >= kappa)


_CHUNK = 256
"""Entries gathered together by :func:`group_hourly` (a few hundred kB a chunk)."""


def group_hourly(values: Any, rows: I64, groups: I64, n_groups: int, bins: int) -> F64:
    """Σ of the counts ``values[E, V, H]`` of entries ``rows`` over each group (``groups``,
    one per row), directed bins only: float64[G, B, H] (whole numbers: the same sums in any
    order). The rows are read in group order, a chunk at a time (no copy of the whole map's
    counts), and each group's run in a chunk added by one ``reduceat`` (half the time of
    one ``bincount`` over (group, bin, hour) keys on a map of the 20-day benchmark log's
    size)."""
    h = values.shape[2]
    out: F64 = np.zeros((n_groups, bins, h))
    order = np.argsort(groups, kind="stable")
    ranked = groups[order]
    # counts read narrow (a map's: small unsigned integers) summed in integers, exactly and
    # faster than widened to floats first (a query of 10^5 entries: 0.055 -> 0.043 s)
    wide: Any = np.float64
    if values.dtype.kind == "u":  # 256 rows of 16-bit counts stay below 2^32
        wide = np.uint32 if values.dtype.itemsize <= 2 else np.uint64
    for a in range(0, order.size, _CHUNK):
        rank = ranked[a : a + _CHUNK]
        starts = np.flatnonzero(np.concatenate(([True], rank[1:] != rank[:-1])))
        chunk = values[rows[order[a : a + _CHUNK]], :bins]
        out[rank[starts]] += np.add.reduceat(chunk, starts, axis=0, dtype=wide)
    return out


def hourly_priors(static: F64, shift: GroupShift, groups: I64) -> F64:
    """π[(e, h), b] for every profile bin h of each entry (rows entry-major): what
    :func:`hour_prior` gives at pairs (e, h) for h = 0 .. H-1, the same operations on one
    [E, H, B] array (κ_t's estimate reads every bin of a sample of entries)."""
    b = static.shape[1]
    prior: F64 = shift.ratio[groups]  # a gathered copy
    prior *= static[:, None, :]
    flat: F64 = prior.reshape(-1, b)
    flat /= row_sums(flat, keepdims=True)
    return flat


def hour_prior(static: F64, shift: GroupShift | None, groups: I64, h: I64) -> F64:
    """π[P, B]: each pair's static histogram ``static`` (a copy the caller may keep)
    modulated by its group's shift at profile bin ``h`` and renormalised; ``static`` itself
    without a shift."""
    if shift is None:
        return static
    prior: F64 = static * shift.ratio[groups, h]
    prior /= row_sums(prior, keepdims=True)
    return prior
