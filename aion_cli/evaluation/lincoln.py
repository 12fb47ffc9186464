"""Forecasting a real multi-day corridor: the University of Lincoln T-junction (2017).

Protocol (``docs/EVALUATION.md``): train on the four recorded days 2017-05-24, -25, -26, -31
and forecast 2017-06-09, nine days after the last training day. Detections have no ids: every
file is linked into tracks (``engine.tracking``) for headings, the same way for training and
test. A day present in two files (05-25) is taken from the file holding more of its detections.
No file declares when the sensor ran (06-09's header declares four days of which it holds one),
so each day's recording sessions — detections split at gaps over an hour — are its observed
spans, for training and for the test day alike.

aion learns through the real pipeline: each training day becomes an MCAP log with its
observed spans written as empty detection messages (``aion convert --observed``), and
``aion build`` reads them (a log per day, as it was recorded: each starts and ends inside a
window, which counts by the share of it recorded). The zone is Europe/London (the local
clock people keep).

Scores, per model:

- **heading NLL** of every test detection with a heading (association radius 1 m; the same
  floor for every model, ``evaluation.heading``);
- **hourly activity**: over the test day's observed 10-minute windows, the predicted number of
  detections per window summed per hour against the true count — Spearman rank correlation,
  Poisson deviance ``2 Σ [y ln(y/μ) − (y − μ)]`` and mean absolute error. A window a session
  starts or ends inside is expected to hold its rate times the share of it recorded, for
  every model alike, and the baselines learn their rates per window recorded the same way
  (:func:`recorded_shares`, as ``aion build`` counts a fixed sensor's windows).

Models: ``aion`` (each entry's chosen families), ``aion static`` (its static rates and pooled
histograms), ``aion historical`` (headings only: the raw proportions ``predict --historical``
shows), ``hour-of-day profile`` (activity: the training days' detections per observed
window at each hour of the day; headings: the time-of-day histogram per 1 m cell),
``hour-of-day mean`` (activity only: the plain profile, detections in each hour of the day
averaged over the training days whether or not a day recorded all of that hour), ``static``
(activity: the training days' mean detections per observed window; headings: one histogram
per 1 m cell) and ``grid`` (the STeF-style grid: headings from its FreMEn bin values; activity
from a grid of the same kind fed raw counts).
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.types import DetectionBatch
from aion_cli.errors import InputError
from aion_cli.evaluation.baselines import StaticHistogram, TimeOfDayHistogram
from aion_cli.evaluation.grid import GridMoD, GridSpec
from aion_cli.evaluation.heading import (
    AionHeadingModel,
    GridHeadingModel,
    HeadingModel,
    association_radius,
    score_headings,
)
from aion_cli.evaluation.metrics import hourly_activity

TRAIN_DAYS = ("2017-05-24", "2017-05-25", "2017-05-26", "2017-05-31")
TEST_DAY = "2017-06-09"
ALIGN_DAY = "2017-05-31"
"""The day whose file holds the corridor in another frame (turned by about 171°,
docs/EVALUATION.md); ``run_lincoln(align=True)`` puts it into the split's other training
days' frame."""
ZONE = "Europe/London"
SESSION_GAP_NS = 3_600 * 1_000_000_000
DAY_NS = 86_400 * 1_000_000_000
HOUR_NS = 3_600 * 1_000_000_000


@dataclass
class DayData:
    """One recorded day: its detections and observed spans (UNIX ns, half-open)."""

    day: str
    batch: DetectionBatch
    spans: list[tuple[int, int]]
    source: str


@dataclass
class LincolnResult:
    """Scores per model: heading NLL and hourly activity, plus the per-hour series."""

    headings: list[dict[str, Any]] = field(default_factory=list)
    activity: list[dict[str, Any]] = field(default_factory=list)
    hours: list[int] = field(default_factory=list)
    series: dict[str, list[float]] = field(default_factory=dict)
    families: dict[str, dict[str, int]] = field(default_factory=dict)
    data: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    spread: dict[str, dict[str, Any]] = field(default_factory=dict)
    """The coverage of the test day's counts by aion's 10th-90th percentile band, per
    (entry, window) and per hour (``evaluation.spread.spread_of``)."""

    train: tuple[str, ...] = TRAIN_DAYS
    test: str = TEST_DAY
    zone: str = ZONE
    """The zone of aion's days and hours (the config's ``timezone``)."""

    def to_dict(self) -> dict[str, Any]:
        return {
            "protocol": {"train": list(self.train), "test": self.test, "zone": self.zone},
            "data": self.data,
            "headings": self.headings,
            "activity": self.activity,
            "hours_utc": self.hours,
            "hourly_series": self.series,
            "families": self.families,
            "spread_coverage": self.spread,
            "warnings": self.warnings,
        }


def _utc_day(t_ns: np.ndarray) -> np.ndarray:
    return np.array(
        [datetime.fromtimestamp(int(d) * 86400, UTC).strftime("%Y-%m-%d")
         for d in (t_ns // DAY_NS).tolist()]
    )


def load_days(data_dir: Path) -> dict[str, DayData]:
    """Every recorded day of the Lincoln files, each from the file holding most of it."""
    from aion_cli.formats.datasets import read_lincoln
    from aion_cli.formats.track_types import sessions

    files = sorted(Path(data_dir).glob("2017-*"))
    if not files:
        raise FileNotFoundError(f"no Lincoln files (2017-*.txt) in {data_dir}")
    days: dict[str, DayData] = {}
    for path in files:
        batch = read_lincoln(path).batch
        if len(batch) == 0:
            continue
        day_index = batch.t_ns // DAY_NS
        for d in np.unique(day_index).tolist():
            part = batch.select(day_index == d)
            name = _utc_day(np.array([d * DAY_NS]))[0]
            if name in days and len(days[name].batch) >= len(part):
                continue
            days[name] = DayData(name, part, sessions(part.t_ns, SESSION_GAP_NS), path.name)
    return days


def align_day(days: dict[str, DayData], name: str, onto: list[str]) -> dict[str, Any] | None:
    """Day ``name``'s detections (positions and headings) put into the frame of the days
    ``onto`` by the rigid transform that best overlays their occupancy
    (:func:`aion_cli.engine.align.align_occupancy`), in place; what was found (JSON
    ``aligned``), or None without a day to align onto."""
    from aion_cli.engine.align import align_occupancy

    if not onto:
        return None
    day = days[name]
    fixed = np.concatenate([days[d].batch.xyz[:, :2] for d in onto])
    found = align_occupancy(day.batch.xyz, fixed)
    b = day.batch
    moved = DetectionBatch(
        b.t_ns, found.apply(b.xyz), found.apply_heading(b.heading), b.speed, b.track_id
    )
    days[name] = DayData(name, moved, day.spans, day.source)
    return {"angle_deg": round(float(np.rad2deg(found.angle)), 2),
            "shift_m": [round(v, 3) for v in found.shift], "mirror": found.mirror,
            "onto": list(onto), "overlap_before": round(found.overlap_before, 3),
            "overlap_after": round(found.overlap_after, 3)}


def observed_windows(spans: list[tuple[int, int]], window_ns: int) -> np.ndarray:
    """Windows overlapping the spans (sorted)."""
    parts = [np.arange(a // window_ns, -((-b) // window_ns)) for a, b in spans]
    return np.unique(np.concatenate(parts)).astype(np.int64) if parts else np.zeros(0, np.int64)


def recorded_shares(
    spans: list[tuple[int, int]], windows: np.ndarray, window_ns: int, config: ModelConfig
) -> np.ndarray:
    """Per window, the share of it the spans recorded, as a build counts it (a session that
    starts or ends inside a window recorded only that part; whole windows without
    ``config.exposure``): what every forecast's rate per window is multiplied by."""
    from aion_cli.engine.observation import ObservationSource

    source = ObservationSource()
    for a, b in spans:
        source.set_fixed_sensor(a, b)
    return source.fixed_share(windows, window_ns, config)


def _build_aion(train: list[DayData], config: ModelConfig, work: Path) -> Any:
    """aion's map of the training days through ``convert`` + ``build`` (see module doc)."""
    from aion_cli.formats.tracks_log import tracks_to_log
    from aion_cli.mapquery import load_map
    from aion_cli.pipeline import BuildOptions, build_map

    logs = []
    for d in sorted(train, key=lambda day: day.day):  # a log per day, as it was recorded:
        log = work / f"lincoln_{d.day}.mcap"  # each starts and ends inside a window
        tracks_to_log(d.batch.sorted_by_time(), log, observed=d.spans, overwrite=True)
        logs.append(log)
    report = build_map(
        BuildOptions(logs=tuple(logs), output=work / "lincoln.aion", config=config)
    )
    return load_map(report.output).state


def _rate_per_hour_of_day(
    train: list[DayData], window_ns: int, config: ModelConfig
) -> tuple[np.ndarray, float]:
    """Training detections per observed window at each UTC hour of the day, and overall,
    each window counted for the share of it recorded (:func:`recorded_shares`)."""
    counts, windows = np.zeros(24), np.zeros(24)
    for d in train:
        w = observed_windows(d.spans, window_ns)
        hours = (w * window_ns % DAY_NS) // HOUR_NS
        np.add.at(windows, hours, recorded_shares(d.spans, w, window_ns, config))
        det_w = d.batch.t_ns // window_ns
        seen = np.isin(det_w, w)
        np.add.at(counts, (det_w[seen] * window_ns % DAY_NS) // HOUR_NS, 1.0)
    overall = counts.sum() / windows.sum()
    rate = np.where(windows > 0, counts / np.maximum(windows, 1.0), overall)
    return rate, float(overall)


def _mean_per_hour_of_day(train: list[DayData]) -> np.ndarray:
    """The plain profile: training detections in each UTC hour of the day, averaged over the
    training days (whether or not a day recorded that hour)."""
    counts = np.zeros(24)
    for d in train:
        np.add.at(counts, (d.batch.t_ns % DAY_NS) // HOUR_NS, 1.0)
    out: np.ndarray = counts / len(train)
    return out


def run_lincoln(
    data_dir: Path,
    config: ModelConfig | None = None,
    radius: float = 1.0,
    progress: Callable[[str], None] | None = None,
    train_days: tuple[str, ...] = TRAIN_DAYS,
    test_day: str = TEST_DAY,
    align: bool = False,
) -> LincolnResult:
    """Train on ``train_days`` (default: the four May days), forecast ``test_day`` (June 9);
    see the module docstring. Other splits of the recorded days check that a result is not
    one split's luck. :class:`InputError` for a day the files do not hold, a test day among
    the training days, or no training day; a training day after the test day is a warning
    (``LincolnResult.warnings``). ``align``: 2017-05-31, if in the split, is first put into
    the frame of the split's other training days (:func:`align_day`; off by default: the
    protocol reads the files as recorded)."""
    radius = association_radius(radius)
    cfg = config or ModelConfig(timezone=ZONE)
    say = progress or (lambda _msg: None)
    days = load_days(data_dir)
    recorded = ", ".join(sorted(days))
    missing = [d for d in (*train_days, test_day) if d not in days]
    if missing:
        raise InputError(
            f"Lincoln days not in {data_dir}: {', '.join(missing)}",
            hint=f"the files hold {recorded}",
        )
    if not train_days or test_day in train_days:
        raise InputError(
            "the Lincoln evaluation needs training days and a test day that is not one of them",
            hint=f"the files hold {recorded}",
        )
    aligned = None
    if align and ALIGN_DAY in (*train_days, test_day):
        say(f"aligning {ALIGN_DAY} to the other training days' frame")
        onto = [d for d in sorted(set(train_days)) if d != ALIGN_DAY]
        aligned = align_day(days, ALIGN_DAY, onto)
    train = [days[d] for d in sorted(set(train_days))]
    test = days[test_day]
    window_ns = round(cfg.window_s * 1e9)
    result = LincolnResult(train=tuple(d.day for d in train), test=test_day, zone=cfg.timezone)
    if cfg.timezone != ZONE:  # a --config from print-config says UTC
        result.warnings.append(
            f"the config's timezone is {cfg.timezone}: aion learns the corridor's hours of the "
            f"day in {cfg.timezone}, not in {ZONE}, the clock its people keep (set timezone = "
            f'"{ZONE}" in the config to learn those)'
        )
    later = [d.day for d in train if d.day > test_day]  # ISO dates sort as days do
    if later:
        result.warnings.append(
            f"{len(later)} of the {len(train)} training days ({', '.join(later)}) "
            f"{'comes' if len(later) == 1 else 'come'} after "
            f"the test day {test_day}: the forecast is judged on the past, not on what it "
            "forecasts (train on days before the test day only)"
        )
    result.data = {
        d.day: {"detections": len(d.batch), "file": d.source, "observed_h": round(
            sum(b - a for a, b in d.spans) / 3.6e12, 2)}
        for d in (*train, test)
    }
    if aligned is not None:
        result.data[ALIGN_DAY]["aligned"] = aligned
    say(f"building aion from the {len(train)} training days (convert + build)")
    with tempfile.TemporaryDirectory(prefix="aion-lincoln-") as tmp:
        state = _build_aion(train, cfg, Path(tmp))
    train_batch = DetectionBatch.concat([d.batch for d in train])
    say("training the baselines")
    models = _heading_models(state, train_batch, train, cfg, radius)
    for model in models:
        score = score_headings(model, test.batch, cfg.bins, window_s=cfg.window_s)
        result.headings.append(score.to_dict())
    say("forecasting the test day's hourly activity")
    _activity(result, state, train, test, train_batch, cfg, window_ns)
    return result


def _heading_models(
    state: Any, train_batch: DetectionBatch, train: list[DayData], cfg: ModelConfig,
    radius: float,
) -> list[HeadingModel]:
    spec = GridSpec.covering(train_batch.xyz[:, :2], 1.0)
    grid = GridMoD(spec, cfg)
    for d in train:
        grid.fit(d.batch, *_span_bounds(d))
    tod = TimeOfDayHistogram(spec, cfg.bins)
    tod.fit(train_batch)
    static = StaticHistogram(spec, cfg.bins)
    static.fit(train_batch)
    return [
        *AionHeadingModel.readings(state, radius),
        tod,
        static,
        GridHeadingModel(grid),
    ]


def _span_bounds(day: DayData) -> tuple[int, int]:
    return day.spans[0][0], day.spans[-1][1]


def _activity(
    result: LincolnResult,
    state: Any,
    train: list[DayData],
    test: DayData,
    train_batch: DetectionBatch,
    cfg: ModelConfig,
    window_ns: int,
) -> None:
    from aion_cli.engine.query import predict_table

    windows = observed_windows(test.spans, window_ns)
    det_w = test.batch.t_ns // window_ns
    truth_w = np.array([np.count_nonzero(det_w == w) for w in windows.tolist()], dtype=float)
    centres = windows * window_ns + window_ns // 2
    # a window the test day recorded in part is expected to hold that part of its rate
    share = recorded_shares(test.spans, windows, window_ns, cfg)
    per_window: dict[str, np.ndarray] = {}
    aion = np.array([np.nansum(predict_table(state, int(t)).flow) for t in centres.tolist()])
    per_window["aion"] = aion
    static_rate = float(np.nansum(_historical_flow(state)))
    per_window["aion static"] = np.full(windows.size, static_rate)
    rate_h, overall = _rate_per_hour_of_day(train, window_ns, cfg)
    hod = (windows * window_ns % DAY_NS) // HOUR_NS
    per_window["hour-of-day profile"] = rate_h[hod]
    per_window["hour-of-day mean"] = _mean_per_hour_of_day(train)[hod] * window_ns / HOUR_NS
    per_window["static"] = np.full(windows.size, overall)
    spec = GridSpec.covering(train_batch.xyz[:, :2], 1.0)
    counts_grid = GridMoD(spec, cfg, normalise=False)
    for d in train:
        counts_grid.fit(d.batch, *_span_bounds(d))
    per_window["grid"] = np.array(
        [counts_grid.predict(int(t)).sum() for t in centres.tolist()]
    )
    per_window = {name: forecast * share for name, forecast in per_window.items()}
    starts = windows * window_ns
    hours, result.series, result.activity = hourly_activity(starts, truth_w, per_window)
    # beside the issue's Spearman of the hours' totals, that of their rates: a part hour (the
    # day's last, 14 minutes recorded) is low in every forecast scaled by its share, so the
    # totals credit a one-rate forecast with ranking hours by how long they were recorded
    _, _, by_rate = hourly_activity(starts, truth_w, per_window, exposure=share)
    for row, rated in zip(result.activity, by_rate, strict=True):
        row["spearman_rate"] = rated["spearman"]
    result.hours = [int(h // HOUR_NS % 24) for h in hours.tolist()]
    result.spread = _spread(state, test, windows, share, window_ns)
    table = predict_table(state, int(centres[len(centres) // 2]))
    fam, cnt = np.unique(table.flow_family[table.flow_family != "none"], return_counts=True)
    dfam, dcnt = np.unique(
        table.direction_family[table.direction_family != "none"], return_counts=True
    )
    result.families = {
        "flow": {str(f): int(c) for f, c in zip(fam, cnt, strict=True)},
        "direction": {str(f): int(c) for f, c in zip(dfam, dcnt, strict=True)},
    }


def _spread(
    state: Any, test: DayData, windows: np.ndarray, share: np.ndarray, window_ns: int
) -> dict[str, dict[str, Any]]:
    """How aion's band holds the test day's counts (``evaluation.spread``): every entry in
    every observed window, its forecast times the share of the window recorded (UTC hours,
    as the hourly activity)."""
    from aion_cli.evaluation.spread import spread_of

    rows, predictor = state.predictor()
    centres = windows * window_ns + window_ns // 2
    place = np.tile(np.arange(rows.size, dtype=np.int64), windows.size)
    window = np.repeat(np.arange(windows.size, dtype=np.int64), rows.size)
    expected = predictor.flows(place, centres[window]) * share[window]
    variance = predictor.variances(
        place, predictor.params.calendar.profile_bin(centres[window]), expected
    )
    det_w = test.batch.t_ns // window_ns
    at = np.searchsorted(windows, det_w)
    hit = (at < windows.size) & (windows[np.minimum(at, windows.size - 1)] == det_w)
    starts = windows * window_ns
    return spread_of(
        state, rows, test.batch.xyz, np.where(hit, at, -1), (place, window, windows.size),
        (expected, variance), (starts, starts),
    )


def _historical_flow(state: Any) -> np.ndarray:
    from aion_cli.engine.query import historical_table

    out: np.ndarray = historical_table(state).flow
    return out
