"""Every family's forecast for a set of entries, from the accumulators (no scoring, no choice).

:class:`Forecaster` precomputes the time-independent parts for entries ``rows`` of a
:class:`~aion_cli.engine.temporal.accumulators.TemporalState` — static rates, the parents'
periodic shapes, FreMEn components, the static direction histograms — and then evaluates any
family at (entry, time) pairs: :meth:`Forecaster.flow` (expected detections per window, all
value bins) and :meth:`Forecaster.direction` (B-bin probabilities). The same object serves the
day-ahead scoring (built from the state before the day) and queries.

Shapes (``params`` docstring for the families). With W[e,h] the entry's observed windows in
profile bin h, S[e,h] its detections there and μ its static rate:

μ = N / max(W_e, 1), N the entry's detections and W_e its observed windows. With whole windows
(``exposure`` off) W_e ≥ 1 wherever an entry was observed and this is N / W_e;
under exposure a robot that passed a place once, for one 10-s step of a window, has W_e =
``exposure_floor`` (0.2; 1/60 with no floor), and three detections then made a rate of 15 (180)
a window that topped every forecast (a hash cell exists only where detections were, so such
places are seen *because* someone was there). Less
than one window's worth of watching is taken as one window: the rate never exceeds the
detections seen, as without exposure, and every family built on μ follows (the shapes scale
by it, so ``shape`` keeps the count over W_e / max(W_e, 1) of it). A fixed sensor is watched
for exactly the time its logs recorded, with no place picked by its detections, so where those
logs hold less than one window in all (a four-minute log in ten-minute windows) μ = N / W_e.

every rate is a Gamma-Poisson posterior mean with c pseudo-detections at its parent's rate m,
:func:`shrunk_rate` ``m (S + c) / (m W + c)`` (its own rate once its detections outweigh c):
for the map's and the groups' shapes c = α·φ, with φ how bursty the map's window counts are
and α how much the bins really vary beyond that, both estimated from the map
(:mod:`~aion_cli.engine.temporal.shape_prior`); for an entry's own profile c =
``profile_prior``:

* map rate per entry-window ρ_map[h] with parent rate ρ_map (flat), shape r_map = ρ_map[h] / ρ_map;
* group g: ρ_g[h] with parent rate ρ_g·r_map[h], shape r_g = ρ_g[h] / ρ_g (the map's shape for
  a group without detections);
* an entry's borrowed shape s[e,h] = r_g[h] / r̄_e with r̄_e = Σ_h W[e,h] r_g[h] / W_e, so the
  ``shape`` forecast μ·s keeps the entry's count over its observed windows;
* ``profile``: λ(h) with parent rate μ·s[e,h] (per value bin v the same with the bin's share of
  the c pseudo-detections, so the bins sum to λ).

A bin of a kind of day the map never observed (a Saturday of a map of weekdays:
``PoolStats.unseen``) has no windows at any level, so each level reads its own sums at the same
hour of the kinds it saw: the map's and the groups' shapes
(:func:`~aion_cli.engine.temporal.shape_prior.group_shapes`) and an entry's S[e,h] and W[e,h]
(:meth:`Forecaster._hours`), so a place busy at lunch on weekdays is busy at a Saturday lunch
too, where it used to take the map's shape there. Bins of kinds seen read as they are.

Directions: p_map,b = (N_map,b + 1) / (N_map + B) (Laplace), p_g,b = (N_g,b + κ p_map,b) /
(N_g + κ), static h_e,b = (N_e,b + κ p_g,b) / (N_e + κ) with κ = ``direction_prior`` (with
``"auto"``: the groups' κ 10, the entries' estimated from the map, ``PoolStats.kappa`` and
:mod:`.direction_prior`; κ = 0:
the raw proportions, the parent's only where an entry has no directed detection); the
time-varying families use pseudo-counts c_b(t) (profile: the entry's directed counts in the
profile bin; FreMEn: max(0, λ_b(t)) × W[e,h]) and q_b = (c_b + κ_t π_e,h,b) / (Σ c + κ_t), κ_t =
``direction_time_prior`` (with ``"auto"``, the default: estimated from the entries' profile
bins, :meth:`Forecaster.kappa_t`), π_e,h the static histogram h_e modulated by the group's
hourly shift (:mod:`~aion_cli.engine.temporal.group_shift`; h_e itself where the map has no
shift), so no probability falls below κ_t·min_b π_e,h,b / (Σ c + κ_t) — a floor set by the
counts, never zero.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.row_sums import row_sums
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.fremen_parts import BLOCK, FremenParts
from aion_cli.engine.temporal.group_shift import hour_prior
from aion_cli.engine.temporal.params import DIRECTION_ORDERS, TemporalParams
from aion_cli.engine.temporal.pooling import (
    PoolStats,
    borrowed,
    count_sums,
    entry_counts,
    normalised,
    posterior,
    rows_of,
)
from aion_cli.engine.temporal.shape_prior import by_hour, shrunk_rate
from aion_cli.engine.types import F64, I64

if TYPE_CHECKING:
    from collections.abc import Sequence

    from aion_cli.engine.temporal.components import FremenComponents



class Forecaster(FremenParts):
    """Forecast parts of entries ``rows`` whose groups ``groups`` index ``pool``."""

    def __init__(
        self,
        params: TemporalParams,
        state: TemporalState,
        rows: I64,
        groups: I64,
        pool: PoolStats,
        components: FremenComponents | None = None,
        counts: F64 | None = None,
    ) -> None:
        self.params = params
        self.state = state
        self.rows = np.asarray(rows, dtype=np.int64)
        groups = np.asarray(groups, dtype=np.int64)
        e, b = self.rows.size, params.bins
        r = self.rows
        glob = state.glob
        self.groups = groups
        self.pool = pool
        self._glob_profile = glob.profile[0]
        # the observation (``TemporalState.observation``), read per entry; W[e, h] per pair
        own_windows = state.obs.n[r]  # each entry's own windows (no fixed sensor's)
        self.windows = own_windows + glob.n[0]
        first = np.fmin(state.obs.first[r], glob.first[0])
        last = np.fmax(state.obs.last[r], glob.last[0])
        self.observed = self.windows > 0
        self.counts = entry_counts(state, r, BLOCK) if counts is None else counts  # N[e, v]
        shape_sum, map_sum = np.empty(e), np.empty(e)
        for a in range(0, e, BLOCK):  # one pass, block by block: no [E, H] temporaries
            rows = r[a : a + BLOCK]
            w = rows_of(state.obs.profile, rows) + self._glob_profile  # W of the block
            # row sums of the profile bins: numpy's own order, in column passes (row_sums)
            shape_sum[a : a + BLOCK] = row_sums(w * pool.shape[groups[a : a + BLOCK]])
            map_sum[a : a + BLOCK] = row_sums(w * pool.map_shape)
        # μ = N / max(W, 1): less than one window's worth of watching (a robot that passed a
        # place for seconds, ``ModelConfig.exposure``) counts as one window (module docstring),
        # unless only a fixed sensor watched the entry and its logs recorded less than a
        # window in all (N / W: their time); an entry a robot watched keeps the one window
        fixed_time = float(glob.n[0])
        least = np.where(
            own_windows > 0, 1.0, min(1.0, fixed_time) if fixed_time > 0 else 1.0
        )
        safe_n = np.where(self.observed, np.maximum(self.windows, least), 1.0)
        self.rate = self.counts / safe_n[:, None]  # μ[e, v]
        self.rate_total = row_sums(self.rate)
        total = row_sums(self.counts)
        directed = row_sums(self.counts[:, :b])
        self.directed = directed  # N[e, :B] summed: directed detections (whole numbers)
        self.directed_share = np.divide(directed, total, out=np.zeros(e), where=total > 0)
        self._shape_mean = self._mean(shape_sum)
        self._map_mean = self._mean(map_sum)
        self.raw_histogram = normalised(self.counts[:, :b])
        self.histogram = posterior(
            self.counts[:, :b], pool.histogram[groups], pool.kappa
        )
        self._cache: dict[str, Any] = {}
        self._profiles: tuple[F64, F64] | None = None  # W, S of every entry (cache_profiles)
        self._fremen(first, last)
        if components is not None:
            self._preset(components)

    # -- precomputation ---------------------------------------------------------------------
    def _mean(self, weighted_sum: F64) -> F64:
        """r̄_e = Σ_h W[e,h] r[e,h] / W_e (0 for an entry never observed)."""
        out: F64 = np.divide(
            weighted_sum, self.windows, out=np.zeros(weighted_sum.size), where=self.observed
        )
        return out

    # -- per (entry, profile bin) pairs -------------------------------------------------------
    def cache_profiles(self, pooled_at: I64 | None = None) -> None:
        """Hold W[e, h] and S[e, h] of every entry (float64[E, H] each): a day's scoring asks
        for every profile bin of every entry, a query for one bin, which is cheaper read per
        pair from the accumulators. ``pooled_at``: the entries' positions among the rows
        :attr:`pool` pooled, whose W and S it may hold already (``PoolStats.kept``: the same
        sums, read instead of computed again)."""
        if self._profiles is not None:
            return
        kept = self.pool.kept
        if pooled_at is not None and kept is not None:
            self._profiles = (
                self._by_hour(np.asarray(kept[0][pooled_at], dtype=np.float64)),
                self._by_hour(np.asarray(kept[1][pooled_at], dtype=np.float64)),
            )
            return
        e, h = self.rows.size, self.params.n_profile
        windows, total = np.empty((e, h)), np.empty((e, h))
        for a in range(0, e, BLOCK):
            rows = self.rows[a : a + BLOCK]
            windows[a : a + BLOCK] = rows_of(self.state.obs.profile, rows) + self._glob_profile
            total[a : a + BLOCK] = count_sums(rows_of(self.state.cnt_profile, rows), 1)
        self._profiles = self._by_hour(windows), self._by_hour(total)

    def _by_hour(self, values: F64) -> F64:
        """Sums per profile bin ``values[E, H]`` with the bins of a kind of day the map never
        saw summed over the same hour of the kinds it saw (``PoolStats.unseen``)."""
        return by_hour(values, self.pool.unseen, self.params.calendar.bins_per_day)

    def _hours(self, read: Any, e: I64, h: I64, values: bool = False) -> Any:
        """``read(e, h)`` — a sum per profile bin at pairs (or a broadcast grid), with a value
        axis last if ``values`` — where a bin of an unseen kind of day (``PoolStats.unseen``)
        reads the sum of ``read`` at the same hour of every kind (those of unseen kinds hold
        no windows, so: of the kinds seen). Bins of kinds seen read as they are, the same
        array, so their forecasts are unchanged."""
        out = read(e, h)
        unseen = self.pool.unseen
        if unseen is None:
            return out
        mask = unseen[h]
        if not mask.any():
            return out
        per_day = self.params.calendar.bins_per_day
        hour = np.asarray(h) % per_day
        pooled = np.zeros(np.shape(out))
        for k in range(self.params.n_profile // per_day):  # 2 or 7 kinds of day
            pooled += read(e, hour + k * per_day)
        return np.where(mask[..., None] if values else mask, pooled, out)

    def profile_windows_at(self, e: I64, h: I64) -> F64:
        """W[e, h]: the windows in which entry positions ``e`` were observed in profile bins
        ``h`` (pairs); a bin of a kind of day the map never saw holds the windows of the
        same hour of the kinds it saw (:meth:`_hours`)."""
        if self._profiles is not None:
            held: F64 = self._profiles[0][e, h]
            return held
        out: F64 = self._hours(self._windows_at, e, h)
        return out

    def _windows_at(self, e: I64, h: I64) -> F64:
        out: F64 = self.state.obs.profile[self.rows[e], h] + self._glob_profile[h]
        return out

    def profile_total_at(self, e: I64, h: I64) -> F64:
        """S[e, h]: their detections there, all value bins (whole numbers: exact in any
        order, whatever type the counts are held in); unseen kinds of day as W."""
        if self._profiles is not None:
            held: F64 = self._profiles[1][e, h]
            return held
        out: F64 = self._hours(self._total_at, e, h)
        return out

    def _total_at(self, e: I64, h: I64) -> F64:
        # summed over the value axis, the last for pairs and for broadcast (entry, bin) grids
        out: F64 = self.state.cnt_profile[self.rows[e], :, h].sum(axis=-1, dtype=np.float64)
        return out

    def _counts_at(self, e: I64, h: I64, upto: int | None = None) -> Any:
        """The entry's counts per value bin (the first ``upto``) in profile bin ``h``, pairs;
        unseen kinds of day as W (then float64)."""
        rows = self.rows

        def read(e: I64, h: I64) -> Any:
            return self.state.cnt_profile[rows[e], :upto, h]

        return self._hours(read, e, h, values=True)

    def shape_at(self, e: I64, h: I64) -> F64:
        """s[e, h] = r_g[h] / r̄_e: the group's shape, normalised over the entry's windows (1
        where r̄_e is ~0)."""
        return borrowed(self.pool.shape[self.groups[e], h], self._shape_mean[e])

    def map_shape_at(self, e: I64, h: I64) -> F64:
        """The same with the map's pooled shape r_map[h]."""
        return borrowed(self.pool.map_shape[h], self._map_mean[e])

    # -- evaluation at (entry, time) pairs --------------------------------------------------
    def map_total(self, family: str, e: I64, h: I64, t_s: F64) -> F64:
        """The map's forecast of ``family`` spread over entries ``e`` at one time: for the
        periodic families (``shape``, ``profile``) each entry's static rate times the *map's*
        pooled shape (the total then follows the map's own profile, estimated from all its
        detections at once); for FreMEn and ``static`` the family itself."""
        if family in ("shape", "profile"):
            out: F64 = self.rate_total[e] * self.map_shape_at(e, h)
            return out
        return np.maximum(self.flow(family, e, h, t_s), 0.0)

    def flow(self, family: str, e: I64, h: I64, t_s: F64) -> F64:
        """Expected detections per window (all value bins) of family ``family`` at pairs
        (entry position ``e``, profile bin ``h``, model time ``t_s``); FreMEn is not clamped
        (callers clamp at 0 or at the scoring floor). The periodic families also take index
        arrays that broadcast (entries down, bins across: that grid, static one column)."""
        mu = self.rate_total[e]
        if family == "static":
            return mu.copy()
        if family == "shape":
            out: F64 = mu * self.shape_at(e, h)
            return out
        if family == "profile":
            c = self.params.config.profile_prior
            parent = mu * self.shape_at(e, h)
            return shrunk_rate(
                self.profile_total_at(e, h), self.profile_windows_at(e, h), parent, c
            )
        m = int(family.removeprefix("fremen"))
        out = mu + self._total_terms(e, t_s)[:, m - 1]
        return out

    def bin_rates(self, family: str, e: I64, h: I64, t_s: F64) -> F64:
        """Expected detections per window in each value bin, float64[P, V] (FreMEn clamped at
        0 per bin): the per-bin form of :meth:`flow`."""
        mu = self.rate[e]
        if family == "static":
            return mu.copy()
        if family == "shape":
            out: F64 = mu * self.shape_at(e, h)[:, None]
            return out
        if family == "profile":
            c = self.params.config.profile_prior
            parent = self.rate_total[e] * self.shape_at(e, h)
            share = np.divide(
                mu,
                self.rate_total[e][:, None],
                out=np.zeros_like(mu),
                where=self.rate_total[e][:, None] > 0,
            )
            own = self._counts_at(e, h)
            den = parent * self.profile_windows_at(e, h) + c
            out = np.divide(
                parent[:, None] * (own + c * share),
                den[:, None],
                out=np.zeros(own.shape),  # float64 whatever type the counts are held in
                where=den[:, None] > 0,
            )
            return out
        m = int(family.removeprefix("fremen"))
        v, upto = self.params.values, self.params.max_order
        out = np.maximum(mu + self._bin_terms(e, t_s, m, v, upto), 0.0)
        return out

    def flow_bound(self, family: str, e: I64) -> F64:
        """A lower bound of the FreMEn forecast over all times: μ − Σ 2|γ| (for skipping the
        per-window clamp where it cannot bite)."""
        m = int(family.removeprefix("fremen"))
        self.ensure_total(e)
        out: F64 = self.rate_total[e] - 2.0 * np.abs(self._coef_total[e, :m]).sum(axis=1)
        return out

    @property
    def kappa_t(self) -> float:
        """κ_t, the static histogram's pseudo-detections in a time-varying one
        (``direction_time_prior``; ``"auto"``: estimated from every pooled entry,
        ``PoolStats.kappa_t``, whichever block of them this forecaster serves)."""
        return self.pool.kappa_t

    def direction(self, family: str, e: I64, h: I64, t_s: F64) -> F64:
        """Direction probabilities float64[P, B] of family ``family`` at pairs."""
        hist: F64 = self.histogram[e]  # a gathered copy, the caller's to keep
        if family == "static":
            return hist
        hist = self.hour_prior(hist, e, h)
        kappa_t = self.kappa_t
        pseudo = self._pseudo_counts(family, e, h, t_s)
        denominator = row_sums(pseudo, keepdims=True) + kappa_t
        hist *= kappa_t
        hist += pseudo
        hist /= denominator
        return hist

    def direction_at(
        self, family: str, e: I64, h: I64, t_s: F64, pair: I64, b: I64
    ) -> F64:
        """``direction(family, e, h, t_s)[pair, b]`` — the same operations in the same order,
        so equal to the bit — computed at those (pair, bin) positions only: the day-ahead
        scoring asks for the one or two bins each pair has detections in, and a time-varying
        family needs its whole rows only for their sums."""
        return self.directions_at((family,), e, h, t_s, pair, b)[0]

    def directions_at(
        self, families: Sequence[str], e: I64, h: I64, t_s: F64, pair: I64, b: I64
    ) -> list[F64]:
        """:meth:`direction_at` of each of ``families`` at the same positions, bit for bit,
        with the gathers they share made once (issue 15: a day close asks every time-varying
        family at the same pairs): the histogram at (pair, bin) times κ_t, and FreMEn's
        rates and windows W[e, h] at the pairs (``_pseudo_counts``)."""
        out: list[F64] = []
        scaled: F64 | None = None
        shared: dict[str, F64] = {}
        for family in families:
            if family == "static":
                out.append(self.histogram[e[pair], b])  # a gathered copy, the caller's
                continue
            kappa_t = self.kappa_t
            pseudo = self._pseudo_counts(family, e, h, t_s, shared)
            denominator = row_sums(pseudo) + kappa_t
            if scaled is None:  # prior · κ_t, the first step of every family's value
                if self.pool.shift is None:  # the static histogram
                    scaled = self.histogram[e[pair], b]
                else:  # modulated by the group's hour (its whole rows renormalised)
                    scaled = self.hour_prior(self.histogram[e], e, h)[pair, b]
                scaled *= kappa_t
            hist = scaled + pseudo[pair, b]  # a new array: ``scaled`` serves the next family
            hist /= denominator[pair]
            out.append(hist)
        return out

    def hour_prior(self, static: F64, e: I64, h: I64) -> F64:
        """π[P, B], what the time-varying families shrink toward at pairs: the entries'
        static histograms ``static`` (gathered rows; a new array) times their
        groups' hourly direction shift (:mod:`.group_shift`), or ``static`` as it is."""
        return hour_prior(static, self.pool.shift, self.groups[e], h)

    def _pseudo_counts(
        self, family: str, e: I64, h: I64, t_s: F64, shared: dict[str, F64] | None = None
    ) -> F64:
        """The time-varying family's directed pseudo-counts c_b(t) float64[P, B] (module
        docstring): the profile bin's counts, or FreMEn's clamped per-bin rates × W[e, h].
        ``shared``: FreMEn's gathers at these pairs (μ[e, :B], W[e, h]), kept there by the
        first FreMEn family for the next (the same arrays, read only)."""
        b = self.params.bins
        if family == "profile":
            counts: F64 = self._counts_at(e, h, b)
            return counts
        m = int(family.removeprefix("fremen"))
        terms = self._bin_terms(e, t_s, m, b, min(self.params.max_order, DIRECTION_ORDERS))
        held = {} if shared is None else shared
        if "rate" not in held:
            held["rate"] = self.rate[e, :b]
            held["windows"] = self.profile_windows_at(e, h)[:, None]
        pseudo: F64 = held["rate"] + terms  # a new array: the terms are memoised
        np.maximum(pseudo, 0.0, out=pseudo)
        pseudo *= held["windows"]
        return pseudo

