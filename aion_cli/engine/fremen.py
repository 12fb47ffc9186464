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
The order is chosen per row by prequential error: before a scored observation is absorbed it is
predicted with every order 0..M from the state at that moment, and |s − p_m| is added to
``order_err[row, m]``. With scoring stride k (``FremenModel.score_stride``) a row scores all of
its first observations, then only those whose count of earlier observations is a multiple of k,
weighted k (an unbiased, deterministic subsample that depends only on the row's own count). The
chosen order is the lowest order whose mean error is not beaten by a higher order by more than
``order_bias``. Ties in amplitude go to the lower period index.

Everything runs on whole arrays: ``update`` absorbs W windows for r rows with two matrix
products (values·E and observed·E with E = [cos ωt | sin ωt] of shape W×2K). The prequential
errors are exact (predict-before-absorb in time order) and computed in row chunks: many rows
replay blocks of k windows in order on a private copy of the chunk's accumulators (one small
matrix product per block, the scored observations ranked from the block's start plus its earlier
windows; cache-sized chunks on a small thread pool); a few rows instead evaluate blocks of
windows at once from cumulative sums along the window axis, at the scored observations only.
Both give the same numbers. Ranking the K amplitudes of a scored observation is the dominant
cost (see ``benchmarks/bench_fremen.py``); a mean-only model skips it.
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

_FULL_SCORING = 64
"""With a scoring stride k > 1, a row's first observations are all scored, up to this count
rounded up to a multiple of k; after that every k-th, weighted k (see ``FremenModel``)."""

_STATE_FIELDS = ("n", "sum_s", "sum_se", "sum_e", "t_first", "t_last", "order_err", "order_n")


def _add_weighted(err: F64, count: F64, i: I64, errs: F64, weight: F64) -> None:
    """``err[i] += weight·errs`` and ``count[i] += weight`` for scored observations sorted by
    row ``i`` (a row may repeat: several scored observations in one block)."""
    if weight.max() != 1.0:  # weights are 1 or the stride
        errs *= weight[:, None]
    if i.size > 1 and not bool(np.all(i[1:] != i[:-1])):
        np.add.at(err, i, errs)
        np.add.at(count, i, weight)
    else:
        err[i] += errs
        count[i] += weight


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
    absolute-error sums) and ``order_n`` the number of observations they stand for per row
    (scored observations, weighted by the scoring stride after a row's first ones).
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
    span gate factor, the bias towards lower orders (mean absolute error) and the scoring
    stride k for the prequential order errors.

    With n the row's number of earlier observations, an observation is scored iff n > 0 and
    either n < F (F = :data:`_FULL_SCORING` rounded up to a multiple of k: a young row scores
    every observation, so its order choice is not left to a handful of samples) or n is a
    multiple of k, then weighted k (it stands for itself and the next k − 1). The weighted sums
    are thus an unbiased, deterministic subsample of the full prequential sums, depending only
    on each row's own count (independent of how windows are batched). k = 1 scores every
    observation after the first, weight 1."""

    periods: tuple[float, ...]
    max_order: int = 4
    span_factor: float = 1.5
    order_bias: float = 0.002
    score_stride: int = 1
    full_scoring: int = field(init=False, repr=False, compare=False)
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
        if not (isinstance(self.score_stride, (int, np.integer)) and self.score_stride >= 1):
            raise ValueError(f"score_stride must be an integer >= 1, got {self.score_stride!r}")
        object.__setattr__(self, "score_stride", int(self.score_stride))
        k = self.score_stride
        object.__setattr__(self, "full_scoring", -(-_FULL_SCORING // k) * k if k > 1 else 0)
        object.__setattr__(self, "periods", tuple(float(p) for p in periods))
        object.__setattr__(self, "omega", 2.0 * np.pi / periods)
        object.__setattr__(self, "min_span", self.span_factor * periods)

    @classmethod
    def from_config(cls, config: ModelConfig) -> FremenModel:
        return cls(
            config.periods,
            config.max_order,
            config.span_factor,
            config.order_bias,
            score_stride=config.score_stride,
        )

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
        ``observed[i, w]``. Each scored observation (see ``score_stride``) is first predicted
        with orders 0..M from the row's state just before it (the prequential order errors);
        every observation is absorbed.
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

    def _scored(self, n_pre: F64, obs: BoolA, n0: F64 | None = None) -> BoolA:
        """Which observations are scored, given each one's count of earlier observations of its
        row (see the class docstring). ``n0``: the rows' counts when every window is observed
        (``n_pre = n0 + w``), which replaces the modulo of every count by one per row."""
        k = self.score_stride
        if k == 1:
            return obs & (n_pre > 0)
        if n0 is None:
            scored = (n_pre < self.full_scoring) | (np.fmod(n_pre, k) == 0.0)
            scored &= obs
        else:  # window w is scored iff w = -n0 (mod k), or the row is still young
            phase = np.fmod(k - np.fmod(n0, k), k).astype(np.int64)
            scored = (np.arange(n_pre.shape[1]) % k)[None, :] == phase[:, None]
            if n0.min() < self.full_scoring:
                scored |= n_pre < self.full_scoring
        if n0 is None or n0.min() <= 0:
            scored &= n_pre > 0
        return scored

    def _weights(self, n_pre: F64) -> F64:
        """Weights of scored observations: 1 while the row is young, else the stride."""
        return np.where(n_pre < self.full_scoring, 1.0, float(self.score_stride))

    def _score_orders(
        self, state: FremenState, rows: I64, t: F64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """Prequential errors: predict the scored observations with orders 0..M from the row's
        state just before each of them (see :meth:`_scored`).

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

    def _pair_errors(
        self,
        s_se: F64,
        s_e: F64,
        n_p: F64,
        ss_p: F64,
        span_p: F64 | None,
        wi: I64 | int,
        v_p: F64,
        cos_t: F64,
        sin_t: F64,
    ) -> F64:
        """|s − p_m| for orders 0..M (float64[q, M+1]) of q scored observations, each from
        the state just before it: ``s_se`` / ``s_e`` = [Re | Im] of Σs·e^{iωt} / Σe^{iωt}
        (float64[q, 2K]), count, Σs and span (None: every period admitted), at window ``wi``
        with value ``v_p``.

        Ranking uses |S − μ·Σe|² = n²|γ|² (same order as |γ|); components the span gate
        rejects are marked −1 and contribute nothing even when fewer than m are admitted.
        """
        k, m_all = self.n_periods, self.max_order
        m_eff = min(m_all, k)  # orders above K use every period
        q = n_p.size
        mu = ss_p / n_p
        x = np.multiply(s_e, mu[:, None])
        np.subtract(s_se, x, out=x)  # [Re | Im] of n·γ, contiguous (q, 2K)
        xr, xi = x[:, :k], x[:, k:]
        a2 = np.multiply(xr, xr)
        a2 += np.square(xi)
        if span_p is not None and span_p.min() < float(self.min_span.max()):  # gate binds
            np.putmask(a2, self.min_span[None, :] > span_p[:, None], -1.0)
        # the m_eff strongest components, strongest first (ties: lowest index), through flat
        # indices (much cheaper than 2-d fancy indexing)
        a2_flat, x_flat = a2.reshape(-1), x.reshape(-1)
        row_a2 = np.arange(0, q * k, k)
        row_x = np.arange(0, q * 2 * k, 2 * k)
        terms = np.empty((m_eff, q))
        gated = np.empty((m_eff, q), dtype=bool)
        for m in range(m_eff):
            j = a2.argmax(axis=1)
            at = row_a2 + j
            gated[m] = a2_flat.take(at) < 0.0  # not admitted by the span gate
            a2_flat[at] = -2.0
            at = row_x + j
            if isinstance(wi, np.ndarray):
                cw, sw = cos_t.take(wi * k + j), sin_t.take(wi * k + j)
            else:
                cw, sw = cos_t[wi].take(j), sin_t[wi].take(j)
            np.multiply(x_flat.take(at), cw, out=terms[m])
            terms[m] += x_flat.take(at + k) * sw
        terms *= 2.0 / n_p
        terms[gated] = 0.0
        p = np.empty((m_all + 1, q))
        p[0] = mu
        p[1] = terms[0]
        for m in range(1, m_eff):  # the running sum of terms, as np.cumsum (cheaper here)
            np.add(p[m], terms[m], out=p[m + 1])
        p[1 : m_eff + 1] += mu
        p[m_eff + 1 :] = p[m_eff]
        np.clip(p, 0.0, 1.0, out=p)
        p -= v_p
        return np.abs(p, out=p).T

    def _score_chunk(
        self, state: FremenState, rr: I64, t: F64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """The prequential replay for one chunk of rows (see :meth:`_score_orders`).

        Windows go in blocks of B = ``score_stride`` (B consecutive counts hold one multiple of
        the stride, so a row past its fully scored start has at most one scored observation
        per block). The scored observations of a block are ranked from the block's starting
        accumulators plus the earlier windows of the block (one small matrix product); then
        the whole block is absorbed with one matrix product, as :meth:`_absorb` does.
        Un-scored observations cost only that absorb.
        """
        c, k = rr.size, self.n_periods
        if min(self.max_order, k) == 0:
            self._score_mean_only(state, rr, vz, obs)
            return
        if c < _FEW_ROWS:
            self._score_few_rows(state, rr, t, vz, obs, cos_t, sin_t)
            return
        n = state.n[rr].copy()
        ss = state.sum_s[rr].copy()
        first = state.t_first[rr].copy()
        last = state.t_last[rr].copy()
        acc_se = np.concatenate([state.sum_se[rr].real, state.sum_se[rr].imag], axis=1)
        acc_e = np.concatenate([state.sum_e[rr].real, state.sum_e[rr].imag], axis=1)
        basis = np.concatenate([cos_t, sin_t], axis=1)  # (W, 2K)
        err = np.zeros((c, self.max_order + 1))
        scored_n = np.zeros(c)
        step = stride = self.score_stride
        # spans only grow: when every row's span already admits every period, the span gate
        # cannot bind and first / last need no tracking (NaN: a row never observed)
        with np.errstate(invalid="ignore"):
            gated = not bool(np.all(last - first >= self.min_span.max()))
        mature = max(self.full_scoring, 1)  # rows from here on score once per block, weight k
        for a in range(0, t.size, step):
            b = min(a + step, t.size)
            ob, v, e_blk = obs[:, a:b], vz[:, a:b], basis[a:b]
            dense = bool(ob.all())
            of = ob.astype(np.float64)
            if dense and n.min() >= mature:  # row r scores window j_r = (-n_r) mod k, if any
                jf = np.fmod(stride - np.fmod(n, stride), stride) if stride > 1 else None
                if jf is None or not jf.any():  # every row scores the block's first window
                    errs = self._pair_errors(
                        acc_se,
                        acc_e,
                        n,
                        ss,
                        last - first if gated else None,
                        a,
                        v[:, 0],
                        cos_t,
                        sin_t,
                    )
                    if stride > 1:
                        errs *= float(stride)
                    err += errs
                    scored_n += float(stride)
                    i = np.empty(0, dtype=np.int64)
                else:
                    i = np.flatnonzero(jf < b - a)
                    j = jf[i].astype(np.int64)
                    n_p = n[i] + jf[i]
            else:
                if dense:
                    n_pre = n[:, None] + np.arange(b - a, dtype=np.float64)[None, :]
                else:
                    n_pre = n[:, None] + _exclusive_cumsum(of)
                i, j = np.nonzero(self._scored(n_pre, ob, n if dense else None))  # by row
                n_p = n_pre[i, j]
            if i.size:
                s_se, s_e = acc_se[i], acc_e[i]
                ss_p = ss[i]
                f_p, l_p = first[i], last[i]
                if j.max() > 0:  # add the block's windows before each scored one
                    before = np.arange(b - a)[None, :] < j[:, None]
                    v_before = np.where(before, v[i], 0.0)
                    s_se += v_before @ e_blk
                    ss_p = ss_p + v_before.sum(axis=1)
                    if dense:
                        s_e += _exclusive_cumsum(e_blk.T).T[j]
                        t_in = np.where(j > 0, t[a], np.nan)
                        l_in = np.where(j > 0, t[np.maximum(a + j - 1, a)], np.nan)
                    else:
                        o_before = ob[i] & before
                        s_e += o_before.astype(np.float64) @ e_blk
                        if gated:
                            seen = o_before.any(axis=1)
                            t_in = np.where(seen, t[a + np.argmax(o_before, axis=1)], np.nan)
                            back = np.argmax(o_before[:, ::-1], axis=1)
                            l_in = np.where(seen, t[b - 1 - back], np.nan)
                    if gated:
                        f_p = np.fmin(f_p, t_in)
                        l_p = np.fmax(l_p, l_in)
                span_p = l_p - f_p if gated else None
                errs = self._pair_errors(s_se, s_e, n_p, ss_p, span_p, a + j, v[i, j], cos_t, sin_t)
                _add_weighted(err, scored_n, i, errs, self._weights(n_p))
            # absorb the block into the chunk's private accumulators
            acc_se += v @ e_blk
            ss += v.sum(axis=1)
            if dense:
                acc_e += e_blk.sum(axis=0)
                n += float(b - a)
                first = np.fmin(first, t[a])
                last = np.fmax(last, t[b - 1])
            else:
                acc_e += of @ e_blk
                n += of.sum(axis=1)
                if gated:
                    seen = ob.any(axis=1)
                    t_in = np.where(seen, t[a + np.argmax(ob, axis=1)], np.nan)
                    first = np.fmin(first, t_in)
                    back = np.argmax(ob[:, ::-1], axis=1)
                    last = np.fmax(last, np.where(seen, t[b - 1 - back], np.nan))
        state.order_err[rr] += err
        state.order_n[rr] += scored_n

    def _score_few_rows(
        self, state: FremenState, rr: I64, t: F64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """The prequential replay for a few rows: blocks of windows, each evaluated at once
        from exclusive cumulative sums (rows × windows × periods) at its scored observations,
        then absorbed into a private copy of the rows' accumulators."""
        c, k = rr.size, self.n_periods
        acc = state.take(rr)
        local = np.arange(c, dtype=np.int64)
        err = np.zeros((c, self.max_order + 1))
        scored_n = np.zeros(c)
        step = max(1, _BLOCK_CELLS // (c * k))
        for a in range(0, t.size, step):
            b = min(a + step, t.size)
            self._score_block(acc, t[a:b], a, vz[:, a:b], obs[:, a:b], cos_t, sin_t, err, scored_n)
            self._absorb(acc, local, t[a:b], vz[:, a:b], obs[:, a:b], cos_t[a:b], sin_t[a:b])
        state.order_err[rr] += err
        state.order_n[rr] += scored_n

    def _score_block(
        self,
        acc: FremenState,
        t: F64,
        a: int,
        v: F64,
        ob: BoolA,
        cos_t: F64,
        sin_t: F64,
        err: F64,
        scored_n: F64,
    ) -> None:
        """Add the order errors and scored counts of one block of windows (``t`` = windows
        a.. of ``cos_t`` / ``sin_t``) for the rows of ``acc`` (its state before the block)."""
        of = ob.astype(np.float64)
        n_pre = acc.n[:, None] + _exclusive_cumsum(of)
        i, j = np.nonzero(self._scored(n_pre, ob))
        if i.size == 0:
            return
        ss_p = acc.sum_s[i] + _exclusive_cumsum(v)[i, j]
        # span before each window: running first / last observed time, from the stored ones
        t_obs = np.where(ob, t[None, :], np.nan)
        run_first = np.fmin.accumulate(t_obs, axis=1)
        run_last = np.fmax.accumulate(t_obs, axis=1)
        jm = np.maximum(j - 1, 0)
        prior = j > 0
        f_p = np.fmin(acc.t_first[i], np.where(prior, run_first[i, jm], np.nan))
        l_p = np.fmax(acc.t_last[i], np.where(prior, run_last[i, jm], np.nan))
        # accumulators before each scored window: inclusive cumsums read one window earlier
        w = t.size
        basis = np.concatenate([cos_t[a : a + w], sin_t[a : a + w]], axis=1)  # (w, 2K)
        s_se = np.concatenate([acc.sum_se.real, acc.sum_se.imag], axis=1)[i]
        s_e = np.concatenate([acc.sum_e.real, acc.sum_e.imag], axis=1)[i]
        if prior.any():
            rows = np.unique(i[prior])  # only rows scored after their block's first window
            local = np.searchsorted(rows, i[prior])
            wmax = int(jm[prior].max()) + 1  # later windows are never read
            cs = np.cumsum(v[rows, :wmax, None] * basis[None, :wmax], axis=1)
            s_se[prior] += cs[local, jm[prior]]
            if ob[rows, :wmax].all():
                s_e[prior] += np.cumsum(basis[:wmax], axis=0)[jm[prior]]
            else:
                cs = np.cumsum(of[rows, :wmax, None] * basis[None, :wmax], axis=1)
                s_e[prior] += cs[local, jm[prior]]
        n_p = n_pre[i, j]
        errs = self._pair_errors(s_se, s_e, n_p, ss_p, l_p - f_p, a + j, v[i, j], cos_t, sin_t)
        _add_weighted(err, scored_n, i, errs, self._weights(n_p))

    def _score_mean_only(self, state: FremenState, rr: I64, vz: F64, obs: BoolA) -> None:
        """Order 0 only: the prequential mean before each window, from cumulative sums."""
        n0 = state.n[rr]
        w = vz.shape[1]
        k = self.score_stride
        dense = bool(obs.all())
        diff = np.cumsum(vz, axis=1)
        diff -= vz
        if dense and k > 1:
            self._score_mean_only_dense(state, rr, vz, diff)
            return
        if dense:  # n before window w is n0 + w, no cumulative count needed
            n_pre = n0[:, None] + np.arange(w, dtype=np.float64)[None, :]
        else:
            of = obs.astype(np.float64)
            n_pre = n0[:, None] + np.cumsum(of, axis=1) - of
        scored = self._scored(n_pre, obs, n0 if dense else None)
        at = np.flatnonzero(scored) if self.score_stride > 1 else None
        if at is not None and at.size < scored.size // 4:  # few scored (rows past their start)
            i = at // w
            n_p = n_pre.reshape(-1).take(at)
            mean = diff.reshape(-1).take(at)
            mean += state.sum_s[rr].take(i)
            mean /= n_p
            np.clip(mean, 0.0, 1.0, out=mean)
            mean -= vz.reshape(-1).take(at)
            weight = self._weights(n_p)
            mean = np.abs(mean, out=mean) * weight
            state.order_err[rr] += np.bincount(i, mean, minlength=rr.size)[:, None]
            state.order_n[rr] += np.bincount(i, weight, minlength=rr.size)
            return
        diff += state.sum_s[rr, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            diff /= n_pre
        np.clip(diff, 0.0, 1.0, out=diff)
        diff -= vz
        np.abs(diff, out=diff)
        diff[~scored] = 0.0
        if at is None:
            state.order_err[rr] += diff.sum(axis=1)[:, None]
            state.order_n[rr] += scored.sum(axis=1, dtype=np.float64)
            return
        weight = np.where(scored, self._weights(n_pre), 0.0)
        diff *= weight
        state.order_err[rr] += diff.sum(axis=1)[:, None]
        state.order_n[rr] += weight.sum(axis=1)

    def _score_mean_only_dense(self, state: FremenState, rr: I64, vz: F64, diff: F64) -> None:
        """:meth:`_score_mean_only` for every window observed and a stride k > 1. ``diff``:
        Σ s of the call's earlier windows. Row r is young in windows j < Y_r (F − n0_r: all
        scored, weight 1), then scores windows start_r + k·m (weight k), start_r ≡ −n0_r."""
        c, w = vz.shape
        k, full = self.score_stride, self.full_scoring
        n0, s0 = state.n[rr], state.sum_s[rr]
        young = np.clip(full - n0, 0, w).astype(np.int64)
        phase = np.fmod(k - np.fmod(n0, k), k).astype(np.int64)
        start = np.maximum(young, phase)  # young > 0 is ≡ phase (F is a multiple of k)
        cols = start[:, None] + np.arange(0, w, k)[None, :]
        inside = cols < w
        np.minimum(cols, w - 1, out=cols)
        at = (np.arange(c) * w)[:, None] + cols
        mean = diff.reshape(-1).take(at)
        mean += s0[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):  # cells outside: 0 / 0
            mean /= n0[:, None] + cols
        np.clip(mean, 0.0, 1.0, out=mean)
        mean -= vz.reshape(-1).take(at)
        np.abs(mean, out=mean)
        mean[~inside] = 0.0
        err = float(k) * mean.sum(axis=1)
        count = float(k) * inside.sum(axis=1)
        y = int(young.max())
        if y > 0:  # the young windows: every one scored but a row's very first
            d = diff[:, :y] + s0[:, None]
            with np.errstate(divide="ignore", invalid="ignore"):
                d /= n0[:, None] + np.arange(y, dtype=np.float64)[None, :]
            np.clip(d, 0.0, 1.0, out=d)
            d -= vz[:, :y]
            np.abs(d, out=d)
            d[np.arange(y)[None, :] >= young[:, None]] = 0.0
            fresh = n0 == 0
            d[fresh, 0] = 0.0
            err += d.sum(axis=1)
            count += young - fresh
        state.order_err[rr] += err[:, None]
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
