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

The order is chosen per row by its *forecast* error, prequentially: time is cut into rank
epochs of ``rank_period`` seconds (a UTC day by default, aligned to :data:`EPOCH_NS`). When a
row is first updated in an epoch, its model is frozen from its state at that moment — the mean
and the M strongest admitted components — in ``rank_*`` arrays; each scored observation of the
epoch is predicted by that frozen model with every order 0..M, and |s − p_m| is added to
``order_err[row, m]``. This is the error of forecasting the day ahead, which is what the map is
used for; a row's first epoch has no earlier model and is not scored. With scoring stride k a
row scores all of its first observations, then only those whose count of earlier observations is
a multiple of k, weighted k (a deterministic subsample depending only on the row's own count).
The chosen order is the lowest order whose mean error is not beaten by a higher order by more
than ``order_bias``. Ties in amplitude go to the lower period index.

Everything runs on whole arrays: ``update`` absorbs W windows for r rows with two matrix
products per epoch (values·E and observed·E with E = [cos ωt | sin ωt] of shape W×2K); ranking
is one top-M selection per row and epoch; a scored observation costs M basis lookups. Results do
not depend on how windows are batched into calls, because the frozen models are part of the
state (and of the map file). ``predict`` is one matrix product of per-row coefficients with the
basis at the query times.

Fixed here (public FreMEn bugs, see ``notes-mod_anchors.md`` §1.6): the balance is exact across
calls, the mean divides by the number of observations actually absorbed, the strongest (not
weakest) components are used, the best order is a real argmin, predictions are floats, and
times are float64 seconds from a recent epoch (float32 UNIX seconds break short periods).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import pairwise
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aion_cli.engine.errors import MapCorruptError
from aion_cli.engine.types import RowTake

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

RANK_PERIOD_S: float = 86_400.0
"""Default rank epoch: a row's forecasting model for the order errors is refrozen daily."""

STALE: int = int(np.iinfo(np.int64).min)
"""``rank_epoch`` of a row whose frozen model must be recomputed before it is scored again."""

_FULL_SCORING = 64
"""With a scoring stride k > 1, a row's first observations are all scored, up to this count
rounded up to a multiple of k; after that every k-th, weighted k (see ``FremenModel``)."""

_SCORE_CELLS = 1 << 21
"""Rows × windows per block of the scoring pass (bounds its temporary arrays to tens of MB)."""

_RANK_ROWS = 1 << 16
"""Rows per block of the top-M selection (rows × K complex temporaries)."""

_ABSORB_ROWS = 1 << 15
"""Rows per block of the accumulator update (its (rows × 2K) temporaries stay ~16 MB)."""

_ADDITIVE = ("n", "sum_s", "sum_se", "sum_e", "order_err", "order_n")
_RANK_FIELDS = ("rank_epoch", "rank_mu", "rank_idx", "rank_coef")
_STATE_FIELDS = ("t_first", "t_last", *_ADDITIVE, *_RANK_FIELDS)


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

    The frozen forecasting model of the current rank epoch (M' = min(M, K)): ``rank_epoch``
    int64[R] (:data:`STALE`: recompute), ``rank_mu`` float64[R] (NaN: nothing was known, the
    epoch is not scored), ``rank_idx`` int16[R, M'] (period indices, strongest first) and
    ``rank_coef`` float64[R, 2M'] ([2 Re γ | 2 Im γ] of those periods; 0 where the span gate
    rejected the period), so a term is ``coef_re·cos ωt + coef_im·sin ωt``.
    """

    n: F64
    sum_s: F64
    sum_se: C128
    sum_e: C128
    t_first: F64
    t_last: F64
    order_err: F64
    order_n: F64
    rank_epoch: I64
    rank_mu: F64
    rank_idx: npt.NDArray[np.int16]
    rank_coef: F64
    high_water: int = field(default=-1, init=False, compare=False, repr=False)
    """Rows from here on have never been written (empty): :meth:`resize` does not copy them.
    −1 at construction means every row (set in ``__post_init__``); :meth:`empty` sets 0."""
    generation: int = field(default=0, init=False, compare=False, repr=False)
    """Bumped by every change of the accumulators (it invalidates the cached predictor)."""
    predictor_cache: tuple[int, FremenModel, Predictor] | None = field(
        default=None, init=False, compare=False, repr=False
    )
    """(generation, model, predictor) of :meth:`FremenModel.predictor`, valid while the
    generation and the model match."""

    def __post_init__(self) -> None:
        if self.high_water < 0:
            self.high_water = self.n_rows

    def _written(self, rows: I64) -> None:
        """Note that ``rows`` are about to be written (raises the high-water mark)."""
        if rows.size:
            self.high_water = max(self.high_water, int(rows.max()) + 1)

    @classmethod
    def empty(cls, n_rows: int, n_periods: int, max_order: int) -> FremenState:
        """R rows with no observations."""
        out = cls._empty_arrays(n_rows, n_periods, max_order)
        out.high_water = 0
        return out

    @classmethod
    def _empty_arrays(cls, n_rows: int, n_periods: int, max_order: int) -> FremenState:
        m = min(max_order, n_periods)
        return cls(
            n=np.zeros(n_rows),
            sum_s=np.zeros(n_rows),
            sum_se=np.zeros((n_rows, n_periods), np.complex128),
            sum_e=np.zeros((n_rows, n_periods), np.complex128),
            t_first=np.full(n_rows, np.nan),
            t_last=np.full(n_rows, np.nan),
            order_err=np.zeros((n_rows, max_order + 1)),
            order_n=np.zeros(n_rows),
            rank_epoch=np.full(n_rows, STALE, np.int64),
            rank_mu=np.full(n_rows, np.nan),
            rank_idx=np.zeros((n_rows, m), np.int16),
            rank_coef=np.zeros((n_rows, 2 * m)),
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
        accumulate; ``src`` values are read before any write, so overlap is safe. The frozen
        models of ``dst`` go stale (refrozen from the combined state at its next update).
        """
        s = np.asarray(src, dtype=np.int64).reshape(-1)
        d = np.asarray(dst, dtype=np.int64).reshape(-1)
        if s.shape != d.shape:
            raise ValueError("src and dst must have the same length")
        written = s < self.high_water  # rows never written are empty: adding them is a no-op
        s, d = s[written], d[written]
        if s.size == 0:
            return
        self._written(d)
        self.generation += 1
        step = s.size if np.intersect1d(s, d).size else _ABSORB_ROWS  # overlap: one pass
        for a in range(0, s.size, step):
            sb, db = s[a : a + step], d[a : a + step]
            vals = {n: getattr(self, n)[sb] for n in (*_ADDITIVE, "t_first", "t_last")}
            for name in _ADDITIVE:
                np.add.at(getattr(self, name), db, vals[name])
            np.fmin.at(self.t_first, db, vals["t_first"])
            np.fmax.at(self.t_last, db, vals["t_last"])
            self.rank_epoch[db] = STALE

    def zero_rows(self, idx: npt.ArrayLike) -> None:
        """Forget everything about rows ``idx`` (they become never-observed rows, equal to the
        rows of :meth:`empty`)."""
        i = np.asarray(idx, dtype=np.int64).reshape(-1)
        i = i[i < self.high_water]  # rows never written are empty already (and stay unbacked)
        for name in _ADDITIVE:
            getattr(self, name)[i] = 0
        self.t_first[i] = np.nan
        self.t_last[i] = np.nan
        self.rank_epoch[i] = STALE
        self.rank_mu[i] = np.nan
        self.rank_idx[i] = 0
        self.rank_coef[i] = 0.0
        self.generation += 1

    def take(self, idx: npt.ArrayLike) -> FremenState:
        """A new state holding copies of rows ``idx`` (in that order)."""
        i = np.asarray(idx, dtype=np.int64).reshape(-1)
        return FremenState(**{name: getattr(self, name)[i].copy() for name in _STATE_FIELDS})

    def resize(self, n_rows: int) -> None:
        """Truncate to, or extend with empty rows up to, ``n_rows`` rows (in place).

        Rows past the high-water mark were never written and are not copied, so capacity
        that was reserved but never used stays unbacked by memory (copying its zeros would
        touch every page of the new arrays)."""
        if n_rows < 0:
            raise ValueError("n_rows must be >= 0")
        keep = min(n_rows, self.high_water)
        new = FremenState._empty_arrays(n_rows, self.n_periods, self.max_order)
        for name in _STATE_FIELDS:
            getattr(new, name)[:keep] = getattr(self, name)[:keep]
            setattr(self, name, getattr(new, name))
        self.high_water = keep
        self.generation += 1

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

    def rows_to_arrays(self, prefix: str, rows: I64) -> dict[str, RowTake]:
        """:meth:`to_arrays` of ``take(rows)``, each member gathered only when written."""
        return {prefix + name: RowTake(getattr(self, name), rows) for name in _STATE_FIELDS}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], prefix: str) -> FremenState:
        """Inverse of :meth:`to_arrays`; raises :class:`MapCorruptError` on missing or
        inconsistent members. Maps written before frozen models were stored (no ``rank_*``
        members) load with every frozen model stale."""
        required = tuple(f for f in _STATE_FIELDS if f not in _RANK_FIELDS)
        missing = [prefix + f for f in required if prefix + f not in arrays]
        has_rank = [prefix + f in arrays for f in _RANK_FIELDS]
        if any(has_rank) and not all(has_rank):
            missing += [prefix + f for f, ok in zip(_RANK_FIELDS, has_rank, strict=True) if not ok]
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
            "rank_epoch": np.int64,
            "rank_mu": np.float64,
            "rank_idx": np.int16,
            "rank_coef": np.float64,
        }
        present = [f for f in _STATE_FIELDS if prefix + f in arrays]
        try:
            vals: dict[str, np.ndarray] = {f: np.array(arrays[prefix + f]) for f in present}
            for f in present:
                if vals[f].dtype.kind not in "fcib" or (
                    vals[f].dtype.kind == "c" and kinds[f] is not np.complex128
                ):
                    raise ValueError(f"{f} has dtype {vals[f].dtype}")
                vals[f] = vals[f].astype(kinds[f], casting="unsafe")
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
            shapes = {f: vals[f].shape for f in present}
            raise MapCorruptError(f"FreMEn state arrays have inconsistent shapes: {shapes}")
        k, m_all = vals["sum_se"].shape[1], vals["order_err"].shape[1] - 1
        if "rank_epoch" not in vals:
            fresh = cls.empty(r[0], k, m_all)
            vals.update({f: getattr(fresh, f) for f in _RANK_FIELDS})
        m = min(m_all, k)
        rank_ok = (
            vals["rank_epoch"].shape == r
            and vals["rank_mu"].shape == r
            and vals["rank_idx"].shape == (r[0], m)
            and vals["rank_coef"].shape == (r[0], 2 * m)
            and bool(np.all((vals["rank_idx"] >= 0) & (vals["rank_idx"] < k)))
        )
        if not rank_ok:
            shapes = {f: vals[f].shape for f in _RANK_FIELDS}
            raise MapCorruptError(f"FreMEn frozen models are inconsistent: {shapes}")
        return cls(**vals)


def merge_states(a: FremenState, b: FremenState) -> FremenState:
    """One state as if fed the observations of ``a`` and of ``b`` (same rows, disjoint time).

    Accumulators and order errors add; first = min, last = max. The spectrum and predictions
    of the result equal those of a single state fed both streams. Frozen models go stale.
    """
    if (a.n_rows, a.n_periods, a.max_order) != (b.n_rows, b.n_periods, b.max_order):
        raise ValueError("merge_states needs states with the same rows, periods and orders")
    out = a.copy()
    for name in _ADDITIVE:
        getattr(out, name)[...] += getattr(b, name)
    out.t_first = np.fmin(a.t_first, b.t_first)
    out.t_last = np.fmax(a.t_last, b.t_last)
    out.rank_epoch[...] = STALE
    return out


def _as_slice(r: I64) -> slice | I64:
    """A contiguous ascending run of row indices as a slice (no gather/scatter), else ``r``."""
    if r[-1] - r[0] == r.size - 1 and (r.size == 1 or bool(np.all(np.diff(r) == 1))):
        return slice(int(r[0]), int(r[-1]) + 1)
    return r


@dataclass
class Predictor:
    """What :meth:`FremenModel.predict` needs per row, precomputed from a state: the mean
    (NaN: never observed, predicts :data:`PRIOR`), the chosen order, and the M' strongest
    admitted components (``idx`` int16[R, M'], ``coef`` = [2 Re γ | 2 Im γ], 0 where not
    admitted). Predicting is then M' basis lookups per row and time, with no ranking."""

    mu: F64
    order: npt.NDArray[np.int8]
    idx: npt.NDArray[np.int16]
    coef: F64
    _form: tuple[F64, C128, I64] | None = field(default=None, init=False, repr=False)

    def _evaluation_form(self) -> tuple[F64, C128, I64]:
        """(base, terms, idx), built on first use: the base (mean, or PRIOR) and complex
        coefficients c = 2γ, zero past each row's order, so p(t) = base + Re Σ c·e^{−iωt}
        needs no order test."""
        if self._form is None:
            m = self.idx.shape[1]
            base = np.where(np.isnan(self.mu), PRIOR, self.mu)
            terms = self.coef[:, :m] + 1j * self.coef[:, m:]
            terms[np.arange(m)[None, :] >= self.order[:, None]] = 0.0
            self._form = (base, terms, self.idx.astype(np.int64))
        return self._form

    @property
    def n_rows(self) -> int:
        return int(self.mu.shape[0])

    def evaluate(self, omega: F64, t: F64, rows: I64 | None = None) -> F64:
        """Predictions float64[r, T] at times ``t`` of rows ``rows`` (all: None)."""
        base, terms, idx = self._evaluation_form()
        if rows is not None:
            base, terms, idx = base[rows], terms[rows], idx[rows]
        out = np.empty((base.size, t.size))
        out[...] = base[:, None]
        if idx.shape[1] and t.size and base.size:
            rot = np.exp(-1j * np.multiply.outer(omega, t))  # (K, T): e^{−iω_k t}
            if t.size == 1:
                out[:, 0] += np.einsum("rm,rm->r", terms, rot[:, 0].take(idx)).real
            elif t.size <= 4:
                for o in range(idx.shape[1]):
                    out += (terms[:, o, None] * rot.take(idx[:, o], axis=0)).real
            else:  # many times: scatter the terms into (r, K) and let BLAS do the rest
                k = rot.shape[0]
                dense = np.zeros((base.size, k), np.complex128)
                np.put_along_axis(dense, idx, terms, axis=1)  # a row's periods are distinct
                out += np.concatenate([dense.real, -dense.imag], axis=1) @ np.concatenate(
                    [rot.real, rot.imag], axis=0
                )
        np.clip(out, 0.0, 1.0, out=out)
        return out

    def take(self, rows: I64) -> Predictor:
        return Predictor(self.mu[rows], self.order[rows], self.idx[rows], self.coef[rows])

    def to_arrays(self, prefix: str) -> dict[str, np.ndarray]:
        return {prefix + f: getattr(self, f) for f in ("mu", "order", "idx", "coef")}

    @classmethod
    def from_arrays(
        cls, arrays: dict[str, np.ndarray], prefix: str, n_rows: int, model: FremenModel
    ) -> Predictor | None:
        """The stored predictor, or None when the map has none (written before predictors
        were stored); :class:`MapCorruptError` when it does not fit ``n_rows`` and ``model``."""
        names = [prefix + f for f in ("mu", "order", "idx", "coef")]
        present = [n in arrays for n in names]
        if not any(present):
            return None
        m = model.n_ranked
        try:
            if not all(present):
                raise ValueError("some members are missing")
            mu = np.asarray(arrays[names[0]])
            order = np.asarray(arrays[names[1]])
            idx = np.asarray(arrays[names[2]])
            coef = np.asarray(arrays[names[3]])
            ok = (
                mu.dtype == np.float64
                and order.dtype == np.int8
                and idx.dtype == np.int16
                and coef.dtype == np.float64
                and mu.shape == (n_rows,)
                and order.shape == (n_rows,)
                and idx.shape == (n_rows, m)
                and coef.shape == (n_rows, 2 * m)
                and bool(np.all((order >= 0) & (order <= model.max_order)))
                and bool(np.all((idx >= 0) & (idx < model.n_periods)))
            )
            if not ok:
                raise ValueError("dtypes, shapes or values do not fit the model")
        except ValueError as exc:
            raise MapCorruptError(f"stored FreMEn predictor is invalid: {exc}") from exc
        return cls(mu, order, idx, coef)


@dataclass(frozen=True)
class FremenModel:
    """The model parameters shared by every row: candidate periods (s), the highest order, the
    span gate factor, the bias towards lower orders (mean absolute error), the scoring stride k
    and the rank epoch (s) of the prequential order errors.

    With n the row's number of earlier observations, an observation is scored iff its row had
    observations before the current rank epoch and either n < F (F = :data:`_FULL_SCORING`
    rounded up to a multiple of k: a young row scores every observation, so its order choice is
    not left to a handful of samples) or n is a multiple of k, then weighted k (it stands for
    itself and the next k − 1). This depends only on each row's own count and on time, never
    on how windows are batched. k = 1 scores every such observation, weight 1."""

    periods: tuple[float, ...]
    max_order: int = 4
    span_factor: float = 1.5
    order_bias: float = 0.002
    score_stride: int = 1
    rank_period: float = RANK_PERIOD_S
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
        if not (np.isfinite(self.rank_period) and self.rank_period > 0):
            raise ValueError(f"rank_period must be a positive number, got {self.rank_period!r}")
        object.__setattr__(self, "score_stride", int(self.score_stride))
        object.__setattr__(self, "rank_period", float(self.rank_period))
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
            rank_period=config.rank_period_s,
        )

    @property
    def n_periods(self) -> int:
        return len(self.periods)

    @property
    def n_ranked(self) -> int:
        """M' = min(M, K): components in a frozen model (orders above K use every period)."""
        return min(self.max_order, self.n_periods)

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

    def rank_epochs(self, t_s: npt.ArrayLike) -> I64:
        """The rank epoch of each time (model seconds): floor(t / rank_period)."""
        return np.floor(np.asarray(t_s, dtype=np.float64) / self.rank_period).astype(np.int64)

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
        ``observed[i, w]``. Per rank epoch spanned by the windows: the rows' stale frozen
        models are refrozen from their current state, the scored observations (see the class
        docstring) are predicted by them with orders 0..M (the prequential order errors), and
        the epoch's windows are absorbed.
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
        state.generation += 1
        state._written(r)
        cos_t, sin_t = self.basis(t)
        epochs = self.rank_epochs(t)
        cuts = [0, *(np.flatnonzero(np.diff(epochs)) + 1).tolist(), t.size]
        for a, b in pairwise(cuts):
            seg = slice(a, b)
            self._freeze(state, r, int(epochs[a]))
            self._score(state, r, vz[:, seg], obs[:, seg], cos_t[seg], sin_t[seg])
            self._absorb(state, r, t[seg], vz[:, seg], obs[:, seg], cos_t[seg], sin_t[seg])

    def _absorb(
        self, state: FremenState, r: I64, t: F64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """Add the windows to the accumulators, in blocks of rows (bounded temporaries)."""
        for a in range(0, r.size, _ABSORB_ROWS):
            sl = slice(a, a + _ABSORB_ROWS)
            self._absorb_rows(state, r[sl], t, vz[sl], obs[sl], cos_t, sin_t)

    def _absorb_rows(
        self, state: FremenState, r: I64, t: F64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """:meth:`_absorb` for one block: two matrix products with E = [cos | sin].

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
        idx = _as_slice(r)
        if isinstance(idx, slice):  # in place through the real / imaginary views
            state.sum_se.real[idx] += ve[:, :k]
            state.sum_se.imag[idx] += ve[:, k:]
            state.sum_e.real[idx] += oe[:, :k]
            state.sum_e.imag[idx] += oe[:, k:]
        else:  # scattered rows: gather whole complex rows, add, scatter (numpy's take and
            # plain assignment are several times faster than an in-place fancy ``+=``)
            acc = np.take(state.sum_se, idx, axis=0)
            acc.real += ve[:, :k]
            acc.imag += ve[:, k:]
            state.sum_se[idx] = acc
            acc = np.take(state.sum_e, idx, axis=0)
            acc.real += oe[:, :k]
            acc.imag += oe[:, k:]
            state.sum_e[idx] = acc
        state.n[idx] += n_add
        state.sum_s[idx] += vz.sum(axis=1)
        state.t_first[idx] = np.fmin(state.t_first[idx], first)
        state.t_last[idx] = np.fmax(state.t_last[idx], last)

    def _freeze(self, state: FremenState, r: I64, epoch: int) -> None:
        """Freeze the forecasting model of epoch ``epoch`` for the rows of ``r`` whose frozen
        model belongs to another epoch (or went stale): see :meth:`_top_components`."""
        todo = r[state.rank_epoch[r] != epoch]
        for a in range(0, todo.size, _RANK_ROWS):
            rows = todo[a : a + _RANK_ROWS]
            mu, idx, coef = self._top_components(state, rows)
            state.rank_mu[rows] = mu
            state.rank_epoch[rows] = epoch
            state.rank_idx[rows] = idx
            state.rank_coef[rows] = coef

    def _top_components(
        self, state: FremenState, rows: I64
    ) -> tuple[F64, npt.NDArray[np.int16], F64]:
        """The rows' current mean (NaN for a row never observed) and their M' strongest
        components the span gate admits, strongest first (ties: lowest period index), as
        period indices and [2 Re γ | 2 Im γ] coefficients; components past the admitted ones
        get coefficient 0."""
        m, k = self.n_ranked, self.n_periods
        c = rows.size
        idx = np.zeros((c, m), dtype=np.int64)
        coef = np.zeros((c, 2 * m))
        has, mu = self._mean(state, rows)
        if m > 0 and c > 0:
            gamma, admitted = self._raw_spectrum(state, rows, mu)
            a2 = gamma.real**2 + gamma.imag**2
            np.putmask(a2, ~admitted, -1.0)
            valid = np.empty((c, m), dtype=bool)
            flat = a2.reshape(-1)
            base = np.arange(0, c * k, k)
            for j in range(m):
                pick = a2.argmax(axis=1)
                idx[:, j] = pick
                valid[:, j] = flat.take(base + pick) >= 0.0
                flat[base + pick] = -2.0
            g = np.take_along_axis(gamma, idx, axis=1)
            g[~valid] = 0.0
            coef[:, :m] = 2.0 * g.real
            coef[:, m:] = 2.0 * g.imag
        return np.where(has, mu, np.nan), idx.astype(np.int16), coef

    def _scored(self, n_pre: F64, obs: BoolA, n0: F64 | None = None) -> BoolA:
        """Which observations pass the stride rule, given each one's count of earlier
        observations of its row (see the class docstring). ``n0``: the rows' counts when every
        window is observed (``n_pre = n0 + w``), which replaces the modulo of every count by
        one per row."""
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

    def _score(
        self, state: FremenState, r: I64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """Add the prequential errors of one epoch's windows (before they are absorbed): each
        scored observation predicted by its row's frozen model with orders 0..M."""
        known = np.flatnonzero(np.isfinite(state.rank_mu[r]))
        if known.size == 0:
            return
        if known.size < r.size:
            r, vz, obs = r[known], vz[known], obs[known]
        w = vz.shape[1]
        step = max(1, _SCORE_CELLS // w)
        for a in range(0, r.size, step):
            sl = slice(a, a + step)
            self._score_rows(state, r[sl], vz[sl], obs[sl], cos_t, sin_t)

    def _score_rows(
        self, state: FremenState, r: I64, vz: F64, obs: BoolA, cos_t: F64, sin_t: F64
    ) -> None:
        """:meth:`_score` for one block of rows that all have a frozen model."""
        c, w = vz.shape
        m, m_all, k = self.n_ranked, self.max_order, self.n_periods
        n0 = state.n[r]
        # rows observed in every window and past their young observations score on a regular
        # grid (the fast path), whatever the other rows of the block do
        full = obs.all(axis=1)
        mature = full & (n0 >= self.full_scoring)
        young = full & (n0 + w <= self.full_scoring)  # every window scored, weight 1
        for rows, stride in ((mature, self.score_stride), (young, 1)):
            if rows.any():
                self._score_dense_grid(state, r[rows], vz[rows], cos_t, sin_t, stride)
        rest = ~(mature | young)
        if not rest.any():
            return
        if not rest.all():
            r, vz, obs, n0 = r[rest], vz[rest], obs[rest], n0[rest]
            c = r.size
        dense = bool(obs.all())
        if dense:
            n_pre = n0[:, None] + np.arange(w, dtype=np.float64)[None, :]
            scored = self._scored(n_pre, obs, n0)
        else:
            n_pre = n0[:, None] + _exclusive_cumsum(obs.astype(np.float64))
            scored = self._scored(n_pre, obs)
        at = np.flatnonzero(scored)  # row-major: row = at // w, window = at % w
        if at.size == 0:
            return
        i, j = np.divmod(at, w)
        weight = self._weights(n_pre.reshape(-1).take(at))
        mu = state.rank_mu[r].take(i)
        p = np.empty((m_all + 1, at.size))
        p[0] = mu
        if m > 0:
            comp = state.rank_idx[r].astype(np.int64)  # (c, m)
            coef = state.rank_coef[r]  # (c, 2m)
            cell = (j * k)[:, None] + comp[i]  # flat index into the (w, K) basis
            terms = coef[i, :m] * cos_t.reshape(-1).take(cell)
            terms += coef[i, m:] * sin_t.reshape(-1).take(cell)
            np.cumsum(terms, axis=1, out=terms)
            p[1 : m + 1] = terms.T
            p[1 : m + 1] += mu
            p[m + 1 :] = p[m]
        np.clip(p, 0.0, 1.0, out=p)
        p -= vz.reshape(-1).take(at)
        np.abs(p, out=p)
        p *= weight
        err = np.empty((c, m_all + 1))
        for o in range(m_all + 1):
            err[:, o] = np.bincount(i, p[o], minlength=c)
        state.order_err[r] += err
        state.order_n[r] += np.bincount(i, weight, minlength=c)

    def _score_dense_grid(
        self, state: FremenState, r: I64, vz: F64, cos_t: F64, sin_t: F64, stride: int
    ) -> None:
        """:meth:`_score_rows` for rows observed in every window that are either past their
        young observations (``stride`` = k: row i scores windows j ≡ −n_i (mod k), each
        weighted k) or young in every window of the call (``stride`` = 1: all scored, weight
        1). The scored observations form a regular (rows × ⌈W/stride⌉) grid: no index search."""
        c, w = vz.shape
        m, m_all, k = self.n_ranked, self.max_order, self.n_periods
        slots = -(-w // stride)
        n0 = state.n[r]
        phase = np.fmod(stride - np.fmod(n0, stride), stride).astype(np.int64)
        j = phase[:, None] + stride * np.arange(slots, dtype=np.int64)[None, :]
        outside = j >= w
        np.minimum(j, w - 1, out=j)
        v = np.take_along_axis(vz, j, axis=1)
        mu = state.rank_mu[r][:, None]
        err = np.empty((c, m_all + 1))
        p = np.broadcast_to(mu, v.shape).copy()
        e = np.empty_like(p)
        for o in range(m + 1):
            if o > 0:
                cell = j * k
                cell += state.rank_idx[r, o - 1].astype(np.int64)[:, None]
                p += state.rank_coef[r, o - 1][:, None] * cos_t.reshape(-1).take(cell)
                p += state.rank_coef[r, m + o - 1][:, None] * sin_t.reshape(-1).take(cell)
            np.clip(p, 0.0, 1.0, out=e)
            e -= v
            np.abs(e, out=e)
            e[outside] = 0.0
            err[:, o] = e.sum(axis=1)
        err[:, m + 1 :] = err[:, m : m + 1]
        err *= float(stride)
        state.order_err[r] += err
        state.order_n[r] += float(stride) * (slots - outside.sum(axis=1))

    # -- reading --------------------------------------------------------------------------------
    def _rows(self, state: FremenState, rows: npt.ArrayLike | None) -> I64:
        if rows is None:
            return np.arange(state.n_rows, dtype=np.int64)
        return np.asarray(rows, dtype=np.int64).reshape(-1)

    def _mean(self, state: FremenState, r: I64) -> tuple[BoolA, F64]:
        """For rows ``r``: observed at all, and the mean Σs/n (0 for a row never observed)."""
        n = state.n[r]
        has = n > 0
        return has, state.sum_s[r] / np.where(has, n, 1.0)

    def _raw_spectrum(self, state: FremenState, r: I64, mu: F64) -> tuple[C128, BoolA]:
        """For rows ``r`` with means ``mu`` (see :meth:`_mean`): the spectrum γ before the
        span gate and the gate's admitted mask (rows × K; nothing for a row never observed)."""
        gamma = np.take(state.sum_e, r, axis=0)
        gamma *= -mu[:, None]
        gamma += np.take(state.sum_se, r, axis=0)
        gamma /= np.maximum(state.n[r], 1.0)[:, None]
        with np.errstate(invalid="ignore"):  # NaN span (never observed): nothing admitted
            admitted = (state.t_last[r] - state.t_first[r])[:, None] >= self.min_span
        return gamma, admitted

    def _gamma(self, state: FremenState, r: I64) -> tuple[F64, C128]:
        """Mean μ (PRIOR for unobserved rows) and the gated spectrum γ for rows ``r``."""
        has, mu = self._mean(state, r)
        gamma, admitted = self._raw_spectrum(state, r, mu)
        gamma[~admitted] = 0.0
        return np.where(has, mu, PRIOR), gamma

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

    def predictor(
        self, state: FremenState, rows: npt.ArrayLike | None = None, cache: bool = True
    ) -> Predictor:
        """Per-row prediction coefficients (:class:`Predictor`) of ``rows`` (all: None).

        Cached on the state while it is unchanged: a request for at least a quarter of the
        rows computes and caches every row's (unless ``cache`` is False), so repeated
        whole-map predictions rank the components once; a map file stores the predictor of
        its state (see :meth:`attach_predictor`), so a loaded map predicts without ranking."""
        self._check(state)
        r = None if rows is None else np.asarray(rows, dtype=np.int64).reshape(-1)
        pred = self._cached(state)
        if pred is not None:
            if r is None and pred.n_rows == state.n_rows:
                return pred
            if r is not None and (r.size == 0 or int(r.max()) < pred.n_rows):
                return pred.take(r)
        if r is not None and (4 * r.size < state.n_rows or not cache):
            return self._compute_predictor(state, r)
        pred = self._compute_predictor(state, np.arange(state.n_rows, dtype=np.int64))
        state.predictor_cache = (state.generation, self, pred)
        return pred if r is None else pred.take(r)

    def _cached(self, state: FremenState) -> Predictor | None:
        """The state's cached predictor if it is still valid for this model."""
        cache = state.predictor_cache
        if cache is not None and cache[0] == state.generation and cache[1] == self:
            return cache[2]
        return None

    def attach_predictor(self, state: FremenState, pred: Predictor) -> None:
        """Cache ``pred`` (e.g. read from a map file) as the predictor of ``state``'s first
        ``pred.n_rows`` rows, valid until the state changes."""
        self._check(state)
        if pred.n_rows > state.n_rows or pred.idx.shape[1] != self.n_ranked:
            raise ValueError("predictor does not fit the state")
        state.predictor_cache = (state.generation, self, pred)

    def _compute_predictor(self, state: FremenState, r: I64) -> Predictor:
        order = self._choose(state.order_err[r], state.order_n[r]).astype(np.int8)
        mu = np.empty(r.size)
        idx = np.empty((r.size, self.n_ranked), np.int16)
        coef = np.empty((r.size, 2 * self.n_ranked))
        for a in range(0, r.size, _RANK_ROWS):
            sl = slice(a, a + _RANK_ROWS)
            mu[sl], idx[sl], coef[sl] = self._top_components(state, r[sl])
        return Predictor(mu, order, idx, coef)

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
            pred = self._cached(state)
            if pred is None or (r.size > 0 and int(r.max()) >= pred.n_rows):
                if 4 * r.size < state.n_rows:  # a few rows: rank just those
                    return self.predictor(state, r).evaluate(self.omega, t)
                pred = self.predictor(state)  # every row's, cached for the next call
            if t.size <= 4 and 2 * r.size >= pred.n_rows:  # outputs are cheaper to gather
                out = pred.evaluate(self.omega, t)
                if r.size == pred.n_rows and bool(np.all(r == np.arange(r.size))):
                    return out  # every row in order (a loaded map's whole table)
                return out[r]
            return pred.evaluate(self.omega, t, r)
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
    return normalise_directions(p, floor)


def normalise_directions(p: F64, floor: float) -> F64:
    """Predicted direction fractions float64[E, B, T], in place: floored at ``floor`` and
    renormalised to sum 1 over the B bins."""
    np.maximum(p, floor, out=p)
    p /= p.sum(axis=1, keepdims=True)
    return p
