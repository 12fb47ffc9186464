"""Time windows of Δ seconds aligned to the UNIX epoch, and the model's time base.

Window ``w`` covers ``[w·Δ, (w+1)·Δ)`` in integer nanoseconds, so every map built with the same
Δ uses the same windows whatever log it started from (needed to continue and merge maps). A
window enters the temporal model at its centre time; FreMEn phases use *model seconds*, float64
seconds since :data:`EPOCH_NS` (a recent epoch: float seconds since 1970 would lose the
precision short periods need). These are UTC; a map's FreMEn phases take its own clock,
``TemporalParams.model_seconds`` (UTC plus the zone's daylight-saving shift).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, I64
from aion_cli.errors import ConfigError

EPOCH_NS: int = 1_578_268_800 * 1_000_000_000
"""The model epoch, 2020-01-06T00:00:00Z (a Monday), in UNIX nanoseconds."""


def to_model_seconds(t_ns: npt.ArrayLike) -> F64:
    """UNIX nanoseconds -> float64 seconds since :data:`EPOCH_NS` (exact integer subtraction)."""
    t = np.asarray(t_ns, dtype=np.int64)
    out: F64 = (t - np.int64(EPOCH_NS)).astype(np.float64) / 1e9
    return out


def window_ns(window_s: float) -> int:
    """Δ in integer nanoseconds (rounded); :class:`ConfigError` if not at least 1 ns."""
    delta = round(float(window_s) * 1e9)
    if delta < 1:
        raise ConfigError(f"window_s must be at least 1 ns, got {window_s!r}")
    return int(delta)


def window_index(t_ns: npt.ArrayLike, delta_ns: int) -> I64:
    """``floor(t_ns / Δ)`` for int64 nanosecond times (exact integer floor division)."""
    out: I64 = np.floor_divide(np.asarray(t_ns, dtype=np.int64), np.int64(delta_ns))
    return out


def window_start_ns(window: npt.ArrayLike, delta_ns: int) -> I64:
    """Start time of each window (inclusive) in ns."""
    out: I64 = np.asarray(window, dtype=np.int64) * np.int64(delta_ns)
    return out


def window_centre_ns(window: npt.ArrayLike, delta_ns: int) -> I64:
    """Centre time of each window in ns (the time the temporal model sees it at)."""
    out: I64 = window_start_ns(window, delta_ns) + np.int64(delta_ns // 2)
    return out
