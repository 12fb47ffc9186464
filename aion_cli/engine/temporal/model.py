"""The temporal model's entry points: record windows, close days, forecast.

* ``MapState.record_window`` — one closed window's observations and counts join the pending
  day; log time reaching a later day closes it (:func:`close_pending`: scored against the
  model before it, then absorbed). :func:`learn` does the same for many days at once.
* :func:`~aion_cli.engine.temporal.query_state.query_view` — the accumulators as a query
  sees them: the pending day and the open window (recorded as closing it would record it)
  absorbed without scoring.
* :class:`Predictor` — per entry the flow (expected detections per window), the direction
  histogram, the families used and the predictive variance at a time (:meth:`Predictor.at`)
  or historically (:meth:`Predictor.historical`); with every temporal family switched off
  (``families = ["static"]``) the flows are equal exactly, and so are the histograms when the
  direction prior is off too (``direction_prior = 0``; otherwise predictions pool sparse
  entries' directions toward their parents).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.grouping import cut_by_key
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.calendar_view import pooled_view
from aion_cli.engine.temporal.choice import dispersion
from aion_cli.engine.temporal.components import FremenComponents
from aion_cli.engine.temporal.day_level import level_variance
from aion_cli.engine.temporal.forecast import Forecaster
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows, PendingDay
from aion_cli.engine.temporal.pool_priors import PoolPriors
from aion_cli.engine.temporal.pooling import PoolStats, entry_sums
from aion_cli.engine.temporal.query_state import choose, observed_bins
from aion_cli.engine.temporal.scoring import close_day
from aion_cli.engine.temporal.shape_prior import overdispersion
from aion_cli.engine.temporal.unseen_hours import blind_families, unseen_own_hours
from aion_cli.engine.types import F64, I64, BoolA
from aion_cli.engine.windows import window_centre_ns

_SCALE_PAIRS = 1 << 18
"""(entry, time) pairs :meth:`Predictor.scale` evaluates at once (bounded temporaries)."""


def empty_state(params: TemporalParams, rows: int) -> TemporalState:
    return TemporalState.empty(
        rows,
        params.values,
        params.n_periods,
        params.n_profile,
        len(params.flow),
        len(params.direction),
    )


def window_day(params: TemporalParams, window: int, window_ns: int) -> int:
    """The local day of a window (by its centre)."""
    centre = window_centre_ns(np.array([window], np.int64), window_ns)
    return int(params.calendar.day(centre)[0])


def close_pending(
    params: TemporalParams,
    state: TemporalState,
    pending: PendingDay,
    live_rows: I64,
    groups: I64,
    n_groups: int,
    window_ns: int,
) -> None:
    """Score and absorb the pending day, then forget it."""
    if pending:
        close_day(params, state, pending.consolidated(), live_rows, groups, n_groups, window_ns)
    pending.clear()


def learn(
    params: TemporalParams,
    state: TemporalState,
    windows: DayWindows,
    rows: I64,
    groups: I64,
    n_groups: int,
    window_ns: int,
) -> None:
    """Learn many closed windows at once (any number of days, in time order): each local day
    is scored against the model before it and absorbed, exactly as a build would record them
    one by one. ``rows``/``groups``: the population that pools shapes and histograms."""
    if windows.windows.size == 0:
        return
    if np.any(np.diff(windows.windows) <= 0):
        raise ValueError("windows must be increasing")
    days = params.calendar.day(window_centre_ns(windows.windows, window_ns))
    cuts = np.flatnonzero(np.diff(days)) + 1
    bounds = np.concatenate([[0], cuts, [days.size]])
    # pairs grouped by day, each day's in their given order (a stable sort by the day's
    # number: the (entry, slot) order of consolidated windows survives into every day)
    small = bounds.size <= np.iinfo(np.int16).max  # numpy sorts small ints stably by radix
    day_of_slot: npt.NDArray[np.integer] = np.repeat(
        np.arange(bounds.size - 1, dtype=np.int16 if small else np.int64), np.diff(bounds)
    )
    day_starts = np.arange(bounds.size)
    obs_order, obs_cut = cut_by_key(day_of_slot[windows.obs_slot], day_starts)
    cnt_order, cnt_cut = cut_by_key(day_of_slot[windows.cnt_slot], day_starts)
    for k, (a, b) in enumerate(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True)):
        o = obs_order[obs_cut[k] : obs_cut[k + 1]]
        c = cnt_order[cnt_cut[k] : cnt_cut[k + 1]]
        day = DayWindows(
            windows.windows[a:b],
            windows.fixed[a:b],
            windows.obs_entry[o],
            windows.obs_slot[o] - a,
            windows.cnt_entry[c],
            windows.cnt_slot[c] - a,
            np.take(windows.cnt_values, c, axis=0),  # rows of V values: take is ~2x faster
            windows.weights_at(o),
            None if windows.fixed_share is None else windows.fixed_share[a:b],
        )
        close_day(params, state, day, rows, groups, n_groups, window_ns)


@dataclass(frozen=True)
class Prediction:
    """Per entry at one time (or historically): ``flow`` expected detections per window (all
    value bins; NaN for an entry never observed), ``probabilities[E, B]`` the direction
    histogram, ``directed_share`` the fraction of detections with a heading, the chosen
    family names, and ``variance`` of the window count (NaN historically)."""

    flow: F64
    probabilities: F64
    directed_share: F64
    flow_family: npt.NDArray[np.str_]
    direction_family: npt.NDArray[np.str_]
    variance: F64
    observed: BoolA


@dataclass
class Predictor:
    """The time-independent part of the forecasts of entries ``rows``: every family's parts,
    the chosen families, the dispersion and whether totals are reconciled; :meth:`at` and
    :meth:`pairs` evaluate them.

    Reconciliation (``ModelConfig.reconcile``, when the map's pooled day-ahead evidence
    chooses a temporal family f_map): the entries' forecasts at time t are scaled by one factor
    so that their total is the map's forecast with f_map (``Forecaster.map_total``: the pooled
    periodic profile of the whole map for the periodic families, the entries' FreMEn sum for
    FreMEn, an entry's share by the map's profile at an hour it never observed: below) —
    the best-supported forecast of *how busy the whole map is* — while each entry
    keeps its own family's share of it. Sparse entries that chose ``static`` on noisy evidence then
    still follow the map's rhythm, and the map's total is never diluted by them.

    Extrapolation (``extrapolated``, per profile bin): at an hour of the day that the map
    observed on no day at all — a robot that never ran at night — no family's forecast was
    ever scored, and FreMEn's sinusoids, fitted to the hours observed, can swing anywhere
    there (a corridor cell empty all day but at 17–19 h was forecast at 2.7 times its mean at
    03:00). There every entry forecasts with ``static`` (its rate per observed window and its
    static histogram), unreconciled: where people generally are, at the level they generally
    are, which is what the hours observed support. A kind of day never observed at an hour
    seen on others (a Saturday morning after weekdays only) is not extrapolated in this
    sense: the families carry the other days' rhythm there (the profile falls back to the
    hour of the day).

    Hours an entry never observed (``unseen_own``, per entry and hour of the day,
    :mod:`~aion_cli.engine.temporal.unseen_hours`): an entry that chose ``static`` or a
    FreMEn family chose it on the windows it was observed in — a place the robot passes by
    day only was scored by day only, where its flat rate or its sinusoids may well beat the
    group's rhythm — and neither says anything of the hours it never saw. At an hour the map
    observed (elsewhere) but the entry never did, such an entry forecasts with ``shape``
    instead (its rate times its group's periodic shape, which the entries observed at that
    hour measured), and names that family: on the bundled sample a place seen only 07–19 h,
    with nobody anywhere at night, was forecast at half its daytime level all night (its
    constant rate took half of the reconciled night total); a desk watched 08–18 h whose
    rate rises through the day chose ``fremen1``, whose cosine stood at 9.5 % of its noon
    forecast at night (2.5 % with ``shape``). The periodic families need no such rule
    (``profile`` at a bin without windows is its ``shape`` parent). A map total reconciled to
    FreMEn takes, at an hour an entry never observed, that entry's rate times the map's shape
    (as the periodic totals do) instead of its sinusoids, which the factor would otherwise
    spread back over the others. Without the ``shape`` family (``ModelConfig.families``) the
    chosen family stays."""

    params: TemporalParams
    forecaster: Forecaster
    flow_choice: I64
    direction_choice: I64
    phi: F64
    map_family: str | None
    extrapolated: BoolA
    phi_static: F64
    unseen_own: BoolA
    phi_shape: F64
    phi_total: float = 1.0
    """How bursty the map's window totals are (``shape_prior.overdispersion``): the spread
    of a sum of places (:mod:`~aion_cli.engine.temporal.totals`)."""
    level_variance: float = 0.0
    """How much a day's level varies around the forecast's (``day_level.level_variance``):
    a sum of places of mean S adds it times S² to its variance."""

    @classmethod
    def of(
        cls,
        params: TemporalParams,
        state: TemporalState,
        rows: I64,
        groups: I64,
        n_groups: int,
        components: FremenComponents | None = None,
        priors: PoolPriors | None = None,
    ) -> Predictor:
        """The forecasts of entries ``rows`` of ``state`` (a query view); ``components``:
        FreMEn components stored in the map for these very rows (a state read without its
        Fourier sums); ``priors``: the pooling's prior strengths the map stores for this very
        view (``PoolStats.of``). A ``week`` map whose evidence does not ask for the week
        forecasts with its sums pooled into weekdays and weekends (:mod:`.calendar_view`), and
        the predictor's ``params`` are then that profile's (its bins: ``params.calendar``)."""
        params, state = pooled_view(params, state)
        counts, totals = entry_sums(state, rows)  # summed once for the pooling and the forecast
        pool = PoolStats.of(params, state, rows, groups, n_groups, counts, totals, priors)
        fc = Forecaster(params, state, rows, groups, pool, components, counts)
        flow_choice, dir_choice, map_choice = choose(
            params, state, rows, groups, n_groups, components
        )
        chi2, scored = state.flow_chi2[rows], state.flow_scored[rows]
        phi = dispersion(chi2, scored, flow_choice)
        static = np.full_like(flow_choice, params.flow.index("static"))
        phi_static = dispersion(chi2, scored, static)
        name = params.flow[map_choice]
        map_family = name if params.config.reconcile and name != "static" else None
        per_day = params.calendar.bins_per_day
        hours = np.zeros(per_day, dtype=bool)  # the hours of the day observed on any day
        hours[observed_bins(params, state, rows, [], 0) % per_day] = True
        seen = np.tile(hours, params.n_profile // per_day)
        extrapolated = ~seen if seen.any() else seen  # nothing observed: nothing to fall to
        # the hours each entry never observed: of those whose family says nothing there,
        # and of every entry when the map's total is FreMEn's (``scale``)
        blind = blind_families(params)
        fremen_total = map_family is not None and map_family.startswith("fremen")
        ask = blind[flow_choice] | (fremen_total and bool(blind.any()))
        unseen_own = unseen_own_hours(params, fc, np.flatnonzero(ask), hours)
        # shape's dispersion, read only where an entry forecasts with it in its stead
        falls = np.flatnonzero(unseen_own.any(axis=1) & blind[flow_choice])
        phi_shape = np.ones(rows.size)
        if falls.size:
            shape = np.full(falls.size, params.flow.index("shape"), dtype=np.int64)
            phi_shape[falls] = dispersion(chi2, scored, shape, at=falls)
        return cls(
            params,
            fc,
            flow_choice,
            dir_choice,
            phi,
            map_family,
            extrapolated,
            phi_static,
            unseen_own,
            phi_shape,
            phi_total := overdispersion(state.window_chi2),
            level_variance(state.day_level, phi_total),
        )

    def __post_init__(self) -> None:
        self._blind_rows = blind_families(self.params)[self.flow_choice]
        self._any_fall = bool((self.unseen_own.any(axis=1) & self._blind_rows).any())
        fremen_total = self.map_family is not None and self.map_family.startswith("fremen")
        self._unseen_total = fremen_total and bool(self.unseen_own.any())

    def _falls(self, e: I64, h: I64) -> BoolA | None:
        """Whether each pair's entry forecasts with ``shape`` at an hour it never observed
        (``unseen_own``, never an extrapolated hour); None where no entry ever does."""
        if not self._any_fall:
            return None
        out: BoolA = self.unseen_own[e, h % self.params.calendar.bins_per_day]
        out &= self._blind_rows[e]
        return out

    def _flow_choice(self, e: I64, h: I64) -> I64:
        """Each pair's flow family: the entry's choice, ``static`` in extrapolated bins,
        ``shape`` for a ``static`` or FreMEn entry at an hour it never observed."""
        choice = self._at_pairs(self.flow_choice[e], self.params.flow.index("static"), h)
        fall = self._falls(e, h)
        if fall is None:
            return choice
        out: I64 = np.where(fall, self.params.flow.index("shape"), choice)
        return out

    def _direction_choice(self, e: I64, h: I64) -> I64:
        """Each pair's direction family: the entry's, ``static`` in extrapolated bins."""
        return self._at_pairs(self.direction_choice[e], self.params.direction.index("static"), h)

    def _at_pairs(self, choice: I64, static: int, h: I64) -> I64:
        if not self.extrapolated.any():
            return choice
        out: I64 = np.where(self.extrapolated[h], static, choice)
        return out

    @property
    def reconcile(self) -> bool:
        """Whether totals are reconciled to the map's family."""
        return self.map_family is not None

    def historical(self) -> Prediction:
        """What was observed: each entry's rate per observed window and the raw proportions
        of its detections' direction bins (zeros for an entry without a heading)."""
        fc = self.forecaster
        n = fc.rows.size
        flow = np.where(fc.observed, fc.rate_total, np.nan)
        names = np.full(n, "historical")
        return Prediction(
            flow,
            fc.raw_histogram.copy(),
            fc.directed_share,
            names,
            names,
            np.full(n, np.nan),
            fc.observed,
        )

    def _flows(self, e: I64, h: I64, t_s: F64) -> F64:
        """The chosen flow families at pairs, before reconciliation (clamped at 0)."""
        fc = self.forecaster
        flow = np.zeros(e.size)
        choice = self._flow_choice(e, h)
        for f, name in enumerate(self.params.flow):
            pick = np.flatnonzero(choice == f)
            if pick.size:
                flow[pick] = np.maximum(fc.flow(name, e[pick], h[pick], t_s[pick]), 0.0)
        return flow

    def _directions(self, e: I64, h: I64, t_s: F64) -> F64:
        fc = self.forecaster
        probs = np.zeros((e.size, self.params.bins))
        choice = self._direction_choice(e, h)
        for d, name in enumerate(self.params.direction):
            pick = np.flatnonzero(choice == d)
            if pick.size:
                probs[pick] = fc.direction(name, e[pick], h[pick], t_s[pick])
        return probs

    def scale(self, t_ns: npt.ArrayLike) -> F64:
        """The reconciliation factor at each time (1 where totals are not reconciled)."""
        t = np.asarray(t_ns, dtype=np.int64).reshape(-1)
        out = np.ones(t.size)
        if self.map_family is None or t.size == 0:
            return out
        fc = self.forecaster
        everyone = np.flatnonzero(fc.observed)
        times, inverse = np.unique(t, return_inverse=True)
        bins = self.params.calendar.profile_bin(times)
        secs = self.params.model_seconds(times)
        raw, target = np.zeros(times.size), np.zeros(times.size)
        # a block of times at once: every observed entry at each (sums per time, each over
        # the entries in order, as one time's sum is)
        step = max(1, _SCALE_PAIRS // max(everyone.size, 1))
        for a in range(0, times.size, step):
            k = min(step, times.size - a)
            e = np.tile(everyone, k)
            h = np.repeat(bins[a : a + k], everyone.size)
            t_s = np.repeat(secs[a : a + k], everyone.size)
            raw[a : a + k] = self._flows(e, h, t_s).reshape(k, everyone.size).sum(axis=1)
            total = fc.map_total(self.map_family, e, h, t_s)
            if self._unseen_total:  # FreMEn's: no entry's sinusoids where it never was
                at = np.flatnonzero(self.unseen_own[e, h % self.params.calendar.bins_per_day])
                total[at] = fc.map_total("shape", e[at], h[at], t_s[at])
            target[a : a + k] = total.reshape(k, everyone.size).sum(axis=1)
        factor = np.ones(times.size)
        np.divide(target, raw, out=factor, where=(raw > 0) & ~self.extrapolated[bins])
        out[:] = factor[inverse.reshape(-1)]
        return out

    def flows(self, e: I64, t_ns: npt.ArrayLike) -> F64:
        """The chosen families' flow at (entry position, time) pairs, float64[P] (NaN for an
        entry never observed): :meth:`pairs` without the direction histograms, for series of
        totals."""
        t = np.asarray(t_ns, dtype=np.int64).reshape(-1)
        h = self.params.calendar.profile_bin(t)
        return self._flow_pairs(e, t, h, self.params.model_seconds(t))

    def _flow_pairs(self, e: I64, t: I64, h: I64, t_s: F64) -> F64:
        flow = self._flows(e, h, t_s) * self.scale(t)
        out: F64 = np.where(self.forecaster.observed[e], flow, np.nan)
        return out

    def pairs(self, e: I64, t_ns: npt.ArrayLike) -> tuple[F64, F64]:
        """Chosen families at (entry position, time) pairs: flow float64[P] and direction
        probabilities float64[P, B] (e.g. every held-out detection at its own window)."""
        t = np.asarray(t_ns, dtype=np.int64).reshape(-1)
        h = self.params.calendar.profile_bin(t)
        t_s = self.params.model_seconds(t)
        return self._flow_pairs(e, t, h, t_s), self._directions(e, h, t_s)

    def at(self, t_ns: int) -> Prediction:
        """Each entry's chosen families evaluated at ``t_ns``."""
        fc = self.forecaster
        n = fc.rows.size
        everyone = np.arange(n)
        t = np.full(n, int(t_ns), np.int64)
        flow, probs = self.pairs(everyone, t)
        h = self.params.calendar.profile_bin(t)
        return Prediction(
            flow,
            probs,
            fc.directed_share,
            np.asarray(self.params.flow, dtype=str)[self._flow_choice(everyone, h)],
            np.asarray(self.params.direction, dtype=str)[self._direction_choice(everyone, h)],
            self.variances(everyone, h, flow),
            fc.observed,
        )

    def variances(self, e: I64, h: I64, flow: F64) -> F64:
        """The variance of the window count at (entry position, profile bin) pairs whose
        expected count is ``flow``: φ · flow, with the entry's dispersion φ of its chosen
        family (of ``static`` in extrapolated bins, where ``static`` forecasts; of ``shape``
        where a ``static`` or FreMEn entry forecasts with it, at an hour it never observed).
        ``flow`` may be a share of the window's forecast (a window watched in part): counts
        over a share s of a window have mean s·λ and variance φ·s·λ, as the day-ahead scoring
        measured φ (``scoring``)."""
        phi = np.where(self.extrapolated[h], self.phi_static[e], self.phi[e])
        fall = self._falls(e, h)
        if fall is not None:
            phi = np.where(fall, self.phi_shape[e], phi)
        out: F64 = phi * flow
        return out
