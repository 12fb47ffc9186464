"""A dense grid Map of Dynamics in the style of STeF-map: the baseline aion is compared with.

STeF-map (Molina et al., TAROS 2018) as its public scripts implement it: a dense grid over the
area (1 m cells), B = 8 direction bins, 600 s windows; per window and cell the bin counts are
normalised by the cell's maximum bin (the dominant direction becomes 1), cells with no detection
in an observed window are observed zeros, and FreMEn per cell and bin learns the periodicity.
Memory is allocated for every cell of the bounding box, as a dense grid does; the stored size is
reported by :meth:`GridMoD.stored_bytes`.

It uses aion's own temporal code (``aion_cli.engine.temporal``) restricted to the static and
FreMEn families (orders chosen per cell by the same day-ahead score), so differences between the
two maps come from the spatial representation and from aion's other families, not from a second
FreMEn implementation. Its predictions are the raw per-bin rates (no direction prior). Under a
robot it observes a cell in a window as aion observes an entry there, and counts the window by
the same share (``ModelConfig.exposure``): with whole windows against aion's shares, Table I's
flow rows had compared two observation rules rather than two maps (``docs/EVALUATION.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.descriptors import bin_of
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.temporal import model as temporal
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
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
    """STeF-style dense grid: FreMEn per cell and direction bin (see the module docstring)."""

    def __init__(
        self, spec: GridSpec, config: ModelConfig | None = None, normalise: bool = True
    ) -> None:
        """``normalise``: STeF's per-window max normalisation; False keeps raw counts (a grid
        whose predictions are expected detections, for activity comparisons)."""
        self.spec = spec
        self.normalise = normalise
        self.config = (config or ModelConfig()).replace(families=["static", "fremen"])
        self.bins = self.config.bins
        self.params = TemporalParams.from_config(self.config)
        self.state = temporal.empty_state(self.params, spec.n_cells)
        self.counts = np.zeros((spec.n_cells, self.bins))
        self.windows_observed_per_cell = np.zeros(spec.n_cells)
        self._rows = np.arange(spec.n_cells, dtype=np.int64)
        self._predictor: temporal.Predictor | None = None

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
        centre (a robot's sensor range, as aion uses), for the share of the window aion would
        count (its ``exposure``), and unobserved cells teach nothing.
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
        b = self.bins
        flat = cells[keep][in_span] * b + bin_of(batch.heading[keep][in_span], b)
        pair = w[in_span] * self.spec.n_cells * b + flat
        keys, counts = np.unique(pair, return_counts=True)
        slot, rest = np.divmod(keys, self.spec.n_cells * b)
        cell, bin_ = np.divmod(rest, b)
        np.add.at(self.counts, (cell, bin_), counts)
        # per (window, cell): counts normalised by the cell's largest bin (STeF)
        group, inverse = np.unique(slot * self.spec.n_cells + cell, return_inverse=True)
        values = np.zeros((group.size, self.params.values))
        values[inverse.reshape(-1), bin_] = counts
        if self.normalise:
            values[:, :b] /= values[:, :b].max(axis=1, keepdims=True)
        cnt_slot, cnt_cell = np.divmod(group, self.spec.n_cells)
        share = self._coverage(first, n_windows, window_ns, observation)
        windows = np.arange(first, last + 1, dtype=np.int64)
        weight = None
        if share is None:
            fixed = np.ones(n_windows, bool)
            obs_entry = obs_slot = np.zeros(0, np.int64)
            self.windows_observed_per_cell += n_windows
        else:
            fixed = np.zeros(n_windows, bool)
            # detections: observed whatever the source says, a whole window where it says not
            # (aion's own rule, engine.closing)
            uncovered = share[cnt_slot, cnt_cell] == 0
            share[cnt_slot[uncovered], cnt_cell[uncovered]] = 1.0
            obs_slot, obs_entry = np.nonzero(share)
            weight = share[obs_slot, obs_entry]
            self.windows_observed_per_cell += share.sum(axis=0)
        day = DayWindows(windows, fixed, obs_entry, obs_slot, cnt_cell, cnt_slot, values, weight)
        groups = np.zeros(self.spec.n_cells, np.int64)
        temporal.learn(self.params, self.state, day, self._rows, groups, 1, window_ns)
        self._predictor = None

    def _coverage(
        self, first: int, n_windows: int, window_ns: int, observation: ObservationSource | None
    ) -> F64 | None:
        """Per window and cell, the share of the window the cell's centre was observed in,
        float64[n_windows, n_cells], as aion counts its entries' windows
        (:meth:`ObservationSource.coverage`: the robot's exposure, at least
        ``exposure_floor``, with ``exposure``, else 1 wherever in range; in a fixed sensor's
        window, for every cell the share of it the logs recorded, as aion counts it
        (:meth:`ObservationSource.fixed_share`: a log that starts or ends inside a window
        watched only that part); 0 where unobserved. None: every cell, a fixed sensor."""
        if observation is None:
            return None
        centres = self.spec.centres()
        windows = np.arange(first, first + n_windows, dtype=np.int64)
        fixed = observation.fixed_share(windows, window_ns, self.config)
        return np.stack(
            [
                np.full(self.spec.n_cells, fixed[k])
                if fixed[k] > 0
                else observation.coverage(centres, first + k, window_ns, self.config)
                for k in range(n_windows)
            ]
        )

    def _ready(self) -> temporal.Predictor:
        if self._predictor is None:
            groups = np.zeros(self.spec.n_cells, np.int64)
            self._predictor = temporal.Predictor.of(self.params, self.state, self._rows, groups, 1)
        return self._predictor

    def predict(self, t_ns: int, static: bool = False) -> F64:
        """Predicted max-normalised bin values per cell at ``t_ns``: float64[n_cells, B]: the
        total of the cell's chosen flow family (static or FreMEn) split over the bins as its
        chosen direction family's per-bin rates are (raw rates, no direction prior);
        ``static`` forces the static mean."""
        pred = self._ready()
        fc = pred.forecaster
        n, b = self.spec.n_cells, self.bins
        t = np.full(n, int(t_ns), np.int64)
        h = pred.params.calendar.profile_bin(t)  # the forecast's calendar (calendar_view)
        t_s = self.params.model_seconds(t)
        if static:
            return fc.bin_rates("static", self._rows, h, t_s)[:, :b]
        total = np.zeros(n)
        for f, name in enumerate(self.params.flow):
            pick = np.flatnonzero(pred.flow_choice == f)
            if pick.size:
                total[pick] = fc.bin_rates(name, pick, h[pick], t_s[pick])[:, :b].sum(axis=1)
        split = np.zeros((n, b))
        for d, name in enumerate(self.params.direction):
            pick = np.flatnonzero(pred.direction_choice == d)
            if pick.size:
                split[pick] = fc.bin_rates(name, pick, h[pick], t_s[pick])[:, :b]
        sums = split.sum(axis=1, keepdims=True)
        share = np.divide(split, sums, out=np.zeros_like(split), where=sums > 0)
        out: F64 = total[:, None] * share
        return out

    def historical(self) -> F64:
        """Cumulative counts per cell and bin."""
        return self.counts.copy()

    def stored_bytes(self) -> int:
        """Bytes held for the whole dense grid (temporal accumulators and counts, in memory:
        a dense grid allocates every cell whether anyone walked there or not)."""
        return int(self.state.nbytes + self.counts.nbytes)


def expected_counts_per_window(grid: GridMoD) -> F64:
    """Historical mean detections per observed window per cell (the grid's flow magnitude):
    under a robot's exposure, per window watched, and never more than the cell's detections
    (at least one window, as aion's rates, ``engine.temporal.forecast``)."""
    windows = grid.windows_observed_per_cell
    out = np.zeros(grid.spec.n_cells)
    np.divide(grid.counts.sum(axis=1), np.maximum(windows, 1.0), out=out, where=windows > 0)
    return out
