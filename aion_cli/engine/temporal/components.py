"""FreMEn components stored in a map file, so that a query never reads the Fourier sums.

Why: the per-entry Fourier sums (``cnt_fourier``: one complex sum per entry, value bin and
period) are about 80 % of a map's bytes, and a query needs only a few numbers from them: for
each entry whose chosen family is FreMEn, the strongest admitted periods of its spectrum and
their coefficients γ (:class:`~aion_cli.engine.temporal.forecast.Forecaster`). So when a map is
written, those components are computed from the state *as a query sees it* (the pending day and
the open window absorbed, ``MapState.query_temporal``) for the entries that use them, and stored
beside the sums; ``predict`` / ``plan`` / ``export`` then read the map without the sums
(``TemporalState.fourier_loaded`` false) and give the very same forecasts.

Which entries (``Predictor`` evaluates nothing else):

* the *total* components (``period_idx`` / ``coef_total``, every order up to ``max_order``) of
  the entries whose chosen flow family is FreMEn, and of every entry when the map's totals are
  reconciled to a FreMEn forecast of the whole map (``Predictor.scale`` sums it over all);
* the *per-bin* components (``bin_idx`` / ``coef_bins``, the first ``DIRECTION_ORDERS``
  orders) of the entries whose chosen direction family is FreMEn.

Exactness: every component is computed row by row from the row's own accumulators, and the
absorption of a day sums each row's pairs in their order, so absorbing only the chosen rows'
pairs into a copy of those rows gives them bit for bit what the whole query view gives
(tested: predictions from the stored components equal those from the sums).

Members (``prefix`` + name, positions in the map's canonical entry order): ``total_index``
(uint32/int64, increasing), ``period_idx`` (uint8 [n, M]), ``coef_total`` (complex128
[n, M]); ``bins_index``, ``bin_idx`` (uint8 [n, V, D]), ``coef_bins`` (complex128 [n, V, D]).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.temporal.absorption import absorb
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.params import DIRECTION_ORDERS, TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.temporal.stored_layout import stored_index, stored_positions
from aion_cli.engine.types import I64, BoolA
from aion_cli.errors import MapCorruptError

C128 = npt.NDArray[np.complex128]
PREFIX = "forecast_"
_MEMBERS = ("total_index", "period_idx", "coef_total", "bins_index", "bin_idx", "coef_bins")


@dataclass(frozen=True)
class FremenComponents:
    """Stored FreMEn components of some entries (positions in the query's entry order)."""

    total_pos: I64
    period_idx: I64
    coef_total: C128
    bins_pos: I64
    bin_idx: I64
    coef_bins: C128

    @property
    def bins_depth(self) -> int:
        """The per-bin orders stored (``DIRECTION_ORDERS`` capped by ``max_order``)."""
        return int(self.bin_idx.shape[2])

    def to_arrays(self, periods: int) -> dict[str, Any]:
        """The members (indices narrowed losslessly: positions to uint32, periods to uint8)."""
        narrow = np.uint8 if periods <= 256 else np.int64
        limit = int(self.total_pos.max()) + 1 if self.total_pos.size else 0
        limit = max(limit, int(self.bins_pos.max()) + 1 if self.bins_pos.size else 0)
        return {
            PREFIX + "total_index": stored_positions(self.total_pos, limit),
            PREFIX + "period_idx": self.period_idx.astype(narrow),
            PREFIX + "coef_total": self.coef_total,
            PREFIX + "bins_index": stored_positions(self.bins_pos, limit),
            PREFIX + "bin_idx": self.bin_idx.astype(narrow),
            PREFIX + "coef_bins": self.coef_bins,
        }

    @classmethod
    def from_arrays(
        cls, arrays: Mapping[str, np.ndarray], entries: int, params: TemporalParams
    ) -> FremenComponents | None:
        """The stored components (None when the map has none: written before they were,
        or a part map); :class:`MapCorruptError` when they do not fit the map."""
        if PREFIX + "total_index" not in arrays:
            return None
        missing = [n for n in _MEMBERS if PREFIX + n not in arrays]
        if missing:
            raise MapCorruptError(f"forecast components incomplete, missing: {PREFIX}{missing[0]}")
        m, v, k = params.max_order, params.values, params.n_periods
        depth = min(m, DIRECTION_ORDERS)
        total = stored_index(arrays, PREFIX + "total_index", entries)
        bins = stored_index(arrays, PREFIX + "bins_index", entries)
        period_idx = _indices(arrays, PREFIX + "period_idx", (total.size, m), k)
        bin_idx = _indices(arrays, PREFIX + "bin_idx", (bins.size, v, depth), k)
        coef_total = _coefficients(arrays, PREFIX + "coef_total", (total.size, m))
        coef_bins = _coefficients(arrays, PREFIX + "coef_bins", (bins.size, v, depth))
        return cls(total, period_idx, coef_total, bins, bin_idx, coef_bins)


def _indices(arrays: Mapping[str, np.ndarray], name: str, shape: tuple[int, ...], k: int) -> I64:
    value = np.asarray(arrays[name])
    if value.shape != shape or value.dtype.kind not in "iu":
        raise MapCorruptError(f"{name} has shape {value.shape} and dtype {value.dtype}, "
                              f"expected integers of shape {shape}")
    out = value.astype(np.int64)
    if out.size and (out.min() < 0 or out.max() >= k):
        raise MapCorruptError(f"{name} names a period outside 0..{k - 1}")
    return out


def _coefficients(arrays: Mapping[str, np.ndarray], name: str, shape: tuple[int, ...]) -> C128:
    value = np.asarray(arrays[name])
    if value.shape != shape or value.dtype != np.complex128:
        raise MapCorruptError(f"{name} has shape {value.shape} and dtype {value.dtype}, "
                              f"expected complex128 of shape {shape}")
    if value.size and not np.isfinite(value).all():
        raise MapCorruptError(f"{name} holds non-finite values")
    return value


def needed(
    params: TemporalParams, flow_choice: I64, direction_choice: I64, map_family: str | None
) -> tuple[BoolA, BoolA]:
    """Which positions need total and which need per-bin components (module docstring)."""
    fremen_flow = np.array([name.startswith("fremen") for name in params.flow])
    fremen_dir = np.array([name.startswith("fremen") for name in params.direction])
    total = fremen_flow[flow_choice]
    if map_family is not None and map_family.startswith("fremen"):
        total = np.ones(flow_choice.size, dtype=bool)
    return total, fremen_dir[direction_choice]


def compute(
    params: TemporalParams,
    state: TemporalState,
    parts: list[DayWindows],
    rows: I64,
    total: BoolA,
    bins: BoolA,
    window_ns: int,
) -> FremenComponents:
    """The components of the positions ``total`` / ``bins`` of ``rows`` (the query's entries,
    canonical order) from ``state`` with ``parts`` (the pending day and the open window, as
    the query view absorbs them) absorbed: into a copy of the rows the parts touch, while
    every other row is read in place with the global block as absorbed (a fixed sensor's
    windows are the only thing the parts change for them), so writing a map costs a copy of
    the day's entries, never of the whole state."""
    pos = np.flatnonzero(total | bins)
    touched = np.zeros(state.n_rows, dtype=bool)
    for part in parts:
        touched[part.obs_entry] = True
        touched[part.cnt_entry] = True
    moved = touched[rows[pos]]
    groups = (pos[moved], pos[~moved])
    pieces = [
        _components(params, state, parts, rows[g], total[g], bins[g], copy, window_ns)
        for g, copy in zip(groups, (True, False), strict=True)
    ]
    # each piece lists its rows in position order: merged, they list every position in order
    at_total = np.concatenate([g[total[g]] for g in groups])
    at_bins = np.concatenate([g[bins[g]] for g in groups])
    by_total, by_bins = np.argsort(at_total), np.argsort(at_bins)
    return FremenComponents(
        at_total[by_total],
        np.concatenate([p[0] for p in pieces])[by_total],
        np.concatenate([p[1] for p in pieces])[by_total],
        at_bins[by_bins],
        np.concatenate([p[2] for p in pieces])[by_bins],
        np.concatenate([p[3] for p in pieces])[by_bins],
    )


def _components(
    params: TemporalParams,
    state: TemporalState,
    parts: list[DayWindows],
    rows: I64,
    total: BoolA,
    bins: BoolA,
    copy: bool,
    window_ns: int,
) -> tuple[I64, C128, I64, C128]:
    """Components of entry ``rows`` (``total`` / ``bins``: which of them need which) from
    ``state`` with ``parts`` absorbed: into a copy of the rows (``copy``), or, for rows the
    parts do not touch, into the global block alone (the rows read in place)."""
    from aion_cli.engine.temporal.forecast import Forecaster
    from aion_cli.engine.temporal.pooling import PoolStats

    local = np.full(state.n_rows, -1, np.int64)
    if copy:
        local[rows] = np.arange(rows.size)
    # into a copy of the rows, or (no local rows) a state of no rows: only its global block
    # takes the parts' fixed-sensor windows, and the rows are read in place beside it
    target = state.take(rows if copy else np.zeros(0, np.int64))
    for part in parts:
        absorb(params, target, _restricted(part, local), window_ns)
    if copy:
        view, fc_rows = target, np.arange(rows.size, dtype=np.int64)
    else:
        view, fc_rows = dataclasses.replace(state, glob=target.glob), rows
    h, b = params.n_profile, params.bins
    flat = PoolStats(np.ones((1, h)), np.full((1, b), 1.0 / b), np.ones(h))  # unused here
    fc = Forecaster(params, view, fc_rows, np.zeros(rows.size, np.int64), flat)
    at_total, at_bins = np.flatnonzero(total), np.flatnonzero(bins)
    period_idx, coef_total = fc.total_components(at_total)
    depth = min(params.max_order, DIRECTION_ORDERS)
    fc.ensure_bins(at_bins, depth)
    return (
        period_idx,
        coef_total,
        fc.bin_idx[at_bins, :, :depth],
        fc.coef_bins[at_bins, :, :depth],
    )


def _restricted(day: DayWindows, local: I64) -> DayWindows:
    """The pairs of ``day`` whose entries have a local row (``local[entry] >= 0``), re-labelled
    to it, each in its order (so every row's sums are taken as the whole view takes them)."""
    obs = local[day.obs_entry] >= 0
    cnt = local[day.cnt_entry] >= 0
    return DayWindows(
        day.windows,
        day.fixed,
        local[day.obs_entry[obs]],
        day.obs_slot[obs],
        local[day.cnt_entry[cnt]],
        day.cnt_slot[cnt],
        day.cnt_values[cnt],
        day.weights_at(obs),
        day.fixed_share,
    )
