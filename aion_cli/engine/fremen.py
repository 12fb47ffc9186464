"""One vectorized FreMEn (Frequency Map Enhancement) over every temporal state of a map.

A *row* is one modelled state: an entry's activity, or one of its direction-bin fractions. Rows
are observed at their own times (window centres where the robot saw them), so each row keeps its
own additive accumulators, in float64 seconds since :data:`EPOCH_NS`:

* ``n`` observations, ``sum_s`` = Σ s, ``t_first`` / ``t_last`` (NaN before the first one);
* per candidate period T_k (ω_k = 2π/T_k): ``sum_se`` = Σ s·e^{iω_k t} and ``sum_e`` = Σ e^{iω_k t}.

The spectrum is γ_k = (Σ s e^{iωt} − μ Σ e^{iωt}) / n with μ = Σ s / n: the μ·Σe term (the
"balance") removes the mean's leakage under irregular sampling, and keeping Σe instead of a
rescaled balance makes the accumulators purely additive, so two maps covering disjoint time merge
exactly (:func:`merge_states`). A period counts only once the row's observed span
``t_last − t_first`` reaches ``span_factor · T`` (a shorter span cannot resolve it).

Prediction of order m: p(t) = μ + Σ_{m strongest k} 2|γ_k| cos(ω_k t − φ_k), clamped to [0, 1].
The order is chosen per row by prequential error: before each observation is absorbed it is
predicted with every order 0..M from the state at that moment, and |s − p_m| is added to
``order_err[row, m]``. The chosen order is the lowest order whose mean error is not beaten by a
higher order by more than ``order_bias``. Ties in amplitude go to the lower period index.

Everything runs on whole arrays: ``update`` absorbs W windows for r rows with two matrix
products (values·E and observed·E with E = [cos ωt | sin ωt] of shape W×2K). The prequential
errors are exact (predict-before-absorb in time order) and computed in row chunks: many rows
replay the windows in order on a private copy of the chunk's accumulators, vectorized over rows
and periods (a few cache-sized rows × K arrays per window, chunks on a small thread pool); a few
rows instead evaluate blocks of windows at once from exclusive cumulative sums along the window
axis. Both give the same numbers. Ranking the K amplitudes before every observation is the
dominant cost (see ``benchmarks/bench_fremen.py``); a mean-only model skips it.
``predict`` is one matrix product of per-row coefficients with the basis at the query times.

Fixed here (public FreMEn bugs, see ``notes-mod_anchors.md`` §1.6): the balance is exact across
calls, the mean divides by the number of observations actually absorbed, the strongest (not
weakest) components are used, the best order is a real argmin, predictions are floats, and
times are float64 seconds from a recent epoch (float32 UNIX seconds break short periods).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aion_cli.engine.errors import MapCorruptError

if TYPE_CHECKING:
    from aion_cli.engine.config import ModelConfig

F64 = npt.NDArray[np.float64]
C128 = npt.NDArray[np.complex128]
I64 = npt.NDArray[np.int64]
BoolA = npt.NDArray[np.bool_]

EPOCH_NS: int = 1_578_268_800 * 1_000_000_000
"""The map epoch, 2020-01-06T00:00:00Z (a Monday), in UNIX nanoseconds."""

PRIOR: float = 0.5
"""Prediction for a row that has never been observed (FreMEn's initial gain: no knowledge)."""

_ROW_CHUNK = 1024
"""Rows per chunk of the prequential replay: a few (rows × K) float64 arrays stay in cache."""

_FEW_ROWS = 96
"""Chunks with fewer rows replay with cumulative sums along the window axis instead of a
Python loop over windows (whose per-window overhead dominates for few rows)."""

_BLOCK_CELLS = 1 << 16
"""Rows × windows × periods per block of the cumulative-sum replay."""

_WORKERS = max(1, min(4, os.cpu_count() or 1))
"""Threads for the prequential replay of row chunks."""

_STATE_FIELDS = ("n", "sum_s", "sum_se", "sum_e", "t_first", "t_last", "order_err", "order_n")


def to_model_seconds(t_ns: npt.ArrayLike) -> F64:
    """UNIX nanoseconds -> float64 seconds since :data:`EPOCH_NS` (exact integer subtraction)."""
    t = np.asarray(t_ns, dtype=np.int64)
    return (t - np.int64(EPOCH_NS)).astype(np.float64) / 1e9


def _exclusive_cumsum(x: F64) -> F64:
    """Sum of the strictly earlier entries along axis 1 (the state *before* each window)."""
    out = np.empty_like(x)
    out[:, 0] = 0.0
    if x.shape[1] > 1:
        np.cumsum(x[:, :-1], axis=1, out=out[:, 1:])
    return out


@dataclass
class FremenState:
    """Accumulators of R rows over K periods (struct of arrays), orders 0..M.

    ``sum_se`` / ``sum_e`` are complex128[R, K]; ``order_err`` is float64[R, M+1] (prequential
    absolute-error sums) and ``order_n`` the number of scored observations per row.
    """

    n: F64
    sum_s: F64
    sum_se: C128
    sum_e: C128
    t_first: F64
    t_last: F64
    order_err: F64
    order_n: F64

    @classmethod
    def empty(cls, n_rows: int, n_periods: int, max_order: int) -> FremenState:
        """R rows with no observations."""
        return cls(
            n=np.zeros(n_rows),
            sum_s=np.zeros(n_rows),
            sum_se=np.zeros((n_rows, n_periods), np.complex128),
            sum_e=np.zeros((n_rows, n_periods), np.complex128),
            t_first=np.full(n_rows, np.nan),
            t_last=np.full(n_rows, np.nan),
            order_err=np.zeros((n_rows, max_order + 1)),
            order_n=np.zeros(n_rows),
        )

    @property
    def n_rows(self) -> int:
        return int(self.n.shape[0])

    @property
    def n_periods(self) -> int:
        return int(self.sum_se.shape[1])

    @property
    def max_order(self) -> int:
        return int(self.order_err.shape[1]) - 1

    # -- row operations -------------------------------------------------------------------------
    def add_rows(self, src: npt.ArrayLike, dst: npt.ArrayLike) -> None:
        """``dst += src`` row by row: accumulators add, first = min, last = max.

        Used when a hash cell's state moves into a node (or back). Repeated ``dst`` indices
        accumulate; ``src`` values are read before any write, so overlap is safe.
        """
        s = np.asarray(src, dtype=np.int64).reshape(-1)
        d = np.asarray(dst, dtype=np.int64).reshape(-1)
        if s.shape != d.shape:
            raise ValueError("src and dst must have the same length")
        if s.size == 0:
            return
        vals = {name: getattr(self, name)[s].copy() for name in _STATE_FIELDS}
        for name in ("n", "sum_s", "sum_se", "sum_e", "order_err", "order_n"):
            np.add.at(getattr(self, name), d, vals[name])
        np.fmin.at(self.t_first, d, vals["t_first"])
        np.fmax.at(self.t_last, d, vals["t_last"])

    def zero_rows(self, idx: npt.ArrayLike) -> None:
        """Forget everything about rows ``idx`` (they become never-observed rows)."""
        i = np.asarray(idx, dtype=np.int64).reshape(-1)
        for name in ("n", "sum_s", "sum_se", "sum_e", "order_err", "order_n"):
            getattr(self, name)[i] = 0
        self.t_first[i] = np.nan
        self.t_last[i] = np.nan

    def take(self, idx: npt.ArrayLike) -> FremenState:
        """A new state holding copies of rows ``idx`` (in that order)."""
        i = np.asarray(idx, dtype=np.int64).reshape(-1)
        return FremenState(**{name: getattr(self, name)[i].copy() for name in _STATE_FIELDS})

    def resize(self, n_rows: int) -> None:
        """Truncate to, or extend with empty rows up to, ``n_rows`` rows (in place)."""
        if n_rows < 0:
            raise ValueError("n_rows must be >= 0")
        keep = min(n_rows, self.n_rows)
        new = FremenState.empty(n_rows, self.n_periods, self.max_order)
        for name in _STATE_FIELDS:
            getattr(new, name)[:keep] = getattr(self, name)[:keep]
            setattr(self, name, getattr(new, name))

    def copy(self) -> FremenState:
        return FremenState(**{name: getattr(self, name).copy() for name in _STATE_FIELDS})

    @classmethod
    def concat(cls, states: list[FremenState]) -> FremenState:
        """Rows of every state, in order (all must share K and M)."""
        if not states:
            raise ValueError("concat needs at least one state")
        shapes = {(s.n_periods, s.max_order) for s in states}
        if len(shapes) != 1:
            raise ValueError(f"states differ in periods/orders: {sorted(shapes)}")
        return cls(
            **{name: np.concatenate([getattr(s, name) for s in states]) for name in _STATE_FIELDS}
        )

    # -- persistence ----------------------------------------------------------------------------
    def to_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        """Plain arrays keyed ``prefix + field`` (complex accumulators stay complex128)."""
        return {prefix + name: getattr(self, name) for name in _STATE_FIELDS}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str) -> FremenState:
        """Inverse of :meth:`to_arrays`; raises :class:`MapCorruptError` on missing or
        inconsistent members."""
        missing = [prefix + f for f in _STATE_FIELDS if prefix + f not in arrays]
        if missing:
            raise MapCorruptError(f"FreMEn state incomplete, missing: {', '.join(missing)}")
        kinds = {
            "n": np.float64,
            "sum_s": np.float64,
            "sum_se": np.complex128,
            "sum_e": np.complex128,
            "t_first": np.float64,
            "t_last": np.float64,
            "order_err": np.float64,
            "order_n": np.float64,
        }
        try:
            vals: dict[str, np.ndarray] = {
                f: np.array(arrays[prefix + f], dtype=kinds[f]) for f in _STATE_FIELDS
            }
        except (TypeError, ValueError) as exc:
            raise MapCorruptError(f"FreMEn state has invalid arrays: {exc}") from exc
        r = vals["n"].shape
        ok = (
            len(r) == 1
            and all(vals[f].shape == r for f in ("sum_s", "t_first", "t_last", "order_n"))
            and vals["sum_se"].ndim == 2
            and vals["sum_se"].shape[0] == r[0]
            and vals["sum_e"].shape == vals["sum_se"].shape
            and vals["order_err"].ndim == 2
            and vals["order_err"].shape[0] == r[0]
            and vals["order_err"].shape[1] >= 1
        )
        if not ok:
            shapes = {f: vals[f].shape for f in _STATE_FIELDS}
            raise MapCorruptError(f"FreMEn state arrays have inconsistent shapes: {shapes}")
        return cls(**vals)


def merge_states(a: FremenState, b: FremenState) -> FremenState:
    """One state as if fed the observations of ``a`` and of ``b`` (same rows, disjoint time).

    Accumulators and order errors add; first = min, last = max. The spectrum and predictions
    of the result equal those of a single state fed both streams.
    """
    if (a.n_rows, a.n_periods, a.max_order) != (b.n_rows, b.n_periods, b.max_order):
        raise ValueError("merge_states needs states with the same rows, periods and orders")
    out = a.copy()
    for name in ("n", "sum_s", "sum_se", "sum_e", "order_err", "order_n"):
        getattr(out, name)[...] += getattr(b, name)
    out.t_first = np.fmin(a.t_first, b.t_first)
    out.t_last = np.fmax(a.t_last, b.t_last)
    return out


@dataclass(frozen=True)
class FremenModel:
    """The model parameters shared by every row: candidate periods (s), the highest order, the
    span gate factor and the bias towards lower orders (mean absolute error)."""

    periods: tuple[float, ...]
    max_order: int = 4
    span_factor: float = 1.5
    order_bias: float = 0.002
    omega: F64 = field(init=False, repr=False, compare=False)
    min_span: F64 = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        periods = np.asarray(self.periods, dtype=np.float64)
        if periods.ndim != 1 or periods.size == 0 or not np.all(np.isfinite(periods)):
            raise ValueError("periods must be a non-empty list of finite seconds")
        if np.any(periods <= 0):
            raise ValueError("periods must be positive")
        if self.max_order < 0:
            raise ValueError("max_order must be >= 0")
        object.__setattr__(self, "periods", tuple(float(p) for p in periods))
        object.__setattr__(self, "omega", 2.0 * np.pi / periods)
        object.__setattr__(self, "min_span", self.span_factor * periods)

    @classmethod
    def from_config(cls, config: ModelConfig) -> FremenModel:
        return cls(config.periods, config.max_order, config.span_factor, config.order_bias)

    @property
    def n_periods(self) -> int:
        return len(self.periods)

    def empty(self, n_rows: int) -> FremenState:
        return FremenState.empty(n_rows, self.n_periods, self.max_order)

    def basis(self, t_s: npt.ArrayLike) -> tuple[F64, F64]:
        """cos(ω_k t) and sin(ω_k t) as float64[T, K]."""
        phase = np.multiply.outer(np.asarray(t_s, dtype=np.float64), self.omega)
        return np.cos(phase), np.sin(phase)

    def _check(self, state: FremenState) -> None:
        if state.n_periods != self.n_periods or state.max_order != self.max_order:
            raise ValueError(
                f"state has {state.n_periods} periods / order {state.max_order}, model has "
                f"{self.n_periods} / {self.max_order}"
            )

    # -- learning -------------------------------------------------------------------------------
    def update(
        self,
        state: FremenState,
        rows: npt.ArrayLike,
        t_s: npt.ArrayLike,
        values: npt.ArrayLike,
        observed: npt.ArrayLike,
    ) -> None:
        """Absorb W windows (times ``t_s``, non-decreasing) for ``rows`` (unique), in place.

        ``values[i, w]`` is row ``rows[i]``'s state in window w, used only where
        ``observed[i, w]``. Each observation is first predicted with orders 0..M from the
        row's state just before it (the prequential order errors), then absorbed.
        """
        self._check(state)
        r = np.asarray(rows, dtype=np.int64).reshape(-1)
        t = np.asarray(t_s, dtype=np.float64).reshape(-1)
        obs = np.asarray(observed, dtype=bool)
        v = np.asarray(values, dtype=np.float64)
        if v.shape != (r.size, t.size) or obs.shape != v.shape:
            raise ValueError(
                f"values/observed must have shape ({r.size}, {t.size}), got {v.shape} and "
                f"{obs.shape}"
            )
        if r.size == 0 or t.size == 0:
            return
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
            raise ValueError("t_s must be finite and non-decreasing (windows in time order)")
        if r.min() < 0 or r.max() >= state.n_rows:
            raise IndexError("rows out of range")
        if not (np.all(np.diff(r) > 0) or np.unique(r).size == r.size):  # O(r) when sorted
            raise ValueError("rows must be unique within one update")
        vz = v if obs.all() else np.where(obs, v, 0.0)  # never written to
        if not np.isfinite(vz.sum()):  # one pass; also rejects values near the float limit
            raise ValueError("observed values must be finite")
        cos_t, sin_t = self.basis(t)
        self._score_orders(state, r, t, vz, obs, cos_t, sin_t)
        self._absorb(state, r, t, vz, obs, cos_t, sin_t)

    def _absorb(
        self, state: FremenState, r: I64, t: F64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """Add the windows to the accumulators: two matrix products with E = [cos | sin].

        A contiguous ascending block of rows is written through slices (no gather/scatter);
        when every cell is observed, observed·E is the column sum of E.
        """
        k = self.n_periods
        basis = np.concatenate([cos_t, sin_t], axis=1)  # (W, 2K)
        ve = vz @ basis
        dense = bool(obs.all())
        if dense:
            oe = np.broadcast_to(basis.sum(axis=0), ve.shape)
            n_add = np.full(r.size, float(t.size))
            first = np.full(r.size, t[0])
            last = np.full(r.size, t[-1])
        else:
            oe = obs.astype(np.float64) @ basis
            n_add = obs.sum(axis=1, dtype=np.float64)
            seen = obs.any(axis=1)
            first = np.where(seen, t[np.argmax(obs, axis=1)], np.nan)
            last = np.where(seen, t[t.size - 1 - np.argmax(obs[:, ::-1], axis=1)], np.nan)
        idx: slice | I64 = r
        if r[-1] - r[0] == r.size - 1 and (r.size == 1 or bool(np.all(np.diff(r) == 1))):
            idx = slice(int(r[0]), int(r[-1]) + 1)
        state.sum_se.real[idx] += ve[:, :k]
        state.sum_se.imag[idx] += ve[:, k:]
        state.sum_e.real[idx] += oe[:, :k]
        state.sum_e.imag[idx] += oe[:, k:]
        state.n[idx] += n_add
        state.sum_s[idx] += vz.sum(axis=1)
        state.t_first[idx] = np.fmin(state.t_first[idx], first)
        state.t_last[idx] = np.fmax(state.t_last[idx], last)

    def _score_orders(
        self, state: FremenState, rows: I64, t: F64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """Prequential errors: predict every observation with orders 0..M before absorbing it.

        Rows are split into chunks small enough for the CPU cache; each chunk replays the
        windows in time order on a private copy of its accumulators (vectorized over rows and
        periods) and only writes its rows' ``order_err`` / ``order_n``. Chunks run on a small
        thread pool (numpy releases the GIL inside its loops).
        """
        size = _ROW_CHUNK if self.max_order > 0 else _ROW_CHUNK * 32  # order 0: no K axis
        chunks = [slice(a, min(a + size, rows.size)) for a in range(0, rows.size, size)]

        def run(sl: slice) -> None:
            self._score_chunk(state, rows[sl], t, vz[sl], obs[sl], cos_t, sin_t)

        if len(chunks) > 1 and _WORKERS > 1:
            with ThreadPoolExecutor(max_workers=_WORKERS) as pool:
                list(pool.map(run, chunks))
        else:
            for sl in chunks:
                run(sl)

    def _score_chunk(
        self, state: FremenState, rr: I64, t: F64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """The prequential replay for one chunk of rows (see :meth:`_score_orders`).

        Ranking uses |S − μ·Σe|² = n²|γ|² (same order as |γ|); components the span gate
        rejects are marked −1 and contribute nothing even when fewer than m are admitted.
        """
        c, k = rr.size, self.n_periods
        m_all = self.max_order
        m_eff = min(m_all, k)  # orders above K use every period
        if m_eff == 0:
            self._score_mean_only(state, rr, vz, obs)
            return
        if c < _FEW_ROWS:
            self._score_few_rows(state, rr, t, vz, obs, cos_t, sin_t)
            return
        n = state.n[rr].copy()
        ss = state.sum_s[rr].copy()
        first = state.t_first[rr].copy()
        last = state.t_last[rr].copy()
        sr = np.ascontiguousarray(state.sum_se[rr].real)
        si = np.ascontiguousarray(state.sum_se[rr].imag)
        er = np.ascontiguousarray(state.sum_e[rr].real)
        ei = np.ascontiguousarray(state.sum_e[rr].imag)
        err = np.zeros((c, m_all + 1))
        scored_n = np.zeros(c)
        xr, xi, a2, tmp = (np.empty((c, k)) for _ in range(4))
        min_span = self.min_span[None, :]
        max_span = float(self.min_span.max())
        for w in range(t.size):
            ob = obs[:, w]
            seen = np.flatnonzero(ob)
            if seen.size == 0:
                continue
            s_seen = vz[seen, w]
            sc = seen[n[seen] > 0]
            if sc.size:
                q = sc.size
                if q == c:
                    g_sr, g_si, g_er, g_ei = sr, si, er, ei
                else:
                    g_sr, g_si, g_er, g_ei = sr[sc], si[sc], er[sc], ei[sc]
                bx, by, ba, bt = xr[:q], xi[:q], a2[:q], tmp[:q]
                nn = n[sc]
                mu = ss[sc] / nn
                np.multiply(g_er, mu[:, None], out=bx)
                np.subtract(g_sr, bx, out=bx)
                np.multiply(g_ei, mu[:, None], out=by)
                np.subtract(g_si, by, out=by)
                np.multiply(bx, bx, out=ba)
                np.multiply(by, by, out=bt)
                ba += bt
                span = last[sc] - first[sc]
                if span.min() < max_span:  # some period not yet admitted for some row
                    np.putmask(ba, min_span > span[:, None], -1.0)
                # the m_eff strongest components, strongest first (ties: lowest index)
                ar = np.arange(q)
                picks = np.empty((q, m_eff), dtype=np.int64)
                values = np.empty((q, m_eff))
                for m in range(m_eff):
                    j = np.argmax(ba, axis=1)
                    picks[:, m] = j
                    values[:, m] = ba[ar, j]
                    ba[ar, j] = -2.0
                rows2 = ar[:, None]
                terms = bx[rows2, picks] * cos_t[w, picks] + by[rows2, picks] * sin_t[w, picks]
                terms *= (2.0 / nn)[:, None]
                terms[values < 0.0] = 0.0  # not admitted by the span gate
                p = np.empty((q, m_all + 1))
                p[:, 0] = mu
                np.cumsum(terms, axis=1, out=p[:, 1 : m_eff + 1])
                p[:, 1 : m_eff + 1] += mu[:, None]
                p[:, m_eff + 1 :] = p[:, m_eff : m_eff + 1]
                np.clip(p, 0.0, 1.0, out=p)
                p -= vz[sc, w][:, None]
                err[sc] += np.abs(p)
                scored_n[sc] += 1.0
            # absorb window w into the chunk's private accumulators
            cw, sw = cos_t[w], sin_t[w]
            if seen.size == c:
                np.multiply(s_seen[:, None], cw, out=tmp)
                sr += tmp
                np.multiply(s_seen[:, None], sw, out=tmp)
                si += tmp
                er += cw
                ei += sw
            else:
                sr[seen] += np.multiply.outer(s_seen, cw)
                si[seen] += np.multiply.outer(s_seen, sw)
                er[seen] += cw
                ei[seen] += sw
            n[seen] += 1.0
            ss[seen] += s_seen
            first[seen] = np.fmin(first[seen], t[w])
            last[seen] = np.fmax(last[seen], t[w])
        state.order_err[rr] += err
        state.order_n[rr] += scored_n

    def _score_few_rows(
        self, state: FremenState, rr: I64, t: F64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """The prequential replay for a few rows: blocks of windows, each evaluated at once
        from exclusive cumulative sums (rows × windows × periods), then absorbed into a
        private copy of the rows' accumulators."""
        c, k = rr.size, self.n_periods
        acc = state.take(rr)
        local = np.arange(c, dtype=np.int64)
        err = np.zeros((c, self.max_order + 1))
        scored_n = np.zeros(c)
        step = max(1, _BLOCK_CELLS // (c * k))
        for a in range(0, t.size, step):
            b = min(a + step, t.size)
            e_blk, n_blk = self._score_block(
                acc, t[a:b], vz[:, a:b], obs[:, a:b], cos_t[a:b], sin_t[a:b]
            )
            err += e_blk
            scored_n += n_blk
            self._absorb(acc, local, t[a:b], vz[:, a:b], obs[:, a:b], cos_t[a:b], sin_t[a:b])
        state.order_err[rr] += err
        state.order_n[rr] += scored_n

    def _score_block(
        self, acc: FremenState, t: F64, v: F64, ob: BoolA, cos_t: F64, sin_t: F64
    ) -> tuple[F64, F64]:
        """Order errors (rows × orders) and scored counts of one block of windows for the rows
        of ``acc`` (its state before the block)."""
        m_eff = min(self.max_order, self.n_periods)
        of = ob.astype(np.float64)
        n_pre = acc.n[:, None] + _exclusive_cumsum(of)
        has = n_pre > 0
        n_safe = np.where(has, n_pre, 1.0)
        mu = (acc.sum_s[:, None] + _exclusive_cumsum(v)) / n_safe
        scored = ob & has
        # span before each window: running first / last observed time, from the stored ones
        t_obs = np.where(ob, t[None, :], np.nan)
        first = np.fmin(np.fmin.accumulate(t_obs, axis=1), acc.t_first[:, None])
        last = np.fmax(np.fmax.accumulate(t_obs, axis=1), acc.t_last[:, None])
        span = np.full(first.shape, np.nan)
        span[:, 1:] = last[:, :-1] - first[:, :-1]
        span[:, 0] = acc.t_last - acc.t_first
        with np.errstate(invalid="ignore"):
            gate = (span[..., None] >= self.min_span) & has[..., None]
        sr = _exclusive_cumsum(v[..., None] * cos_t[None]) + acc.sum_se.real[:, None, :]
        si = _exclusive_cumsum(v[..., None] * sin_t[None]) + acc.sum_se.imag[:, None, :]
        er = _exclusive_cumsum(of[..., None] * cos_t[None]) + acc.sum_e.real[:, None, :]
        ei = _exclusive_cumsum(of[..., None] * sin_t[None]) + acc.sum_e.imag[:, None, :]
        xr = sr - mu[..., None] * er
        xi = si - mu[..., None] * ei
        a2 = np.where(gate, xr * xr + xi * xi, -1.0)  # n²|γ|², −1 when not admitted
        contrib = np.where(gate, 2.0 * (xr * cos_t[None] + xi * sin_t[None]), 0.0)
        contrib /= n_safe[..., None]
        err = np.zeros((v.shape[0], self.max_order + 1))
        p = mu
        err[:, 0] = np.where(scored, np.abs(v - np.clip(p, 0.0, 1.0)), 0.0).sum(axis=1)
        for m in range(1, m_eff + 1):
            top = np.argmax(a2, axis=2)[..., None]
            p = p + np.take_along_axis(contrib, top, axis=2)[..., 0]
            np.put_along_axis(a2, top, -2.0, axis=2)
            err[:, m] = np.where(scored, np.abs(v - np.clip(p, 0.0, 1.0)), 0.0).sum(axis=1)
        err[:, m_eff + 1 :] = err[:, m_eff : m_eff + 1]
        return err, scored.sum(axis=1, dtype=np.float64)

    @staticmethod
    def _score_mean_only(state: FremenState, rr: I64, vz: F64, obs: BoolA) -> None:
        """Order 0 only: the prequential mean before each window, from cumulative sums."""
        n0 = state.n[rr]
        if obs.all():  # dense: n before window w is n0 + w, no cumulative count needed
            n_pre = n0[:, None] + np.arange(vz.shape[1], dtype=np.float64)[None, :]
            scored = None
        else:
            of = obs.astype(np.float64)
            n_pre = n0[:, None] + np.cumsum(of, axis=1) - of
            scored = obs & (n_pre > 0)
        diff = np.cumsum(vz, axis=1)
        diff -= vz
        diff += state.sum_s[rr, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            diff /= n_pre
        np.clip(diff, 0.0, 1.0, out=diff)
        diff -= vz
        np.abs(diff, out=diff)
        if scored is None:
            fresh = n0 == 0  # the first window of a never-observed row is not scored
            diff[fresh, 0] = 0.0
            count = vz.shape[1] - fresh.astype(np.float64)
        else:
            diff[~scored] = 0.0
            count = scored.sum(axis=1, dtype=np.float64)
        state.order_err[rr] += diff.sum(axis=1)[:, None]
        state.order_n[rr] += count

    # -- reading --------------------------------------------------------------------------------
    def _rows(self, state: FremenState, rows: npt.ArrayLike | None) -> I64:
        if rows is None:
            return np.arange(state.n_rows, dtype=np.int64)
        return np.asarray(rows, dtype=np.int64).reshape(-1)

    def _gamma(self, state: FremenState, r: I64) -> tuple[F64, C128]:
        """Mean μ (PRIOR for unobserved rows) and the gated spectrum γ for rows ``r``."""
        n = state.n[r]
        has = n > 0
        n_safe = np.where(has, n, 1.0)
        mu = np.where(has, state.sum_s[r] / n_safe, PRIOR)
        gamma = (state.sum_se[r] - mu[:, None] * state.sum_e[r]) / n_safe[:, None]
        with np.errstate(invalid="ignore"):
            gate = (state.t_last[r] - state.t_first[r])[:, None] >= self.min_span
        gamma[~(gate & has[:, None])] = 0.0
        return mu, gamma

    def spectrum(self, state: FremenState, rows: npt.ArrayLike | None = None) -> tuple[F64, F64]:
        """(amplitude |γ|, phase arg γ) as float64[r, K]; 0 for periods the span gate rejects."""
        self._check(state)
        _, gamma = self._gamma(state, self._rows(state, rows))
        return np.abs(gamma), np.angle(gamma)

    def chosen_order(self, state: FremenState) -> I64:
        """Per row, the order 0..M with the lowest mean prequential error (lower-order bias).

        Order m replaces the best lower order only if its mean error is lower by more than
        ``order_bias``; rows with no scored observation use order 0.
        """
        self._check(state)
        return self._choose(state.order_err, state.order_n)

    def _choose(self, order_err: F64, order_n: F64) -> I64:
        """The biased argmin of mean prequential errors (see :meth:`chosen_order`)."""
        mean = order_err / np.maximum(order_n, 1.0)[:, None]
        best = np.zeros(order_n.shape[0], dtype=np.int64)
        best_err = mean[:, 0].copy()
        for m in range(1, self.max_order + 1):
            better = mean[:, m] < best_err - self.order_bias
            best[better] = m
            best_err[better] = mean[better, m]
        return best

    def predict(
        self,
        state: FremenState,
        t_s: npt.ArrayLike,
        rows: npt.ArrayLike | None = None,
        order: int | None = None,
    ) -> F64:
        """Predicted states float64[r, T] in [0, 1] at times ``t_s`` (model seconds).

        ``order=None`` uses each row's chosen order; an int uses that order for every row.
        Rows never observed predict :data:`PRIOR`.
        """
        self._check(state)
        r = self._rows(state, rows)
        t = np.asarray(t_s, dtype=np.float64).reshape(-1)
        if order is None:
            orders = self._choose(state.order_err[r], state.order_n[r])
        else:
            if order < 0:
                raise ValueError("order must be >= 0")
            orders = np.full(r.size, min(int(order), self.n_periods), dtype=np.int64)
        mu, gamma = self._gamma(state, r)
        out = np.empty((r.size, t.size))
        out[...] = mu[:, None]
        top_m = int(orders.max()) if r.size else 0
        if top_m > 0 and t.size > 0:
            k = self.n_periods
            a2 = gamma.real**2 + gamma.imag**2
            rank = np.argsort(-a2, axis=1, kind="stable")[:, :top_m]
            keep = np.arange(top_m)[None, :] < orders[:, None]
            picked = np.where(keep, np.take_along_axis(gamma, rank, axis=1), 0.0)
            coef = np.zeros((r.size, 2 * k))
            np.put_along_axis(coef[:, :k], rank, 2.0 * picked.real, axis=1)
            np.put_along_axis(coef[:, k:], rank, 2.0 * picked.imag, axis=1)
            cos_t, sin_t = self.basis(t)
            out += coef @ np.concatenate([cos_t, sin_t], axis=1).T
        np.clip(out, 0.0, 1.0, out=out)
        return out


def predict_directions(
    model: FremenModel,
    state: FremenState,
    dir_rows: npt.ArrayLike,
    t_s: npt.ArrayLike,
    floor: float,
) -> F64:
    """Direction distributions float64[E, B, T]: each bin's predicted fraction floored at
    ``floor`` (never a zero probability) and renormalised to sum 1 over the B bins."""
    d = np.asarray(dir_rows, dtype=np.int64)
    if d.ndim != 2:
        raise ValueError("dir_rows must have shape (E, B)")
    t = np.asarray(t_s, dtype=np.float64).reshape(-1)
    p = model.predict(state, t, rows=d.reshape(-1)).reshape(d.shape[0], d.shape[1], t.size)
    np.maximum(p, floor, out=p)
    p /= p.sum(axis=1, keepdims=True)
    return p
