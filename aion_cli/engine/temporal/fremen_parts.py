"""The FreMEn part of a :class:`~aion_cli.engine.temporal.forecast.Forecaster`: components
(the strongest admitted periods of each entry's total spectrum and of each value bin's, with
their coefficients γ = (A − μ B) / W), computed on first use per entry or preset from a map's
stored components, and their terms at (entry, time) pairs, memoised so that one pass serves
every order (:class:`FremenParts`, a base class; the forecaster sets up the entries' rates and
observation it reads)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.grouping import distinct
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pooling import rows_of
from aion_cli.engine.temporal.spectrum import admitted, top_periods
from aion_cli.engine.types import F64, I64
from aion_cli.errors import MapCorruptError, MapFileError

if TYPE_CHECKING:
    from aion_cli.engine.temporal.components import FremenComponents

C128 = npt.NDArray[np.complex128]
BLOCK = 1 << 10
"""Entries whose components are computed together (temporaries stay small on any map)."""


class FremenParts:
    """FreMEn components and terms of entries ``rows`` of ``state`` (see the module
    docstring); :class:`~aion_cli.engine.temporal.forecast.Forecaster` sets the attributes
    below and calls :meth:`_fremen` once."""

    params: TemporalParams
    state: TemporalState
    rows: I64
    rate: F64
    rate_total: F64
    windows: F64
    observed: npt.NDArray[np.bool_]
    _cache: dict[str, Any]

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
        None) where not yet computed, in blocks of :data:`BLOCK` entries."""
        if e is None:
            todo = np.flatnonzero(~self._total_done)
        else:
            e = np.asarray(e, dtype=np.int64)
            todo = distinct(e[~self._total_done[e]])
        m = self.params.max_order
        for a in range(0, todo.size, BLOCK):
            pos = todo[a : a + BLOCK]
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
        gamma: C128 = value_sums(rows_of(self.state.cnt_fourier, r))
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
        for a in range(0, todo.size, BLOCK):
            pos = todo[a : a + BLOCK]
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

    # -- FreMEn terms at (entry, time) pairs -----------------------------------------------
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

    def use_rotations(self, t_s: F64, table: C128) -> None:
        """Take ``table`` = e^{−iω_k t} at the times ``t_s`` (a day's slots, the caller's
        exponentials) as the rotation table, when ``t_s`` are strictly increasing: they are
        then their own distinct times, and :meth:`_rotation_table` would compute the same
        rows for any pairs among them (the same exponentials, elementwise; issue 15: a day
        close computed them up to three times)."""
        if t_s.size and bool(np.all(t_s[1:] > t_s[:-1])):
            self._times = (t_s, table)

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



def _running_sum(terms: F64) -> F64:
    """``np.cumsum(terms, axis=-1)`` computed in ``terms`` itself (a fresh array of the
    caller's), one order at a time: the same additions in the same order (s_j = s_{j−1} +
    t_j), so equal to the bit, but as a few whole-array adds — numpy's cumsum along a short
    last axis (the 2–4 FreMEn orders) loops per row."""
    for j in range(1, terms.shape[-1]):
        terms[..., j] += terms[..., j - 1]
    return terms


def value_sums(sums: C128) -> C128:
    """``sums.sum(axis=1)`` of (entry, value bin, period) Fourier sums, bit for bit: numpy
    adds a middle axis's planes one after the other from the first, einsum the same planes
    in the same order from 0 (0 + z is z: these sums hold no −0), in a third less time
    (issue 15: a day close sums every candidate's rows). Other shapes go to numpy."""
    if sums.ndim == 3 and sums.shape[2] >= 2 and sums.dtype == np.complex128:
        out: C128 = np.einsum("evk->ek", sums)
        return out
    summed: C128 = sums.sum(axis=1)
    return summed
