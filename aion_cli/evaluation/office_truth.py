"""The office comparison against the simulator's ground truth (every agent, seen or not).

Per scene, :func:`_truth_scores` compares aion's forecasts per node with the true counts of
the scene's last day (direction JS divergence, correlation of flow) and with two reference
forecasts made from the truth itself (:func:`reference_forecasts`); across scenes,
:func:`expected_flow_correlations` compares each scene's forecasts with the *expected* flow,
the other scenes' mean count (leave-one-out), and :func:`separable_flow_correlations` tells
how much of what separates them is *where* the flow is and how much *when*. Kept apart from
:mod:`.office`, which runs the scenes and compares aion with the grid (Table I); :mod:`.office`
re-exports these names.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.query import EntryTable, historical_table
from aion_cli.evaluation import metrics
from aion_cli.evaluation.baselines import DAY_HOURS, HOUR_NS
from aion_cli.number_text import fixed

F64 = npt.NDArray[np.float64]


@dataclass(frozen=True)
class FlowSeries:
    """One scene's flow forecasts beside the truth they are scored on: aion's predicted flow
    per window ``predicted[k]`` for environment place ``place[k]`` in the window starting at
    ``window_start[k]``, and the scene's true counts of all agents ``counts[W, m]`` per window
    start ``starts[W]`` and environment place ``place_ids[m]``; ``seen_share[m]``: the share
    of the scene's windows in which the robot's sensor covered each place (None: unknown)."""

    place: npt.NDArray[np.uint64]
    window_start: npt.NDArray[np.int64]
    predicted: F64
    place_ids: npt.NDArray[np.uint64]
    starts: npt.NDArray[np.int64]
    counts: F64
    seen_share: F64 | None = None


TRUTH_FIELDS = (
    "direction_js",
    "flow_correlation",
    "flow_correlation_expected",
    "flow_correlation_previous_day",
    "flow_correlation_oracle",
    "flow_correlation_separable",
    "flow_correlation_true_places",
    "flow_correlation_true_times",
    "flow_correlation_separable_oracle",
    "place_correlation_seen_all_day",
    "place_correlation_seen_in_part",
    "places_seen_all_day",
)
"""The per-scene ground-truth figures (see :func:`_truth_scores` and
:func:`separable_flow_correlations`)."""


def truth_sentence(means: dict[str, float]) -> str:
    """One line for people: aion's forecast against the truth, with the two references."""

    def num(key: str) -> str:
        value = means.get(key, math.nan)
        return "n/a" if not math.isfinite(value) else fixed(value, 3)

    return (
        "against the ground truth (mean over scenes): predicted flow per place and window "
        f"correlates {num('flow_correlation')} with one day's true counts and "
        f"{num('flow_correlation_expected')} with the expected flow (the other scenes' mean); "
        f"references: the previous day's true counts {num('flow_correlation_previous_day')}, "
        f"each place's in-sample hour mean {num('flow_correlation_oracle')}; direction JS "
        f"{num('direction_js')}. Where and when apart (place mean x window mean, against the "
        f"expected flow): aion's own {num('flow_correlation_separable')}, with the true places "
        f"{num('flow_correlation_true_places')}, with the true times "
        f"{num('flow_correlation_true_times')}, both true "
        f"{num('flow_correlation_separable_oracle')}; place means against the expected: "
        f"places seen all day {num('place_correlation_seen_all_day')}, seen in part "
        f"{num('place_correlation_seen_in_part')}"
    )


@dataclass(frozen=True)
class SceneTruth:
    """A scene's ground truth as the simulator wrote it (``<log>.truth.npz``), read once for
    every comparison: the places' ids, the true counts per window, place and direction bin,
    the windows' starts and, where recorded, the share of windows the robot saw each place."""

    place_ids: npt.NDArray[np.int64]
    flow_counts: npt.NDArray[np.int64]
    window_start_ns: npt.NDArray[np.int64]
    seen_share: F64 | None

    @classmethod
    def load(cls, truth_npz: Path) -> SceneTruth:
        with np.load(truth_npz, allow_pickle=False) as z:
            seen = z["observed"].mean(axis=0) if "observed" in z.files else None
            return cls(z["place_ids"], z["flow_counts"], z["window_start_ns"], seen)


def place_rows(place_ids: npt.ArrayLike, node_id: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """(aion row, truth column) of each simulated place that became an aion node, int64[n, 2]
    in the truth's order (``node_id``: the table's node id per row, 0 for cells)."""
    row_of = {int(n): i for i, n in enumerate(np.asarray(node_id).tolist()) if n}
    return np.array(
        [(row_of[int(p)], k) for k, p in enumerate(np.asarray(place_ids).tolist())
         if int(p) in row_of],
        dtype=np.int64,
    ).reshape(-1, 2)


def _truth_scores(
    scene: SceneTruth, state: Any, times_ns: npt.NDArray[np.int64], tables: list[EntryTable]
) -> tuple[dict[str, float], FlowSeries | None]:
    """aion against the simulator's ground truth, per place that became an aion node; and the
    forecasts with the scene's true counts, for :func:`expected_flow_correlations`.
    ``tables``: aion's predictions at ``times_ns`` (``predict_table``, one per time).

    ``direction_js``: mean JS divergence between aion's historical direction histogram and the
    true histogram of all agents (every position, seen or not). ``flow_correlation``: Pearson
    correlation, over (place, time) pairs, between aion's predicted flow per window at the
    given times and the true count of agents in the window containing each time.

    Two references bound what any forecast can reach on counts this sparse (a few agent
    positions per place and window): ``flow_correlation_previous_day``, the true counts of all
    agents (seen or not) one day earlier in the same window, used as the forecast; and
    ``flow_correlation_oracle``, each place's true mean count at that hour of the day over
    every simulated day, the evaluated day included (in-sample: it has seen the answer).
    """
    ids, flow_counts, starts = scene.place_ids, scene.flow_counts, scene.window_start_ns
    seen_share = scene.seen_share
    table = historical_table(state)
    pairs = place_rows(ids, table.node_id)
    if len(pairs) == 0:
        return {"places_compared": 0}, None
    aion_hist = table.rate[pairs[:, 0]]
    true_hist = flow_counts[:, pairs[:, 1], :].sum(axis=0).astype(float)
    both = (aion_hist.sum(axis=1) > 0) & (true_hist.sum(axis=1) > 0)
    js = metrics.js_divergence(aion_hist[both], true_hist[both]) if np.any(both) else None
    all_counts = flow_counts.sum(axis=2).astype(float)  # (W, environment places)
    counts = all_counts[:, pairs[:, 1]]  # (W, compared places)
    predicted, true, previous, oracle, windows = [], [], [], [], []
    for t, pred in zip(times_ns.tolist(), tables, strict=True):
        w = int(np.searchsorted(starts, t, side="right")) - 1
        if w < 0:
            continue
        windows.append(np.full(len(pairs), starts[w], np.int64))
        predicted.append(pred.descriptors.flow_per_window[pairs[:, 0]])
        true.append(counts[w])
        yesterday, hour_mean = reference_forecasts(counts, starts, w)
        previous.append(yesterday)
        oracle.append(hour_mean)
    q = np.concatenate(true)
    scores = {
        "places_compared": len(pairs),
        "direction_js": float(js.mean()) if js is not None else math.nan,
        "flow_correlation": _correlation(np.concatenate(predicted), q),
        "flow_correlation_previous_day": _correlation(np.concatenate(previous), q),
        "flow_correlation_oracle": _correlation(np.concatenate(oracle), q),
    }
    series = FlowSeries(
        place=np.tile(ids[pairs[:, 1]].astype(np.uint64), len(windows)),
        window_start=np.concatenate(windows) if windows else np.zeros(0, np.int64),
        predicted=np.concatenate(predicted),
        place_ids=ids.astype(np.uint64),
        starts=starts.astype(np.int64),
        counts=all_counts,
        seen_share=seen_share,
    )
    return scores, series


def expected_flow_correlations(series: list[FlowSeries]) -> list[float]:
    """Per scene, the correlation of aion's predicted flow with the *expected* true flow.

    A single day's true counts are a few agent positions per place and window, so their
    noise caps what any forecast can correlate with them (see the oracle in
    :func:`_truth_scores`). The scenes share the office, its routine and their calendar and
    differ only in their random draws, so the mean of the *other* scenes' true counts in the
    same window at the same place estimates the expected flow there, independently of the
    scene scored (leave-one-out). NaN where fewer than two scenes are given or a scene's pair
    is missing from every other scene."""
    if len(series) < 2:
        return [math.nan] * len(series)
    out = []
    for k, s in enumerate(series):
        expected = _expected(series, k)
        out.append(_correlation(np.where(np.isfinite(expected), s.predicted, np.nan), expected))
    return out


SEPARABLE_FIELDS = (
    "flow_correlation_separable",
    "flow_correlation_true_places",
    "flow_correlation_true_times",
    "flow_correlation_separable_oracle",
)
"""The *where* and *when* of the expected-flow correlation apart
(:func:`separable_flow_correlations`)."""

COVERAGE_FIELDS = (
    "place_correlation_seen_all_day",
    "place_correlation_seen_in_part",
    "places_seen_all_day",
)
"""Where the flow is, by the robot's coverage of the places (:func:`_by_coverage`)."""

SEEN_ALL_DAY = 0.9
"""Places the robot's sensor covered in at least this share of the windows count as seen all
day (around where it rests), the others as seen in part (where it roams)."""


def separable_flow_correlations(series: list[FlowSeries]) -> list[dict[str, float]]:
    """Per scene, which part of the forecast limits its correlation with the expected flow:
    *where* (each place's mean over the evaluated windows) or *when* (the mean over places
    at each window, the map's daily shape). Each figure correlates a separable forecast
    ``place mean × window mean`` with the expected flow (:func:`expected_flow_correlations`)
    over the same pairs: ``_separable`` takes both from aion's forecast,
    ``_true_places`` the expected flow's places with aion's times, ``_true_times`` aion's
    places with the expected flow's times, ``_separable_oracle`` both from the expected flow
    (what a separable forecast can reach at most; in-sample). A forecast whose true places
    gain more than its true times errs more in where the flow is than in when. With the robot's
    coverage (``seen_share``), where the flow is is also judged apart for the places seen all
    day and those seen in part (:data:`COVERAGE_FIELDS`)."""
    keys = SEPARABLE_FIELDS
    if len(series) < 2:
        return [dict.fromkeys(keys + COVERAGE_FIELDS, math.nan) for _ in series]
    out = []
    for k, s in enumerate(series):
        expected = _expected(series, k)
        known = np.isfinite(expected)
        if known.sum() <= 2:
            out.append(dict.fromkeys(keys + COVERAGE_FIELDS, math.nan))
            continue
        places, place = np.unique(s.place, return_inverse=True)
        _, window = np.unique(s.window_start, return_inverse=True)
        aion_where = _mean_by(place, s.predicted, known)
        aion_when = _mean_by(window, s.predicted, known)
        true_where = _mean_by(place, expected, known)
        true_when = _mean_by(window, expected, known)
        pairs = {
            keys[0]: aion_where[place] * aion_when[window],
            keys[1]: true_where[place] * aion_when[window],
            keys[2]: aion_where[place] * true_when[window],
            keys[3]: true_where[place] * true_when[window],
        }
        scene = {k: _correlation(np.where(known, f, np.nan), expected) for k, f in pairs.items()}
        scene.update(_by_coverage(s, places, aion_where, true_where))
        out.append(scene)
    return out


def _by_coverage(
    s: FlowSeries, places: npt.NDArray[np.uint64], aion_where: F64, true_where: F64
) -> dict[str, float]:
    """Where the flow is, apart for the places the robot saw all day and those it saw in part
    (:data:`SEEN_ALL_DAY`): the correlation of aion's place means (``aion_where``, one per
    place of ``places``, the series' places sorted) with the expected flow's over each group,
    and the number seen all day. NaN without the robot's coverage."""
    if s.seen_share is None:
        return dict.fromkeys(COVERAGE_FIELDS, math.nan)
    order = np.argsort(s.place_ids, kind="stable")
    at = order[np.searchsorted(s.place_ids[order], places)]
    all_day = s.seen_share[at] >= SEEN_ALL_DAY
    return {
        COVERAGE_FIELDS[0]: _correlation(np.where(all_day, aion_where, np.nan), true_where),
        COVERAGE_FIELDS[1]: _correlation(np.where(all_day, np.nan, aion_where), true_where),
        COVERAGE_FIELDS[2]: int(all_day.sum()),
    }


def _expected(series: list[FlowSeries], k: int) -> F64:
    """The expected flow at scene ``k``'s pairs: the other scenes' mean count there (NaN
    where none of them has the pair)."""
    s = series[k]
    others = np.vstack(
        [_counts_at(o, s.window_start, s.place) for j, o in enumerate(series) if j != k]
    )
    n = np.isfinite(others).sum(axis=0)
    out: F64 = np.where(n > 0, np.nansum(others, axis=0) / np.maximum(n, 1), np.nan)
    return out


def _mean_by(group: npt.NDArray[np.intp], values: F64, known: npt.NDArray[np.bool_]) -> F64:
    """The mean of ``values`` over the ``known`` pairs of each group (0 for a group with none)."""
    n = np.bincount(group[known], minlength=int(group.max()) + 1)
    sums = np.bincount(group[known], weights=values[known], minlength=n.size)
    out: F64 = np.divide(sums, n, out=np.zeros(n.size), where=n > 0)
    return out


def _counts_at(
    series: FlowSeries, window_start: npt.NDArray[np.int64], place: npt.NDArray[np.uint64]
) -> F64:
    """``series``' true counts at each (window start, place) pair; NaN where it has none."""
    w = np.searchsorted(series.starts, window_start).clip(0, max(len(series.starts) - 1, 0))
    order = np.argsort(series.place_ids, kind="stable")
    at = np.searchsorted(series.place_ids[order], place).clip(0, max(len(order) - 1, 0))
    m = order[at]
    found = (series.starts[w] == window_start) & (series.place_ids[m] == place)
    return np.where(found, series.counts[w, m], np.nan)


def reference_forecasts(
    counts: npt.NDArray[np.float64], starts: npt.NDArray[np.int64], w: int
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The two reference forecasts of window ``w`` from the true ``counts[W, places]``: the
    counts one day earlier (NaN where the scene had not started) and each place's mean over
    the windows at the same UTC hour of the day (every day, ``w``'s own included)."""
    day, hour = DAY_HOURS * HOUR_NS, HOUR_NS
    before = int(np.searchsorted(starts, starts[w] - day))
    known = int(starts[before]) == int(starts[w]) - day  # before <= w: starts increase
    previous = counts[before] if known else np.full(counts.shape[1], np.nan)
    same_hour = (starts // hour) % DAY_HOURS == (starts[w] // hour) % DAY_HOURS
    return previous, counts[same_hour].mean(axis=0)


def _correlation(p: npt.NDArray[np.float64], q: npt.NDArray[np.float64]) -> float:
    """Pearson correlation over the pairs where ``p`` is known (NaN if undefined)."""
    ok = np.isfinite(p)
    if ok.sum() <= 2 or q[ok].std() == 0 or p[ok].std() == 0:
        return math.nan
    return float(np.corrcoef(p[ok], q[ok])[0, 1])
