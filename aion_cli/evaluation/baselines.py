"""Simple heading models that aion is compared against, beside the STeF-style grid.

- :class:`TimeOfDayHistogram`: per 1 m cell, a direction histogram for each hour of the day
  (``chronorobotics/models`` ``CTimeHist`` style); an hour with no training data falls back to
  the cell's all-day histogram.
- :class:`StaticHistogram`: per cell, one all-time histogram (a map without time).

Both answer :meth:`probabilities` like every model in :mod:`aion_cli.evaluation.heading`:
per query detection a B-bin histogram (not normalised) and whether the model had data there.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.descriptors import bin_of
from aion_cli.engine.types import DetectionBatch
from aion_cli.evaluation.grid import GridSpec

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
BoolA = npt.NDArray[np.bool_]

HOUR_NS = 3_600_000_000_000
DAY_HOURS = 24


class StaticHistogram:
    """One direction histogram per grid cell over all training time."""

    name = "static histogram"

    def __init__(self, spec: GridSpec, bins: int = 8) -> None:
        self.spec = spec
        self.bins = bins
        self.counts = np.zeros((spec.n_cells, bins))

    def fit(self, batch: DetectionBatch) -> None:
        cells, b = _cells_and_bins(self.spec, batch, self.bins)
        np.add.at(self.counts, (cells, b), 1.0)

    def probabilities(self, xyz: F64, t_ns: I64) -> tuple[F64, BoolA]:
        cells = self.spec.cell_of(xyz[:, :2])
        hist = np.where(cells[:, None] >= 0, self.counts[np.maximum(cells, 0)], 0.0)
        return hist, hist.sum(axis=1) > 0


class TimeOfDayHistogram:
    """Direction histograms per grid cell and hour of the day (local time via ``utc_offset_h``)."""

    name = "time-of-day histogram"

    def __init__(self, spec: GridSpec, bins: int = 8, utc_offset_h: float = 0.0) -> None:
        self.spec = spec
        self.bins = bins
        self.offset_ns = round(utc_offset_h * HOUR_NS)
        self.counts = np.zeros((DAY_HOURS, spec.n_cells, bins))

    def _hour(self, t_ns: I64) -> I64:
        return ((t_ns + self.offset_ns) // HOUR_NS) % DAY_HOURS

    def fit(self, batch: DetectionBatch) -> None:
        cells, b = _cells_and_bins(self.spec, batch, self.bins)
        keep = _usable(self.spec, batch)
        hours = self._hour(batch.t_ns[keep])
        np.add.at(self.counts, (hours, cells, b), 1.0)

    def probabilities(self, xyz: F64, t_ns: I64) -> tuple[F64, BoolA]:
        cells = self.spec.cell_of(xyz[:, :2])
        safe = np.maximum(cells, 0)
        by_hour = self.counts[self._hour(t_ns), safe]
        all_day = self.counts.sum(axis=0)[safe]
        have_hour = by_hour.sum(axis=1, keepdims=True) > 0
        hist = np.where(have_hour, by_hour, all_day)
        hist = np.where(cells[:, None] >= 0, hist, 0.0)
        return hist, hist.sum(axis=1) > 0


def _usable(spec: GridSpec, batch: DetectionBatch) -> BoolA:
    return np.isfinite(batch.heading) & (spec.cell_of(batch.xyz[:, :2]) >= 0)


def _cells_and_bins(spec: GridSpec, batch: DetectionBatch, bins: int) -> tuple[I64, I64]:
    keep = _usable(spec, batch)
    return spec.cell_of(batch.xyz[keep, :2]), bin_of(batch.heading[keep], bins)
