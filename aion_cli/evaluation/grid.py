"""A dense grid Map of Dynamics in the style of STeF-map: the baseline aion is compared with.

STeF-map (Molina et al., TAROS 2018) as its public scripts implement it: a dense grid over the
area (1 m cells), B = 8 direction bins, 600 s windows; per window and cell the bin counts are
normalised by the cell's maximum bin (the dominant direction becomes 1), cells with no detection
in an observed window are observed zeros, and one FreMEn state per cell and bin learns the
periodicity. Memory is allocated for every cell of the bounding box, as a dense grid does; the
stored size is reported by :meth:`GridMoD.stored_bytes`.

It uses the same FreMEn code as aion (``aion_cli.engine.fremen``), so differences between the
two maps come from the spatial representation, not the temporal model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.descriptors import bin_of
from aion_cli.engine.fremen import FremenModel, FremenState, to_model_seconds
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.types import DetectionBatch

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]


@dataclass(frozen=True)
class GridSpec:
    """A regular 2-D grid: cell (i, j) covers ``origin + [j, j+1) x [i, i+1) * cell_size``."""

    origin: tuple[float, float]
    cell_size: float
    nx: int
    ny: int

    @classmethod
    def covering(cls, xy: F64, cell_size: float = 1.0, margin: float = 1.0) -> GridSpec:
        """The smallest grid aligned to multiples of ``cell_size`` that covers ``xy``."""
        if len(xy) == 0:
            raise ValueError("cannot size a grid without points")
        lo = np.floor((xy.min(axis=0) - margin) / cell_size) * cell_size
        hi = np.ceil((xy.max(axis=0) + margin) / cell_size) * cell_size
        nx, ny = (np.round((hi - lo) / cell_size).astype(int) + 1).tolist()
        return cls((float(lo[0]), float(lo[1])), cell_size, int(nx), int(ny))

    @property
    def n_cells(self) -> int:
        return self.nx * self.ny

    def cell_of(self, xy: F64) -> I64:
        """Flat cell index of each point, -1 outside the grid."""
        j = np.floor((xy[:, 0] - self.origin[0]) / self.cell_size).astype(np.int64)
        i = np.floor((xy[:, 1] - self.origin[1]) / self.cell_size).astype(np.int64)
        inside = (j >= 0) & (j < self.nx) & (i >= 0) & (i < self.ny)
        return np.where(inside, i * self.nx + j, -1)

    def centres(self) -> F64:
        """Cell centres, float64[n_cells, 2], in flat-index order."""
        i, j = np.divmod(np.arange(self.n_cells), self.nx)
        return np.column_stack(
            [
                self.origin[0] + (j + 0.5) * self.cell_size,
                self.origin[1] + (i + 0.5) * self.cell_size,
            ]
        )


class GridMoD:
    """STeF-style dense grid with one FreMEn state per cell and direction bin."""

    def __init__(self, spec: GridSpec, config: ModelConfig | None = None) -> None:
        self.spec = spec
        self.config = config or ModelConfig()
        self.bins = self.config.bins
        self.model = FremenModel.from_config(self.config)
        self.state: FremenState = self.model.empty(spec.n_cells * self.bins)
        self.counts = np.zeros((spec.n_cells, self.bins))
        self.windows_observed = 0
        self.windows_observed_per_cell = np.zeros(spec.n_cells)

    def fit(
        self,
        batch: DetectionBatch,
        start_ns: int | None = None,
        end_ns: int | None = None,
        observation: ObservationSource | None = None,
    ) -> None:
        """Learn from detections over the windows overlapping [start_ns, end_ns).

        Without ``observation`` every cell is observed in every window (a fixed sensor, as for
        ATC); with it, a cell is observed in a window when the source says so for the cell's
        centre (a robot's sensor range, as aion uses), and unobserved cells teach nothing.
        Detections without heading or outside the grid are ignored.
        """
        keep = np.isfinite(batch.heading) & np.all(np.isfinite(batch.xyz[:, :2]), axis=1)
        cells = self.spec.cell_of(batch.xyz[:, :2])
        keep &= cells >= 0
        if not np.any(keep) and start_ns is None:
            return
        t = batch.t_ns[keep]
        window_ns = round(self.config.window_s * 1e9)
        first = (start_ns if start_ns is not None else int(t.min())) // window_ns
        last = ((end_ns - 1) if end_ns is not None else int(t.max())) // window_ns
        n_windows = int(last - first + 1)
        w = t // window_ns - first
        in_span = (w >= 0) & (w < n_windows)
        flat = (
            cells[keep][in_span] * self.bins + bin_of(batch.heading[keep][in_span], self.bins)
        )
        n_rows = self.spec.n_cells * self.bins
        per_window = np.bincount(
            w[in_span] * n_rows + flat, minlength=n_windows * n_rows
        ).astype(np.float64).reshape(n_windows, n_rows)
        self.counts += per_window.sum(axis=0).reshape(self.spec.n_cells, self.bins)
        self.windows_observed += n_windows
        cube = per_window.reshape(n_windows, self.spec.n_cells, self.bins)
        peak = cube.max(axis=2, keepdims=True)
        normalised = np.divide(cube, peak, out=np.zeros_like(cube), where=peak > 0)
        centres_ns = (np.arange(first, last + 1) * window_ns + window_ns // 2).astype(np.int64)
        t_s = to_model_seconds(centres_ns)
        values = normalised.reshape(n_windows, -1).T
        observed = self._observed(first, n_windows, window_ns, observation)
        self.windows_observed_per_cell += observed.sum(axis=0)
        rows = np.arange(self.spec.n_cells * self.bins, dtype=np.int64)
        mask = np.repeat(observed.T, self.bins, axis=0)
        self.model.update(self.state, rows, t_s, values, mask | (values > 0))

    def _observed(
        self, first: int, n_windows: int, window_ns: int, observation: ObservationSource | None
    ) -> npt.NDArray[np.bool_]:
        """Observed mask float[n_windows, n_cells] (every cell when no source is given)."""
        if observation is None:
            return np.ones((n_windows, self.spec.n_cells), dtype=bool)
        centres = self.spec.centres()
        return np.stack(
            [
                observation.observed(centres, first + k, window_ns, self.config.sensor_range)
                for k in range(n_windows)
            ]
        )

    def predict(self, t_ns: int, order: int | None = None) -> F64:
        """Predicted max-normalised bin values per cell at ``t_ns``: float64[n_cells, B].

        ``order=None`` uses each state's chosen FreMEn order; 0 gives the static mean.
        """
        t_s = to_model_seconds(np.array([t_ns], dtype=np.int64))
        pred = self.model.predict(self.state, t_s, order=order)[:, 0]
        return pred.reshape(self.spec.n_cells, self.bins)

    def historical(self) -> F64:
        """Cumulative counts per cell and bin."""
        return self.counts.copy()

    def stored_bytes(self) -> int:
        """Bytes held for the whole dense grid (FreMEn states and counts)."""
        arrays = self.state.to_arrays("g")
        return int(sum(a.nbytes for a in arrays.values()) + self.counts.nbytes)


def expected_counts_per_window(grid: GridMoD) -> F64:
    """Historical mean detections per observed window per cell (the grid's flow magnitude)."""
    windows = grid.windows_observed_per_cell
    out = np.zeros(grid.spec.n_cells)
    np.divide(grid.counts.sum(axis=1), windows, out=out, where=windows > 0)
    return out

