"""Every family's forecast for a set of entries, from the accumulators (no scoring, no choice).

:class:`Forecaster` precomputes the time-independent parts for entries ``rows`` of a
:class:`~aion_cli.engine.temporal.accumulators.TemporalState` — static rates, the parents'
periodic shapes, FreMEn components, the static direction histograms — and then evaluates any
family at (entry, time) pairs: :meth:`Forecaster.flow` (expected detections per window, all
value bins) and :meth:`Forecaster.direction` (B-bin probabilities). The same object serves the
day-ahead scoring (built from the state before the day) and queries.

Shapes (``params`` docstring for the families). With W[e,h] the entry's observed windows in
profile bin h, S[e,h] its detections there and μ its static rate:

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

Directions: p_map,b = (N_map,b + 1) / (N_map + B) (Laplace), p_g,b = (N_g,b + κ p_map,b) /
(N_g + κ), static h_e,b = (N_e,b + κ p_g,b) / (N_e + κ) with κ = ``direction_prior`` (κ = 0:
the raw proportions, the parent's only where an entry has no directed detection); the
time-varying families use pseudo-counts c_b(t) (profile: the entry's directed counts in the
profile bin; FreMEn: max(0, λ_b(t)) × W[e,h]) and q_b = (c_b + κ_t h_e,b) / (Σ c + κ_t), so no
probability falls below κ·κ_t·min_b p_map,b / ((N_e + κ)(Σ c + κ_t)) — a floor set by the
counts, never zero.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.grouping import distinct
from aion_cli.engine.temporal.accumulators import TemporalState
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
from aion_cli.engine.temporal.shape_prior import shrunk_rate
from aion_cli.engine.temporal.spectrum import admitted, top_periods
from aion_cli.engine.types import F64, I64
from aion_cli.errors import MapCorruptError, MapFileError

if TYPE_CHECKING:
    from aion_cli.engine.temporal.components import FremenComponents

C128 = npt.NDArray[np.complex128]
_BLOCK = 1 << 10


class Forecaster:
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
        self.windows = state.obs.n[r] + glob.n[0]
        first = np.fmin(state.obs.first[r], glob.first[0])
        last = np.fmax(state.obs.last[r], glob.last[0])
        self.observed = self.windows > 0
        self.counts = entry_counts(state, r, _BLOCK) if counts is None else counts  # N[e, v]
        shape_sum, map_sum = np.empty(e), np.empty(e)
        for a in range(0, e, _BLOCK):  # one pass, block by block: no [E, H] temporaries
            rows = r[a : a + _BLOCK]
            w = rows_of(state.obs.profile, rows) + self._glob_profile  # W of the block
            shape_sum[a : a + _BLOCK] = (w * pool.shape[groups[a : a + _BLOCK]]).sum(axis=1)
            map_sum[a : a + _BLOCK] = (w * pool.map_shape).sum(axis=1)
        safe_n = np.where(self.observed, self.windows, 1.0)
        self.rate = self.counts / safe_n[:, None]  # μ[e, v]
        self.rate_total = self.rate.sum(axis=1)
        total = self.counts.sum(axis=1)
        directed = self.counts[:, :b].sum(axis=1)
        self.directed_share = np.divide(directed, total, out=np.zeros(e), where=total > 0)
        self._shape_mean = self._mean(shape_sum)
        self._map_mean = self._mean(map_sum)
        self.raw_histogram = normalised(self.counts[:, :b])
        self.histogram = posterior(
            self.counts[:, :b], pool.histogram[groups], params.config.direction_prior
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
    def cache_profiles(self) -> None:
        """Hold W[e, h] and S[e, h] of every entry (float64[E, H] each): a day's scoring asks
        for every profile bin of every entry, a query for one bin, which is cheaper read per
        pair from the accumulators."""
        if self._profiles is not None:
            return
        e, h = self.rows.size, self.params.n_profile
        windows, total = np.empty((e, h)), np.empty((e, h))
        for a in range(0, e, _BLOCK):
            rows = self.rows[a : a + _BLOCK]
            windows[a : a + _BLOCK] = rows_of(self.state.obs.profile, rows) + self._glob_profile
            total[a : a + _BLOCK] = count_sums(rows_of(self.state.cnt_profile, rows), 1)
        self._profiles = (windows, total)

    def profile_windows_at(self, e: I64, h: I64) -> F64:
        """W[e, h]: the windows in which entry positions ``e`` were observed in profile bins
        ``h`` (pairs)."""
        if self._profiles is not None:
            held: F64 = self._profiles[0][e, h]
            return held
        out: F64 = self.state.obs.profile[self.rows[e], h] + self._glob_profile[h]
        return out

    def profile_total_at(self, e: I64, h: I64) -> F64:
        """S[e, h]: their detections there, all value bins (whole numbers: exact in any
        order, whatever type the counts are held in)."""
        if self._profiles is not None:
            held: F64 = self._profiles[1][e, h]
            return held
        out: F64 = self.state.cnt_profile[self.rows[e], :, h].sum(axis=1, dtype=np.float64)
        return out

    def shape_at(self, e: I64, h: I64) -> F64:
        """s[e, h] = r_g[h] / r̄_e: the group's shape, normalised over the entry's windows (1
        where r̄_e is ~0)."""
        return borrowed(self.pool.shape[self.groups[e], h], self._shape_mean[e])

    def map_shape_at(self, e: I64, h: I64) -> F64:
        """The same with the map's pooled shape r_map[h]."""
        return borrowed(self.pool.map_shape[h], self._map_mean[e])

    def _fremen(self, first: F64, last: F64) -> None:
        """FreMEn components, each computed on first use, per entry: the M strongest admitted
        periods of each entry's *total* spectrum with their coefficients (``period_idx``,
        ``coef_total``: the flow family; :meth:`ensure_total`), and each value bin's own M
        strongest (``bin_idx``, ``coef_bins`` complex[E, V, M]: per-bin rates and directions,
        so opposite flows that cancel in the total, east in the morning and west in the
        evening, keep their rhythm). A query of a large map then reads the Fourier sums of
        only the entries whose chosen family is FreMEn; every computation is row by row, so
        what is computed does not depend on which rows are asked together."""
        p = self.params
        m, e, v = p.max_order, self.rows.size, p.values
        self._period_idx = np.zeros((e, m), dtype=np.int64)
        self._coef_total = np.zeros((e, m), dtype=np.complex128)
        self.bin_idx = np.zeros((e, v, m), dtype=np.int64)
        self.coef_bins = np.zeros((e, v, m), dtype=np.complex128)
        self._bins_depth = np.zeros(e, dtype=np.int64)  # per-bin components computed so far
        self._flat: dict[tuple[int, int], tuple[I64, F64, F64]] = {}
        self._times: tuple[F64, C128] = (np.zeros(0), np.zeros((0, p.n_periods), complex))
        self._gate = admitted(first, last, p.min_span)
        self._total_done = np.zeros(e, dtype=bool)
        if m == 0 or e == 0:
            self._bins_depth[:] = m
            self._total_done[:] = True

    def _preset(self, stored: FremenComponents) -> None:
        """Components read from the map file (computed when it was written, from this very
        view: :mod:`~aion_cli.engine.temporal.components`) instead of from the sums."""
        depth = stored.bins_depth
        if stored.total_pos.size and int(stored.total_pos.max()) >= self.rows.size:
            raise MapCorruptError("forecast components name entries the map does not have")
        if stored.bins_pos.size and int(stored.bins_pos.max()) >= self.rows.size:
            raise MapCorruptError("forecast components name entries the map does not have")
        self._period_idx[stored.total_pos] = stored.period_idx
        self._coef_total[stored.total_pos] = stored.coef_total
        self._total_done[stored.total_pos] = True
        self.bin_idx[stored.bins_pos, :, :depth] = stored.bin_idx
        self.coef_bins[stored.bins_pos, :, :depth] = stored.coef_bins
        self._bins_depth[stored.bins_pos] = np.maximum(self._bins_depth[stored.bins_pos], depth)

    def total_components(self, e: I64) -> tuple[I64, C128]:
        """The total-spectrum periods and coefficients of entry positions ``e`` (computed
        where not yet), int64[n, M] and complex128[n, M]."""
        self.ensure_total(e)
        return self._period_idx[e], self._coef_total[e]

    def ensure_total(self, e: I64 | None = None) -> None:
        """Compute ``period_idx`` / ``coef_total`` of entry positions ``e`` (every entry if
        None) where not yet computed, in blocks of :data:`_BLOCK` entries."""
        if e is None:
            todo = np.flatnonzero(~self._total_done)
        else:
            e = np.asarray(e, dtype=np.int64)
            todo = distinct(e[~self._total_done[e]])
        m = self.params.max_order
        for a in range(0, todo.size, _BLOCK):
            pos = todo[a : a + _BLOCK]
            total = self._gamma_total(pos)
            idx, valid = top_periods(total, self._gate[pos], m)
            coef = np.take_along_axis(total, idx, axis=1)
            coef[~valid] = 0.0
            self._period_idx[pos], self._coef_total[pos] = idx, coef
        self._total_done[todo] = True

    @property
    def period_idx(self) -> I64:
        """The M strongest admitted periods of every entry's total spectrum, int64[E, M]."""
        self.ensure_total()
        return self._period_idx

    @property
    def coef_total(self) -> C128:
        """Their coefficients γ, complex128[E, M] (0 where fewer periods are admitted)."""
        self.ensure_total()
        return self._coef_total

    def _gamma(self, pos: I64) -> C128:
        """γ_{v,k} = (A − μ B) / W of entries at positions ``pos``: complex[n, V, K]."""
        self._check_sums()
        r = self.rows[pos]
        balance = rows_of(self.state.obs.fourier, r) + self.state.glob.fourier[0]  # Σ e^{iωt}
        counts = rows_of(self.state.cnt_fourier, r)
        gamma: C128 = self.rate[pos, :, None] * balance[:, None, :]
        np.subtract(counts, gamma, out=gamma)
        gamma /= np.where(self.observed[pos], self.windows[pos], 1.0)[:, None, None]
        return gamma

    def _gamma_total(self, pos: I64) -> C128:
        """γ_k of the entries' total series (all value bins), complex[n, K]: (Σ_v A_v − μ B)
        / W with μ the total rate — the sum over v of :meth:`_gamma`, without its per-bin
        [n, V, K] temporaries (a day's scoring asks it of every candidate)."""
        self._check_sums()
        r = self.rows[pos]
        balance = rows_of(self.state.obs.fourier, r) + self.state.glob.fourier[0]  # Σ e^{iωt}
        gamma: C128 = rows_of(self.state.cnt_fourier, r).sum(axis=1)
        gamma -= self.rate_total[pos, None] * balance
        gamma /= np.where(self.observed[pos], self.windows[pos], 1.0)[:, None]
        return gamma

    def _check_sums(self) -> None:
        """:class:`MapFileError` when the Fourier sums were not read (a query's state) and a
        component the map did not store is asked for."""
        if not self.state.fourier_loaded:
            raise MapFileError(
                "this map was read for queries without its Fourier sums, and its stored "
                "forecast components do not cover what was asked",
                hint="read the map whole (aion_cli.mapquery.load_map(path, forecast_only=False))",
            )

    def _flat_bins(self, bins: int, upto: int) -> tuple[I64, F64, F64]:
        """The per-bin periods and 2·Re γ, 2·Im γ of the first ``bins`` bins and ``upto``
        orders, one contiguous row per entry (int64/float64[E, bins·upto]): a pair's terms
        are then row gathers (scaling by 2 is exact, so the terms equal 2 Re(γ e^{−iωt}))."""
        key = (bins, upto)
        parts = self._flat.get(key)
        if parts is None:
            coef = self.coef_bins[:, :bins, :upto]
            parts = (
                np.ascontiguousarray(self.bin_idx[:, :bins, :upto]).reshape(-1, bins * upto),
                np.ascontiguousarray(2.0 * coef.real).reshape(-1, bins * upto),
                np.ascontiguousarray(2.0 * coef.imag).reshape(-1, bins * upto),
            )
            self._flat[key] = parts
        return parts

    def ensure_bins(self, e: I64, upto: int) -> None:
        """Compute the first ``upto`` per-bin FreMEn components of the entries ``e`` not done
        that far yet (the strongest periods are chosen greedily, so the first ``upto`` of a
        longer choice are the same: directions need 2, per-bin rates all ``max_order``)."""
        todo = distinct(e[self._bins_depth[e] < upto])
        v, k = self.params.values, self.params.n_periods
        for a in range(0, todo.size, _BLOCK):
            pos = todo[a : a + _BLOCK]
            n = pos.size
            gamma = self._gamma(pos).reshape(n * v, k)
            idx, valid = top_periods(gamma, np.repeat(self._gate[pos], v, axis=0), upto)
            coef = np.take_along_axis(gamma, idx, axis=1)
            coef[~valid] = 0.0
            self.bin_idx[pos, :, :upto] = idx.reshape(n, v, upto)
            self.coef_bins[pos, :, :upto] = coef.reshape(n, v, upto)
            for (bins, depth), (f_idx, f_re, f_im) in self._flat.items():
                if depth > upto:  # filled when a call needs that depth
                    continue
                part = self.coef_bins[pos, :bins, :depth]
                f_idx[pos] = self.bin_idx[pos, :bins, :depth].reshape(n, -1)
                f_re[pos] = (2.0 * part.real).reshape(n, -1)
                f_im[pos] = (2.0 * part.imag).reshape(n, -1)
        self._bins_depth[todo] = upto

    # -- evaluation at (entry, time) pairs --------------------------------------------------
    def _rotation_table(self, t_s: F64) -> tuple[C128, I64]:
        """e^{−iω_k t} for the distinct times of ``t_s`` (complex[T, K]) and each pair's row in
        it: pairs share few times (a day's windows), so exponentials are computed per time, and
        the table is kept for the next call while its times cover the pairs' (chunks of a day)."""
        times, table = self._times
        if times.size:
            at = np.minimum(np.searchsorted(times, t_s), times.size - 1)
            if np.array_equal(times[at], t_s):  # every time seen by the previous call
                return table, at
        times, inverse = np.unique(t_s, return_inverse=True)
        table = np.exp(-1j * np.multiply.outer(times, self.params.omega))
        self._times = (times, table)
        return table, inverse.reshape(-1)

    def _memo(self, kind: str, e: I64, t_s: F64, compute: Any) -> Any:
        """The last result of ``compute()`` for these very arrays (the scoring evaluates every
        FreMEn order at the same pairs: orders are cumulative, so one pass serves them all)."""
        key = (kind, id(e), id(t_s), e.size)
        cached = self._cache.get(kind)
        if cached is not None and cached[0] == key:
            return cached[2]
        value = compute()
        self._cache[kind] = (key, (e, t_s), value)
        return value

    def _total_terms(self, e: I64, t_s: F64) -> F64:
        """Cumulative FreMEn terms of the total, float64[P, M]: column j sums periods 0..j."""

        def compute() -> F64:
            self.ensure_total(e)
            table, inverse = self._rotation_table(t_s)
            rot = table[inverse[:, None], self._period_idx[e]]
            return _running_sum(2.0 * (self._coef_total[e] * rot).real)

        out: F64 = self._memo("total", e, t_s, compute)
        return out

    def map_total(self, family: str, e: I64, h: I64, t_s: F64) -> F64:
        """The map's forecast of ``family`` spread over entries ``e`` at one time: for the
        periodic families (``shape``, ``profile``) each entry's static rate times the *map's*
        pooled shape (the total then follows the map's own profile, estimated from all its
        detections at once); for FreMEn and ``static`` the family itself."""
        if family in ("shape", "profile"):
            out: F64 = self.rate_total[e] * self.map_shape_at(e, h)
            return out
        return np.maximum(self.flow(family, e, h, t_s), 0.0)

    def _bin_terms(self, e: I64, t_s: F64, m: int, bins: int, upto: int) -> F64:
        """Σ_j 2 Re(γ_{v,j} e^{−iω t}) over each value bin's own first ``m`` periods:
        float64[P, bins], from one cumulative pass over orders 1..``upto`` for the first
        ``bins`` bins (memoised: the scoring asks for every order at the same pairs)."""

        def compute() -> F64:
            self.ensure_bins(e, upto)
            idx, twice_re, twice_im = self._flat_bins(bins, upto)
            table, inverse = self._rotation_table(t_s)
            k = table.shape[1]
            re_z = np.ascontiguousarray(table.real).ravel()  # z = e^{−iωt}
            im_z = np.ascontiguousarray(table.imag).ravel()
            flat = idx[e]
            flat += (inverse * k)[:, None]
            # 2 Re(γ z) = 2 Re γ Re z − 2 Im γ Im z: real arithmetic and row gathers
            terms = np.take(re_z, flat)
            terms *= np.take(twice_re, e, axis=0)
            minus = np.take(im_z, flat)
            minus *= np.take(twice_im, e, axis=0)
            terms -= minus
            return _running_sum(terms.reshape(e.size, bins, upto))

        full: F64 = self._memo(f"bins{bins}/{upto}", e, t_s, compute)
        out: F64 = full[:, :, m - 1]
        return out

    def flow(self, family: str, e: I64, h: I64, t_s: F64) -> F64:
        """Expected detections per window (all value bins) of family ``family`` at pairs
        (entry position ``e``, profile bin ``h``, model time ``t_s``); FreMEn is not clamped
        (callers clamp at 0 or at the scoring floor)."""
        mu = self.rate_total[e]
        if family == "static":
            return mu.copy()
        if family == "shape":
            out: F64 = mu * self.shape_at(e, h)
            return out
        if family == "profile":
            c = self.params.config.profile_prior
            m = mu * self.shape_at(e, h)
            return shrunk_rate(self.profile_total_at(e, h), self.profile_windows_at(e, h), m, c)
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
            m = self.rate_total[e] * self.shape_at(e, h)
            share = np.divide(
                mu,
                self.rate_total[e][:, None],
                out=np.zeros_like(mu),
                where=self.rate_total[e][:, None] > 0,
            )
            own = self.state.cnt_profile[self.rows[e], :, h]
            den = m * self.profile_windows_at(e, h) + c
            out = np.divide(
                m[:, None] * (own + c * share),
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

    def direction(self, family: str, e: I64, h: I64, t_s: F64) -> F64:
        """Direction probabilities float64[P, B] of family ``family`` at pairs."""
        hist: F64 = self.histogram[e]  # a gathered copy, the caller's to keep
        if family == "static":
            return hist
        kappa_t = self.params.config.direction_time_prior
        pseudo = self._pseudo_counts(family, e, h, t_s)
        denominator = pseudo.sum(axis=1, keepdims=True) + kappa_t
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
        hist: F64 = self.histogram[e[pair], b]
        if family == "static":
            return hist
        kappa_t = self.params.config.direction_time_prior
        pseudo = self._pseudo_counts(family, e, h, t_s)
        denominator = pseudo.sum(axis=1) + kappa_t
        hist *= kappa_t
        hist += pseudo[pair, b]
        hist /= denominator[pair]
        return hist

    def _pseudo_counts(self, family: str, e: I64, h: I64, t_s: F64) -> F64:
        """The time-varying family's directed pseudo-counts c_b(t) float64[P, B] (module
        docstring): the profile bin's counts, or FreMEn's clamped per-bin rates × W[e, h]."""
        b = self.params.bins
        if family == "profile":
            counts: F64 = self.state.cnt_profile[self.rows[e], :b, h]
            return counts
        m = int(family.removeprefix("fremen"))
        terms = self._bin_terms(e, t_s, m, b, min(self.params.max_order, DIRECTION_ORDERS))
        pseudo: F64 = self.rate[e, :b] + terms  # a new array: the terms are memoised
        np.maximum(pseudo, 0.0, out=pseudo)
        pseudo *= self.profile_windows_at(e, h)[:, None]
        return pseudo


def _running_sum(terms: F64) -> F64:
    """``np.cumsum(terms, axis=-1)`` computed in ``terms`` itself (a fresh array of the
    caller's), one order at a time: the same additions in the same order (s_j = s_{j−1} +
    t_j), so equal to the bit, but as a few whole-array adds — numpy's cumsum along a short
    last axis (the 2–4 FreMEn orders) loops per row."""
    for j in range(1, terms.shape[-1]):
        terms[..., j] += terms[..., j - 1]
    return terms
