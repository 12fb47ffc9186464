"""The paper's Table I and the comparison of two maps on the common grid (steps 4 and 5 of
:mod:`.office`): aion's entries discretised onto the grid (:func:`discretise`), the grid's own
descriptors (:func:`grid_view`), and the Jensen–Shannon, Bhattacharyya, Wasserstein and
circular-correlation figures of the cells where both have flow (:func:`compare_views`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree
from scipy.stats import wasserstein_distance

from aion_cli.engine import descriptors
from aion_cli.engine.query import EntryTable
from aion_cli.evaluation import metrics
from aion_cli.evaluation.grid import GridMoD, expected_counts_per_window

F64 = npt.NDArray[np.float64]
BoolA = npt.NDArray[np.bool_]

# The paper's Table I (mean, std); None where the paper prints "--".
PAPER_TABLE: dict[tuple[str, str], dict[str, tuple[float, float] | None]] = {
    ("Entropy", "Historical"): {
        "js": (0.49, 0.13),
        "bhattacharyya": (1.3, 0.68),
        "wasserstein": (0.12, 0.05),
        "circular_correlation": None,
    },
    ("Entropy", "Predicted"): {
        "js": (0.35, 0.32),
        "bhattacharyya": (3.83, 4.69),
        "wasserstein": (0.18, 0.14),
        "circular_correlation": None,
    },
    ("Flow", "Historical"): {
        "js": (0.53, 0.11),
        "bhattacharyya": (2.02, 2.06),
        "wasserstein": (40.17, 21.82),
        "circular_correlation": None,
    },
    ("Flow", "Predicted"): {
        "js": (0.68, 0.02),
        "bhattacharyya": (6.42, 3.76),
        "wasserstein": (76.16, 16.93),
        "circular_correlation": None,
    },
    ("Direction", "Historical"): {
        "js": None,
        "bhattacharyya": None,
        "wasserstein": (15.0, 11.23),
        "circular_correlation": (0.12, 0.07),
    },
    ("Direction", "Predicted"): {
        "js": None,
        "bhattacharyya": None,
        "wasserstein": (103.03, 14.15),
        "circular_correlation": (0.1, 0.05),
    },
}
METRICS = ("js", "bhattacharyya", "wasserstein", "circular_correlation")


@dataclass(frozen=True)
class MapView:
    """One representation discretised on the common grid: per grid cell entropy, flow per
    window, dominant angle (NaN where the map has no flow there)."""

    entropy: F64
    flow: F64
    angle: F64

    @property
    def has_flow(self) -> BoolA:
        return np.isfinite(self.flow) & (self.flow > 0)


def compare_scalar(a: F64, g: F64) -> dict[str, float]:
    """JS and Bhattacharyya between spatial distributions; W1 between max-normalised values."""
    if len(a) == 0 or a.sum() <= 0 or g.sum() <= 0:
        return {"js": math.nan, "bhattacharyya": math.nan, "wasserstein": math.nan}
    return {
        "js": float(metrics.js_divergence(a, g)),
        "bhattacharyya": float(metrics.bhattacharyya_distance(a, g)),
        "wasserstein": float(wasserstein_distance(a / a.max(), g / g.max())),
    }


def compare_views(aion: MapView, grid: MapView) -> dict[str, dict[str, float]]:
    """The three rows (entropy, flow, direction) for one data type."""
    common = aion.has_flow & grid.has_flow
    ent = common & np.isfinite(aion.entropy) & np.isfinite(grid.entropy)
    direction = {
        "wasserstein": metrics.mean_angular_displacement_deg(
            aion.angle[common], grid.angle[common]
        ),
        "circular_correlation": metrics.circular_correlation(
            aion.angle[common], grid.angle[common]
        ),
        "cells": int(common.sum()),
    }
    return {
        "Entropy": compare_scalar(aion.entropy[ent], grid.entropy[ent]),
        "Flow": compare_scalar(aion.flow[common], grid.flow[common]),
        "Direction": direction,
    }


def discretise(table: EntryTable, centres: F64, radius: float) -> MapView:
    """Each grid cell takes the descriptors of the nearest aion entry within ``radius``."""
    n = len(centres)
    entropy, flow, angle = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    if len(table) == 0:
        return MapView(entropy, flow, angle)
    dist, idx = cKDTree(table.xyz[:, :2]).query(centres, distance_upper_bound=radius)
    hit = np.isfinite(dist)
    # like with like: the grid knows its bins only by their centres, so aion's directions are
    # compared as its bins' centres place them too (not at its headings' own mean directions)
    d = replace(table, heading_cos=None, heading_sin=None, placed=None).descriptors
    entropy[hit] = d.entropy[idx[hit]]
    flow[hit] = d.flow_per_window[idx[hit]]
    angle[hit] = d.dominant_angle[idx[hit]]
    return MapView(entropy, flow, angle)


def grid_view(grid: GridMoD, t_ns: int | None) -> MapView:
    """The grid's own descriptors: historical from counts, predicted from its FreMEn states
    (max-normalised bin values; their sum is the grid's relative flow magnitude)."""
    if t_ns is None:
        d = descriptors.historical(
            grid.counts,
            np.zeros_like(grid.counts),
            np.zeros_like(grid.counts),
            np.maximum(grid.windows_observed_per_cell, 1),
            grid.config.window_s,
        )
        flow = expected_counts_per_window(grid)
    else:
        pred = grid.predict(t_ns)
        flow = pred.sum(axis=1)
        ones = np.ones(len(pred))
        d = descriptors.historical(pred, np.zeros_like(pred), np.zeros_like(pred), ones, 1.0)
    trained = grid.counts.sum(axis=1) > 0
    flow = np.where(trained, flow, np.nan)
    return MapView(d.entropy, flow, d.dominant_angle)
