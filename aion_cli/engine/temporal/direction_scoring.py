"""The direction part of closing a day (:mod:`~aion_cli.engine.temporal.scoring`): each
directed detection's log-probability under every direction family's forecast made before the
day, dir_score_d += Σ_{w,b} n_{w,b} log q_{d,b}(t_w), evaluated only at the (pair, bin)
positions that hold detections (:class:`DetectionBins`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.row_sums import row_sums
from aion_cli.engine.temporal.forecast import Forecaster
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.types import F64, I64

_DIRECTION_PAIRS = 1 << 13
"""Pairs whose direction probabilities are evaluated together (temporaries under 1 MB)."""
_LOG_FLOOR = 1e-12
"""Probabilities below this count as it in log-likelihoods (raw histograms, κ = 0, have
zeros)."""


def direction_day_scores(
    params: TemporalParams,
    fc: Forecaster,
    candidates: I64,
    ce: I64,
    cs: I64,
    cv: F64,
    t_s: F64,
    h: I64,
) -> tuple[F64, F64] | None:
    """One day's direction scores of ``candidates``: float64[C, D] of Σ n_{w,b} log q_{d,b}(t_w)
    per direction family, and float64[C] of the directed detections scored; None when the
    day's pairs (``ce`` candidate rows, ``cs`` slots, ``cv`` value counts) hold no directed
    detection. An entry with fewer directed detections before the day than κ_t, in a group
    of fewer than κ_G (:mod:`~aion_cli.engine.temporal.group_shift`), scores its
    time-varying families as its static one."""
    b = params.bins
    directed = cv[:, :b]
    per_pair = row_sums(directed)  # each pair's directed detections (row by row: any subset)
    has = per_pair > 0
    if not has.any():
        return None
    if not has.all():
        ce, cs, directed, per_pair = ce[has], cs[has], directed[has], per_pair[has]
    static = params.direction.index("static")
    day_score = np.zeros((candidates.size, len(params.direction)))
    # an entry with fewer directed detections than the time prior's weight cannot have a
    # time-varying histogram far from its static one, unless its group's hours shift it (a
    # group of κ_G directed detections or more): its other families score as static
    # (the forecaster's sums of the same whole numbers)
    evidence = fc.directed >= fc.kappa_t
    if fc.pool.shift is not None:
        evidence |= fc.pool.shift.telling[fc.groups]
    rich = evidence[ce]
    pair_h, pair_t = h[cs], t_s[cs]  # the same arrays for every family (memoised FreMEn terms)
    counted = DetectionBins.of(directed)
    if rich.all():  # every pair's entry has the evidence (busy maps): no subset to copy
        rich_e, rich_h, rich_t, rich_counted = ce, pair_h, pair_t, counted
    else:
        rich_e, rich_h, rich_t = ce[rich], pair_h[rich], pair_t[rich]
        rich_counted = counted.subset(rich)
    timed = [d for d in range(len(params.direction)) if d != static and params.direction_enabled[d]]
    if params.direction_enabled[static]:
        logp = _pair_log_probs(fc, [params.direction[static]], ce, pair_h, pair_t, counted)
        day_score[:, static] = np.bincount(ce, logp[:, 0], minlength=candidates.size)
    if timed:
        names = [params.direction[d] for d in timed]
        logp = _pair_log_probs(fc, names, rich_e, rich_h, rich_t, rich_counted)
        for j, d in enumerate(timed):
            day_score[:, d] = np.bincount(rich_e, logp[:, j], minlength=candidates.size)
    for d in range(len(params.direction)):
        if d != static and params.direction_enabled[d]:
            day_score[~evidence, d] = day_score[~evidence, static]
    # float64 already (bincount with weights): astype only tells the type checker so
    detections = np.bincount(ce, per_pair, minlength=candidates.size)
    return day_score, detections.astype(np.float64, copy=False)


@dataclass(frozen=True)
class DetectionBins:
    """The nonzero entries of a [P, B] array of directed counts, in row-major order: pair
    ``pair`` (ascending) has ``count`` detections in bin ``bin``. Found once per block and
    shared by every direction family (a pair's detections fill one or two of B bins)."""

    pair: I64
    bin: I64
    count: F64

    @classmethod
    def of(cls, directed: F64) -> DetectionBins:
        b = directed.shape[1]
        flat = np.ascontiguousarray(directed).reshape(-1)
        at = np.flatnonzero(flat)
        pair, column = np.divmod(at, b)
        return cls(pair, column, flat[at])

    def subset(self, keep: npt.NDArray[np.bool_]) -> DetectionBins:
        """The same for the pairs where ``keep`` holds, renumbered in their order."""
        new_index = np.cumsum(keep) - 1
        on = keep[self.pair]
        return DetectionBins(new_index[self.pair[on]], self.bin[on], self.count[on])


def _pair_log_probs(
    fc: Forecaster, names: list[str], e: I64, h: I64, t_s: F64, counted: DetectionBins
) -> F64:
    """Σ_b n_b log q_b per pair for each direction family of ``names``: float64[P, len(names)].

    Pairs are evaluated ``_DIRECTION_PAIRS`` at a time, every family on one chunk before the
    next, so the per-bin FreMEn terms (memoised per chunk: one pass serves every order) and the
    [P, B] temporaries stay small: whole-day temporaries of hundreds of MB cost more in fresh
    pages than in arithmetic. Each pair's value does not depend on the chunking. Only the
    bins a pair has detections in are evaluated and logged (``Forecaster.directions_at``,
    every family of a chunk at once: the gathers they share made once)."""
    out = np.empty((e.size, len(names)))
    starts = np.arange(0, e.size + _DIRECTION_PAIRS, _DIRECTION_PAIRS)
    cut = np.searchsorted(counted.pair, starts)
    for k, a in enumerate(range(0, e.size, _DIRECTION_PAIRS)):
        part = slice(a, a + _DIRECTION_PAIRS)
        pe, ph, pt = e[part], h[part], t_s[part]
        nz = slice(int(cut[k]), int(cut[k + 1]))
        pair, b, n = counted.pair[nz] - a, counted.bin[nz], counted.count[nz]
        for j, q in enumerate(fc.directions_at(names, pe, ph, pt, pair, b)):
            logp = n * np.log(np.maximum(q, _LOG_FLOOR))
            out[part, j] = np.bincount(pair, logp, minlength=pe.size)
    return out
