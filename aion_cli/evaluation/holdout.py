"""A map's forecast judged on your own held-out logs: ``aion evaluate holdout MAP LOG...``.

The public protocols (Lincoln, ATC, the office) judge aion on data someone else recorded. A
user's question is whether *their* map forecasts *their* site: build the map from some logs,
keep later ones back, and score the map's forecast on them. The test logs are read exactly as
``aion build`` would read them into the map (:func:`aion_cli.held_out.read_held_out`: map
frame, headings, time rules, observed windows), so the comparison is like with like. Scores,
per model:

- **heading NLL** of every test detection with a heading (association radius ``radius``
  metres to the nearest entry; unmatched detections count as uniform; the floor of
  ``evaluation.heading``): ``aion`` (each entry's chosen direction family at the detection's
  time), ``aion static`` (its static histogram, pooled toward its parents), ``aion
  historical`` (the raw proportions ``predict --historical`` shows) and ``uniform``
  (``log 2π``, knowing nothing);
- **hourly activity** over the windows the test logs observed: the detections per hour
  against the map's forecast at each window's centre, summed over the places observed then —
  every place in a window a fixed sensor covered (a log without a robot trajectory counts as
  one in the windows it recorded anything; ``--observed`` declares more), the places within
  ``sensor_range`` of the robot's poses in a window only a robot observed (the build's own
  rule, applied to the map's places) — Spearman, Poisson deviance and MAE
  (``metrics.activity_scores``), for ``aion``, ``aion static`` (the places' rates per observed
  window) and ``hour-of-day profile`` (each place's own detections per observed window in each
  profile bin, hour of the day by kind of day, unshrunk: the baseline a temporal model has to
  beat).

A test log that overlaps the map's own data in time is scored all the same, with a warning:
the map has seen those detections (the scores are in-sample); so is one before the map's
data, with a warning that the map learnt from later logs. One none of whose detections lies
within ``radius`` of a map entry (another place, or another frame) is scored with a warning,
as is one more than half of whose detections lie so apart (:data:`MOSTLY_APART`: the share is
named), one whose windows hold no map place observed (every activity forecast is 0), and one
that declares another time zone than the map's (``aion simulate --tz``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.evaluation.heading import (
    UNIFORM_NLL,
    AionHeadingModel,
    association_radius,
    score_headings,
)
from aion_cli.evaluation.holdout_notes import (
    held_out_notes,
    time_warnings,
    unobserved_hours_note,
)
from aion_cli.evaluation.metrics import hourly_activity
from aion_cli.evaluation.spread import spread_of

if TYPE_CHECKING:
    from aion_cli.build_options import BuildOptions
    from aion_cli.engine.state import MapState
    from aion_cli.held_out import HeldOut
    from aion_cli.mapquery import LoadedMap

_PAIRS = 1 << 20
"""(entry, window) pairs whose flow is evaluated together."""


@dataclass
class HoldoutResult:
    """Scores per model (headings, activity), the hourly series, and what was tested."""

    headings: list[dict[str, Any]] = field(default_factory=list)
    activity: list[dict[str, Any]] = field(default_factory=list)
    hours: list[str] = field(default_factory=list)
    series: dict[str, list[float]] = field(default_factory=dict)
    test: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    #: what reading the test logs warned of, as ``aion build`` would (a truncated log ...)
    warnings: list[str] = field(default_factory=list)
    #: the coverage of the held-out counts by aion's 10th-90th percentile band, per (place,
    #: window) and per hour (``evaluation.spread.spread_of``); empty without activity
    spread: dict[str, dict[str, Any]] = field(default_factory=dict)

    def __repr__(self) -> str:
        """The scores in one line (not the hourly series, which a notebook would print
        whole: a value per model and hour)."""
        detections = int(self.test.get("detections", 0))
        def scores(rows: list[dict[str, Any]], key: str) -> str:
            return ", ".join(
                f"{r.get('model')} "
                + (f"{r[key]:.3g}" if isinstance(r.get(key), int | float) else "n/a")
                for r in rows
            ) or "none"

        nll, rho = scores(self.headings, "nll_all"), scores(self.activity, "spearman")
        return (
            f"<aion.HoldoutResult: {detections:,} test detections, {len(self.hours):,} hours; "
            f"heading NLL {nll}; hourly Spearman {rho}>"
        )

    def to_dict(self) -> dict[str, Any]:
        """``aion evaluate holdout --format json``: JSON-safe (a score that cannot be
        computed, NaN here, is None there)."""
        from aion_cli.formats.serialize import clean

        out: dict[str, Any] = clean({
            "test": self.test,
            "headings": self.headings,
            "activity": self.activity,
            "hours": self.hours,
            "hourly_series": self.series,
            "spread_coverage": self.spread,
            "notes": self.notes,
            "warnings": self.warnings,
        })
        return out


def run_holdout(
    map_path: Path,
    opts: BuildOptions,
    radius: float = 1.0,
    progress: Callable[[str], None] | None = None,
) -> HoldoutResult:
    """Score the map at ``map_path`` on the logs of ``opts`` (read with the map's model
    config; see the module docstring). :class:`~aion_cli.errors.InputError` when the map or
    the logs cannot be read, or the logs hold no detection the map could take."""
    from aion_cli.mapquery import load_map

    return score_held_out(load_map(map_path), opts, radius, progress)


def score_held_out(
    loaded: LoadedMap,
    opts: BuildOptions,
    radius: float = 1.0,
    progress: Callable[[str], None] | None = None,
) -> HoldoutResult:
    """:func:`run_holdout` for a map already loaded (or built in memory)."""
    from aion_cli.held_out import read_held_out
    from aion_cli.log_zone import held_out_zone_warnings

    radius = association_radius(radius)
    say = progress or (lambda _msg: None)
    state = loaded.state
    watch = state.entries.xyz[state.entries.canonical_order(), :2]  # the predictor's order
    held = read_held_out(opts, state.config, watch=watch)
    result = HoldoutResult()
    result.test = _test_summary(held, state)
    result.notes = held_out_notes(held, loaded.manifest, state.config.sensor_range)
    result.warnings = list(held.report.warnings) + time_warnings(held, loaded.manifest)
    result.warnings += held_out_zone_warnings(state.config.timezone, opts.logs)
    recorded = loaded.manifest.get("map_frame")
    if isinstance(recorded, str) and recorded != opts.map_frame:  # --map-frame said so
        result.notes.insert(0, (
            f"the map holds positions in frame {recorded!r} and --map-frame read the test "
            f"logs into {opts.map_frame!r}: they are scored as if both were one frame "
            f"(unless they are, give the logs the TF to {recorded!r})"
        ))
    say("scoring headings")
    for model in AionHeadingModel.readings(state, radius):
        result.headings.append(
            score_headings(model, held.batch, state.bins, window_s=state.config.window_s)
            .to_dict()
        )
    result.headings.append(_uniform(held))
    apart = _no_overlap(result.headings[0], radius)
    if apart is not None:
        result.warnings.append(apart)
    say("forecasting the test logs' hourly activity")
    hours = _activity(result, state, held)
    unobserved = unobserved_hours_note(loaded.manifest, hours)
    if unobserved is not None:
        result.notes.append(unobserved)
    return result


def _test_summary(held: HeldOut, state: MapState) -> dict[str, Any]:
    """What the test logs held for the map (counts, windows, span, observation)."""
    batch = held.batch
    directed = int(np.count_nonzero(np.isfinite(batch.heading)))
    span = (int(batch.t_ns.min()), int(batch.t_ns.max())) if len(batch) else None
    return {
        "detections": len(batch),
        "with_heading": directed,
        "windows": int(held.windows.size),
        "fixed_sensor_windows": int(np.count_nonzero(held.fixed)),
        "robot_windows": int(np.count_nonzero(~held.fixed)),
        "window_s": state.config.window_s,
        "timezone": state.config.timezone,
        "start_ns": span[0] if span else None,
        "end_ns": span[1] if span else None,
        "observation": held.report.observation,
        "detection_topics": list(held.report.detection_topics),
    }


MOSTLY_APART = 0.5
"""The share of test detections farther than ``radius`` from every map entry above which the
test logs are warned of as (mostly) of another place or frame: more than half. A log of the
map's own site leaves few apart (ATC's held-out rows: 37 of 69,981, 8 of 198,812); a log of
another site scored against the office map, 62-83 % (THÖR, ETH)."""


def _no_overlap(aion: dict[str, Any], radius: float) -> str | None:
    """A warning when no test detection with a heading lies within ``radius`` of a map entry
    (``aion``: the aion model's heading row): the logs are of another place or frame, and
    every score is that of knowing nothing; or when more than :data:`MOSTLY_APART` of them
    lie apart, the share named: most of the logs are, and most scores are a uniform's."""
    from aion_cli.fixed_sensor_text import share_text

    n = int(aion.get("detections") or 0)
    matched = int(aion.get("matched") or 0)
    if n == 0 or (matched > 0 and (n - matched) / n <= MOSTLY_APART):
        return None
    if matched > 0:
        return (
            f"{share_text((n - matched) / n)} of the {n:,} test detections ({n - matched:,}) "
            f"lie farther than {radius:g} m (--radius) from every map entry: are the test "
            "logs (mostly) of another place or frame than the map? Each of those scores as a "
            "uniform heading"
        )
    return (
        f"none of the {n:,} test detections lies within {radius:g} m (--radius) of a map "
        "entry: the test logs are of another place or frame than the map, and every heading "
        "score of aion's is a uniform heading's"
    )


def _uniform(held: HeldOut) -> dict[str, Any]:
    """The reference that knows nothing: every heading equally likely."""
    n = int(np.count_nonzero(np.isfinite(held.batch.heading)))
    nll = UNIFORM_NLL if n else math.nan
    return {"model": "uniform", "detections": n, "matched": n, "unmatched": 0,
            "nll_matched": nll, "nll_all": nll, "chi_square": math.nan}


def _activity(result: HoldoutResult, state: MapState, held: HeldOut) -> list[int]:
    """Detections per hour over the observed windows against each model's forecast, summed
    over every place in a fixed sensor's windows and over the places within the robot's
    range in a robot's (``HeldOut.seen``); the hours' starts (UNIX ns; none without a
    window observed)."""
    known = held.fixed | np.isin(held.windows, np.fromiter(held.seen, np.int64, len(held.seen)))
    windows, fixed = held.windows[known], held.fixed[known]
    recorded = None if held.fixed_share is None else held.fixed_share[known]
    if windows.size == 0:
        result.notes.append(
            "no test window was observed by a fixed sensor or a robot whose range the map "
            "could follow: the hourly activity needs one (see aion build --observed)"
        )
        return []
    w_ns = state.window_ns
    detected = held.batch.t_ns // w_ns
    at = np.searchsorted(windows, detected)
    hit = (at < windows.size) & (windows[np.minimum(at, windows.size - 1)] == detected)
    truth_w = np.bincount(at[hit], minlength=windows.size).astype(np.float64)
    centres = windows * w_ns + w_ns // 2
    bins = state.params.calendar.profile_bin(centres)
    rows, predictor = state.predictor()
    n = len(rows)
    static = np.nan_to_num(predictor.historical().flow)  # per place, canonical order
    profile = _profile_rates(state, rows, static)  # (places, profile bins)
    # (place, window) pairs: every place in a fixed sensor's window, the robot's in its own,
    # each expected to show its rate for the share of the window it was in range
    place, window, share = _pairs(fixed, windows, held.seen, held.seen_exposure, n, recorded)
    unseen = _no_place_observed(place, fixed, int(truth_w.sum()), state.config.sensor_range)
    if unseen is not None:
        result.warnings.append(unseen)
    aion, expected, variance = _summed(place, window, share, windows.size, predictor, centres)
    per_window = {
        "aion": aion,
        "aion static": np.bincount(window, static[place] * share, minlength=windows.size),
        "hour-of-day profile": np.bincount(
            window, profile[place, bins[window]] * share, minlength=windows.size
        ),
    }
    starts = windows * w_ns
    observed = np.bincount(window, share, minlength=windows.size)  # place-windows per window
    hours, result.series, result.activity = hourly_activity(
        starts, truth_w, per_window, state.params.calendar.local_ns(starts), observed
    )
    result.hours = [_hour_label(int(h), state.config.timezone) for h in hours.tolist()]
    detection_window = np.where(hit, at, -1)
    result.spread = spread_of(
        state, rows, held.batch.xyz, detection_window, (place, window, windows.size),
        (expected, variance), (starts, state.params.calendar.local_ns(starts)),
    )
    return [int(h) for h in hours.tolist()]


def _no_place_observed(
    place: np.ndarray, fixed: np.ndarray, detections: int, sensor_range: float
) -> str | None:
    """A warning when no (place, window) pair was observed (``place`` empty): every model
    then forecasts 0 in every window and the activity rows are one and the same."""
    if place.size:
        return None
    where = (
        f"lay within the robot's sensor range ({sensor_range:g} m) in any of the "
        f"{fixed.size:,} test windows it observed"
        if not fixed.any()
        else f"was observed in any of the {fixed.size:,} test windows"
    )
    return (
        f"no place of the map {where}: every model forecasts 0 detections per hour, so "
        f"the hourly activity rows are alike (the {detections:,} test detections in those "
        "windows against nothing) and rank nothing; the test logs are of another place or "
        "frame than the map"
    )


def _pairs(
    fixed: np.ndarray,
    windows: np.ndarray,
    seen: dict[int, np.ndarray],
    exposure: dict[int, np.ndarray],
    n: int,
    recorded: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(place, window position, share of the window observed) of the observation: all ``n``
    places in a fixed window, each for the share of it the logs recorded (``recorded``, per
    window; whole where None), the places ``seen`` lists in a robot's, each for its
    ``exposure`` (whole where none is given)."""
    places, positions, shares = [], [], []
    everyone = np.arange(n, dtype=np.int64)
    for k, (w, is_fixed) in enumerate(zip(windows.tolist(), fixed.tolist(), strict=True)):
        part = everyone if is_fixed else seen[w]
        places.append(part)
        positions.append(np.full(part.size, k, np.int64))
        if is_fixed:
            shares.append(np.full(part.size, 1.0 if recorded is None else float(recorded[k])))
        else:
            shares.append(np.ones(part.size) if w not in exposure else exposure[w])
    if not places:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(places), np.concatenate(positions), np.concatenate(shares)


def _summed(
    place: np.ndarray,
    window: np.ndarray,
    share: np.ndarray,
    n_windows: int,
    predictor: Any,
    centres: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The map's forecast (``Predictor.flows``; places never observed add nothing) times
    each pair's ``share`` of its window, summed per window over the pairs, a block of pairs
    at a time; and per pair that forecast and its count's variance
    (``Predictor.variances``; NaN for a place never observed), for the spread's coverage."""
    out = np.zeros(n_windows)
    expected, variance = np.full(place.size, np.nan), np.full(place.size, np.nan)
    for a in range(0, place.size, _PAIRS):
        p, k = place[a : a + _PAIRS], window[a : a + _PAIRS]
        t = centres[k]
        flows = predictor.flows(p, t) * share[a : a + _PAIRS]
        expected[a : a + _PAIRS] = flows
        variance[a : a + _PAIRS] = predictor.variances(
            p, predictor.params.calendar.profile_bin(t), flows
        )
        out += np.bincount(k, np.nan_to_num(flows), minlength=n_windows)
    return out, expected, variance


def _profile_rates(state: MapState, rows: np.ndarray, static: np.ndarray) -> np.ndarray:
    """Each place's detections per observed window in each profile bin (its counts in the bin
    over the windows it was observed in the bin; its static rate in a bin it was never
    observed in): float64[places, profile bins], canonical order."""
    from aion_cli.engine.temporal.pooling import count_sums, rows_of

    view = state.query_temporal()
    counts = np.asarray(count_sums(rows_of(view.cnt_profile, rows), 1), dtype=np.float64)
    observed = rows_of(view.obs.profile, rows) + view.glob.profile[0]
    rate: np.ndarray = np.where(
        observed > 0, counts / np.maximum(observed, 1e-300), static[:, None]
    )
    return rate


def _hour_label(hour_ns: int, timezone: str) -> str:
    """The start of an hour (UNIX ns) in the map's zone (an IANA name or an offset such as
    ``UTC+05:30``), ISO 8601 to the minute."""
    from aion_cli.engine.time_text import from_ns
    from aion_cli.timeparse import resolve_zone

    return from_ns(hour_ns, resolve_zone(timezone)).isoformat(timespec="minutes")


def hourly_picture(
    result: HoldoutResult, path: str | os.PathLike[str], title: str, option: str = "path"
) -> Path:
    """The hourly truth (bars) and each model's forecast (lines) as the PNG file ``path``
    (a ``str`` or any ``os.PathLike``, as the API's paths); the file written. Ticks ``HH`` in
    the map's zone, ``MM-DD HH`` when the test spans several days. A bad target is named in
    errors as ``option``: the argument ``path``, or the CLI's ``--png``."""
    from aion_cli.errors import InputError
    from aion_cli.evaluation import plots
    from aion_cli.pictures.render import check_png_target

    path = Path(path)
    check_png_target(path, option)  # a folder, another suffix, a missing folder
    if not result.hours:
        raise InputError(
            "no hourly activity to draw: the test logs observed no window the map could follow",
            hint="see the notes above",
        )
    zone = result.test.get("timezone", "UTC")
    return plots.hourly_activity(
        hour_ticks(result.hours), result.series, path, title, f"hour ({zone})"
    )


def hour_ticks(hours: list[str]) -> list[str]:
    """The ticks of the hours (ISO 8601 with offset, ``HoldoutResult.hours``): ``HH``, or
    ``MM-DD HH`` over several days; an hour a clock change repeats (02:00 twice on an autumn
    change) with its offset, so the two read apart (``02 +02:00``, ``02 +01:00``)."""
    days = {h[:10] for h in hours}
    labels = [h[11:13] if len(days) == 1 else f"{h[5:10]} {h[11:13]}" for h in hours]
    from collections import Counter

    seen = Counter(labels)
    pairs = zip(labels, hours, strict=True)
    return [f"{label} {h[-6:]}" if seen[label] > 1 else label for label, h in pairs]
