"""Predictive accuracy of heading models on held-out detections.

Every model answers ``probabilities(xyz, t_ns) -> (hist[n, B], matched[n])``: for each query
detection a B-bin direction histogram (any non-negative scale) and whether the model had data
near it. Scores, all documented in ``docs/EVALUATION.md``:

- **heading NLL**: ``-(log P(bin) + log(B / 2π))`` per matched detection (every model's
  histogram normalised, floored at :data:`FLOOR` and renormalised;
  :func:`aion_cli.evaluation.metrics.heading_nll`), reported as the
  mean over matched detections, together with the unmatched count and the mean over *all*
  detections where an unmatched one scores the uniform density ``log(2π)`` — the fair number
  when models cover different areas.
- **chi-square**: per (1 m cell, 10 min window) with test detections, the chi-square distance
  between the model's normalised histogram and the observed normalised histogram, averaged.
"""

from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from aion_cli.engine.descriptors import bin_of
from aion_cli.engine.state import MapState
from aion_cli.engine.types import DetectionBatch
from aion_cli.evaluation.grid import GridMoD, GridSpec
from aion_cli.evaluation.metrics import chi_square_distance, heading_nll, normalize

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
BoolA = npt.NDArray[np.bool_]

UNIFORM_NLL = math.log(2 * math.pi)
FLOOR = 0.01


def association_radius(radius: object) -> float:
    """The association radius (metres, a finite number above 0) every heading score matches
    test detections to the model's entries within; :class:`InputError` otherwise (a
    negative one would match nothing, or everything, silently)."""
    from aion_cli.errors import InputError

    if isinstance(radius, bool) or not isinstance(radius, int | float):
        raise InputError(
            f"the association radius must be a number of metres, got {radius!r}",
            hint="e.g. 1.0 (the default): a test detection is matched within it",
        )
    if not (math.isfinite(radius) and radius > 0):
        raise InputError(
            f"the association radius must be a positive number of metres, got {radius!r}",
            hint="e.g. 1.0 (the default): a test detection is matched within it",
        )
    return float(radius)
"""Every model's histogram is floored at this probability and renormalised before scoring, so
sparse count histograms are not punished with near-zero probabilities."""


class HeadingModel(Protocol):
    name: str

    def probabilities(self, xyz: F64, t_ns: I64) -> tuple[F64, BoolA]: ...


@dataclass(frozen=True)
class HeadingScore:
    model: str
    detections: int
    matched: int
    unmatched: int
    nll_matched: float
    nll_all: float
    chi_square: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


class AionHeadingModel:
    """aion's map as a heading model: the nearest live entry within ``radius`` answers.

    ``static=False`` uses each entry's chosen direction family at the detection's time,
    ``static=True`` its static histogram (pooled toward its parents) — "aion static" —
    and ``historical=True`` the raw proportions ``aion predict --historical`` shows."""

    def __init__(
        self,
        state: MapState,
        radius: float,
        static: bool = False,
        name: str = "aion",
        historical: bool = False,
    ) -> None:
        self.state = state
        self.radius = radius
        self.static = static
        self.historical = historical
        self.name = name
        self.rows, self.predictor = state.predictor()
        xy = state.entries.xyz[self.rows, :2]
        self.tree = cKDTree(xy) if len(self.rows) else None

    def variant(
        self, name: str, static: bool = False, historical: bool = False
    ) -> AionHeadingModel:
        """The same map read another way (its static or raw histograms), sharing this
        model's predictor and KD-tree instead of building them again."""
        out = copy.copy(self)
        out.name, out.static, out.historical = name, static, historical
        return out

    @classmethod
    def readings(cls, state: MapState, radius: float) -> list[AionHeadingModel]:
        """aion's forecast ("aion"), its static histograms ("aion static") and the raw
        proportions ``predict --historical`` shows ("aion historical"), on one tree."""
        model = cls(state, radius)
        return [
            model,
            model.variant("aion static", static=True),
            model.variant("aion historical", historical=True),
        ]

    def probabilities(self, xyz: F64, t_ns: I64) -> tuple[F64, BoolA]:
        bins = self.state.bins
        hist = np.zeros((len(xyz), bins))
        if self.tree is None or len(xyz) == 0:
            return hist, np.zeros(len(xyz), dtype=bool)
        dist, idx = self.tree.query(xyz[:, :2], distance_upper_bound=self.radius)
        matched = np.isfinite(dist)
        if not np.any(matched):
            return hist, matched
        entry = idx[matched].astype(np.int64)
        if self.historical:
            hist[matched] = self.predictor.forecaster.raw_histogram[entry]
            return hist, matched & (hist.sum(axis=1) > 0)
        if self.static:
            hist[matched] = self.predictor.forecaster.histogram[entry]
            return hist, matched
        window_ns = self.state.window_ns
        centres = t_ns[matched] // window_ns * window_ns + window_ns // 2
        _flow, probs = self.predictor.pairs(entry, centres)
        hist[matched] = probs
        return hist, matched


class GridHeadingModel:
    """The STeF-style grid as a heading model (cell of the detection, FreMEn prediction)."""

    def __init__(self, grid: GridMoD, static: bool = False, name: str = "grid") -> None:
        self.grid = grid
        self.static = static
        self.name = name

    def probabilities(self, xyz: F64, t_ns: I64) -> tuple[F64, BoolA]:
        cells = self.grid.spec.cell_of(xyz[:, :2])
        hist = np.zeros((len(xyz), self.grid.bins))
        inside = cells >= 0
        window_ns = round(self.grid.config.window_s * 1e9)
        windows, inverse = np.unique(t_ns[inside] // window_ns, return_inverse=True)
        inside_idx = np.flatnonzero(inside)
        for k, w in enumerate(windows):
            pred = self.grid.predict(int(w * window_ns + window_ns // 2), static=self.static)
            pick = inside_idx[inverse == k]
            hist[pick] = pred[cells[pick]]
        trained = self.grid.counts.sum(axis=1) > 0
        matched = inside & trained[np.maximum(cells, 0)] & (hist.sum(axis=1) > 0)
        return hist, matched


def score_headings(
    model: HeadingModel,
    test: DetectionBatch,
    bins: int,
    chi_grid: float = 1.0,
    window_s: float = 600.0,
    floor: float = FLOOR,
) -> HeadingScore:
    """Heading NLL and chi-square of ``model`` on the test detections that have a heading.

    Every model's histogram is normalised, floored at ``floor`` and renormalised before
    scoring, so sparse count histograms are not punished with near-zero probabilities.
    """
    keep = np.isfinite(test.heading) & np.all(np.isfinite(test.xyz), axis=1)
    batch = test.select(keep)
    n = len(batch)
    if n == 0:
        return HeadingScore(model.name, 0, 0, 0, math.nan, math.nan, math.nan)
    hist, matched = model.probabilities(batch.xyz, batch.t_ns)
    hist = np.maximum(normalize(hist), floor)
    observed_bins = bin_of(batch.heading, bins)
    nll = np.full(n, UNIFORM_NLL)
    if np.any(matched):
        nll[matched] = heading_nll(hist[matched], observed_bins[matched])
    matched_count = int(matched.sum())
    return HeadingScore(
        model=model.name,
        detections=n,
        matched=matched_count,
        unmatched=n - matched_count,
        nll_matched=float(nll[matched].mean()) if matched_count else math.nan,
        nll_all=float(nll.mean()),
        chi_square=_chi_square(batch, hist, matched, observed_bins, bins, chi_grid, window_s),
    )


def _chi_square(
    batch: DetectionBatch,
    hist: F64,
    matched: BoolA,
    observed_bins: I64,
    bins: int,
    cell_size: float,
    window_s: float,
) -> float:
    """Mean chi-square distance over (cell, window) groups of matched test detections."""
    if not np.any(matched):
        return math.nan
    spec = GridSpec.covering(batch.xyz[matched, :2], cell_size)
    cells = spec.cell_of(batch.xyz[matched, :2])
    windows = batch.t_ns[matched] // round(window_s * 1e9)
    group_keys = np.column_stack([cells, windows])
    _, group = np.unique(group_keys, axis=0, return_inverse=True)
    group = group.reshape(-1)
    n_groups = int(group.max()) + 1
    observed = np.zeros((n_groups, bins))
    np.add.at(observed, (group, observed_bins[matched]), 1.0)
    predicted = np.zeros((n_groups, bins))
    np.add.at(predicted, group, normalize(hist[matched]))
    return float(chi_square_distance(normalize(observed), normalize(predicted)).mean())
