"""Walking directions against the simulator's truth: aion's and the grid's, historical and
predicted, per place.

Table I compares aion with the STeF-style grid: it says how much the two maps agree, not which
of them is right, and a predicted row that moves away from the grid may move toward the truth
or away from it. The simulator knows every agent's position and heading (seen by the robot or
not), so each map's direction histogram at each place can be set beside the true histogram of
the evaluated day (the last simulated day, every window of it, every agent):

* ``aion historical``: the counts aion learnt (its historical table's per-bin rates);
* ``aion predicted``: the mean over the evaluated times of aion's normalised predicted
  histogram (``predict_table``);
* ``grid historical``: the grid's counts in the cell holding the place;
* ``grid predicted``: the mean over the same times of the grid's normalised predicted bins
  there.

Per map, over the places where the truth and all four maps have a histogram (the same places
for every map): the mean Jensen–Shannon divergence (bits), the mean angle between the
dominant directions (the largest bins' centres, like with like; degrees), the mean absolute
error of the normalised entropy (0 = one direction, 1 = uniform) and its mean signed error (above
0: the map's histograms are flatter than the truth's).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.descriptors import bin_centres
from aion_cli.evaluation import metrics
from aion_cli.number_text import fixed

F64 = npt.NDArray[np.float64]

DIRECTION_MAPS = ("aion historical", "aion predicted", "grid historical", "grid predicted")
DIRECTION_METRICS = ("js", "dominant_deg", "entropy_error", "entropy_bias")


def mean_normalised(histograms: list[F64]) -> F64:
    """The mean of each row's normalised histogram over a list of (places × bins) arrays: every
    time weighs the same, whatever the flow then (a row all zero at a time adds nothing)."""
    if not histograms:
        raise ValueError("no histograms to average")
    total = np.zeros_like(histograms[0], dtype=np.float64)
    for h in histograms:
        total += metrics.normalize(h)
    out: F64 = total / len(histograms)
    return out


def normalised_entropy(histograms: F64) -> F64:
    """Entropy of each row's distribution divided by ln B: 0 for one bin, 1 for uniform."""
    p = metrics.normalize(histograms)
    logs = np.log(np.where(p > 0, p, 1.0))
    out: F64 = -(p * logs).sum(axis=1) / math.log(p.shape[1])
    return out


def direction_truth_scores(truth: F64, maps: dict[str, F64]) -> dict[str, Any]:
    """Each map's histograms (places × B, rows matching ``truth``'s) against the true ones:
    ``{map: {metric: mean}}`` over the places where every map and the truth have counts,
    plus ``places``, their number. NaN metrics when there is no such place."""
    if truth.ndim != 2 or any(m.shape != truth.shape for m in maps.values()):
        raise ValueError("every map needs one histogram row per true histogram, same bins")
    both = truth.sum(axis=1) > 0
    for hist in maps.values():
        both &= hist.sum(axis=1) > 0
    out: dict[str, Any] = {"places": int(both.sum())}
    if not both.any():
        for name in maps:
            out[name] = dict.fromkeys(DIRECTION_METRICS, math.nan)
        return out
    centres = bin_centres(truth.shape[1])
    true = truth[both]
    true_angle = centres[np.argmax(true, axis=1)]
    true_entropy = normalised_entropy(true)
    for name, hist in maps.items():
        h = hist[both]
        out[name] = {
            "js": float(metrics.js_divergence(h, true).mean()),
            "dominant_deg": metrics.mean_angular_displacement_deg(
                centres[np.argmax(h, axis=1)], true_angle
            ),
            "entropy_error": float(np.abs(normalised_entropy(h) - true_entropy).mean()),
            "entropy_bias": float((normalised_entropy(h) - true_entropy).mean()),
        }
    return out


def direction_truth_table(scenes: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Rows of the report's table: per map, the mean and standard deviation over the scenes
    that compared any place of each metric (``scene["directions"]``, from
    :func:`direction_truth_scores`)."""
    compared = [s["directions"] for s in scenes if s.get("directions", {}).get("places", 0) > 0]
    rows = []
    for name in DIRECTION_MAPS:
        row: dict[str, Any] = {"map": name, "scenes": len(compared)}
        for metric in DIRECTION_METRICS:
            values = np.array([c[name][metric] for c in compared if name in c], dtype=float)
            ok = values[np.isfinite(values)]
            row[metric] = (float(ok.mean()), float(ok.std())) if ok.size else None
        rows.append(row)
    return rows


def direction_truth_sentence(rows: list[dict[str, Any]]) -> str:
    """One line for people: the four maps' directions against the truth."""

    def cell(row: dict[str, Any]) -> str:
        js, deg, ent, bias = (row[m] for m in DIRECTION_METRICS)
        if js is None:
            return f"{row['map']} n/a"
        return (f"{row['map']} JS {fixed(js[0], 3)}, dominant {fixed(deg[0], 1)} deg, entropy "
                f"{fixed(ent[0], 3)} ({fixed(bias[0], 3, sign=True)})")

    return "directions against the ground truth of the evaluated day: " + "; ".join(
        cell(r) for r in rows
    )
