"""FreMEn (Frequency Map Enhancement) on rates: the spectrum of additive accumulators.

For one modelled series (an entry's detections in one direction bin, or its total) observed in
windows at times t_w (float64 seconds since :data:`~aion_cli.engine.windows.EPOCH_NS`), with
counts n_w, the accumulators are ``W`` = number of observed windows, ``S0`` = Σ n_w,
``A_k`` = Σ n_w·e^{iω_k t_w} and ``B_k`` = Σ e^{iω_k t_w} (ω_k = 2π/T_k). Then

    μ = S0 / W,    γ_k = (A_k − μ·B_k) / W,    λ(t) = μ + Σ_{k ∈ top m} 2·Re(γ_k e^{−iω_k t})

— the rate's spectrum corrected for uneven observation (the μ·B term removes the mean's
leakage). All four sums add across logs, so maps of disjoint time merge exactly, and order 0 is
the static rate μ. A period counts only once the series' observed span ``t_last − t_first``
reaches ``span_factor·T`` (a shorter span cannot resolve it). Fixed here against public FreMEn
code (``notes-mod_anchors.md`` §1.6): the balance is exact, the *strongest* components are
used, times are float64 seconds from a recent epoch (float32 UNIX seconds break short periods).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]
C128 = npt.NDArray[np.complex128]
I64 = npt.NDArray[np.int64]
BoolA = npt.NDArray[np.bool_]


def omega(periods: npt.ArrayLike) -> F64:
    """Angular frequencies 2π/T of the candidate periods (seconds)."""
    return np.asarray(2.0 * np.pi / np.asarray(periods, dtype=np.float64), dtype=np.float64)


def phasors(t_s: npt.ArrayLike, w: F64) -> C128:
    """e^{iω_k t} as complex128[T, K] (what the accumulators add per window)."""
    return np.exp(1j * np.multiply.outer(np.asarray(t_s, dtype=np.float64), w))


def admitted(first: F64, last: F64, min_span: F64) -> BoolA:
    """Span gate, bool[R, K]: period k is resolvable once ``last − first ≥ min_span[k]``
    (nothing for a series never observed: NaN span)."""
    with np.errstate(invalid="ignore"):
        out: BoolA = (last - first)[:, None] >= min_span[None, :]
    return out


def top_periods(gamma: C128, gate: BoolA, m: int) -> tuple[I64, BoolA]:
    """The ``m`` strongest admitted periods per row, strongest first (ties: lower index).

    Returns period indices int64[R, m] and a validity mask (False where fewer than ``m``
    periods are admitted; the index there is arbitrary and its coefficient must be 0)."""
    r, k = gamma.shape
    idx = np.zeros((r, m), dtype=np.int64)
    valid = np.zeros((r, m), dtype=bool)
    if m == 0 or r == 0:
        return idx, valid
    power = gamma.real**2 + gamma.imag**2
    power[~gate] = -1.0
    flat = power.reshape(-1)
    base = np.arange(0, r * k, k)
    for j in range(min(m, k)):
        pick = power.argmax(axis=1)
        idx[:, j] = pick
        valid[:, j] = flat.take(base + pick) >= 0.0
        flat[base + pick] = -2.0
    return idx, valid


def evaluate_terms(coef: C128, idx: I64, t_s: npt.ArrayLike, w: F64) -> F64:
    """Σ_j 2·Re(coef_j e^{−iω_{idx_j} t}) for rows × times, cumulative over j.

    ``coef`` complex128[R, m] (γ of the chosen periods, 0 where invalid), ``idx`` int64[R, m].
    Returns float64[m, R, T]: entry [j] is the sum of the first j+1 terms (orders 1..m)."""
    t = np.asarray(t_s, dtype=np.float64).reshape(-1)
    r, m = coef.shape
    out = np.empty((m, r, t.size))
    if m == 0:
        return out
    rot = np.exp(-1j * np.multiply.outer(w, t))  # (K, T)
    acc = np.zeros((r, t.size))
    for j in range(m):
        acc += 2.0 * (coef[:, j, None] * rot.take(idx[:, j], axis=0)).real
        out[j] = acc
    return out
