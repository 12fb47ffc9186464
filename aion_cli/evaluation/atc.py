"""Predictive accuracy on the real ATC shopping-centre tracks (2012-10-24, 09:00–21:00 JST).

Two protocols (``docs/EVALUATION.md``):

- ``random``: train on every ``atc-1024-{H}_train.csv`` (90 % of the people of each hour), then
  score the held-out ``_test`` file of each hour (the other 10 %) hour by hour.
- ``chronological``: train on all people of the hours up to 16:00 (09:00–16:59), then predict
  17:00–20:59 (all people of those hours) — forecasting, not interpolation.

Models: ``aion`` (hash cells, each entry's chosen temporal families), ``aion+graph`` (a
navigational graph derived from where people walk, cells bound to its nodes), ``aion static``
(the same map as ``aion`` with its static, pooled histograms), ``aion historical`` (its raw
proportions, as ``predict --historical`` shows), ``grid`` (STeF-style dense 1 m grid, aion's
FreMEn),
``time-of-day`` (per-cell histograms per hour of the day). ATC has no robot: every model is a
fixed sensor observing the whole area over the training span.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.derive_graph import OccupancyGrid
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.state import MapState
from aion_cli.engine.types import DetectionBatch
from aion_cli.evaluation.baselines import TimeOfDayHistogram
from aion_cli.evaluation.grid import GridMoD, GridSpec
from aion_cli.evaluation.heading import (
    AionHeadingModel,
    GridHeadingModel,
    HeadingModel,
    association_radius,
    score_headings,
)
from aion_cli.formats.tracks import read_tracks

JST_OFFSET_H = 9.0
JST = "Asia/Tokyo"
HOUR_NS = 3_600_000_000_000
PROTOCOLS = ("random", "chronological")
_NAME = re.compile(r"atc-1024-(\d+)_(train|test)\.csv$")


@dataclass
class AtcResult:
    """Per-hour scores of every model, plus model sizes and what was used."""

    protocol: str
    radius: float
    train_detections: int
    rows: list[dict[str, Any]] = field(default_factory=list)
    sizes: dict[str, int] = field(default_factory=dict)
    hours_without_training: list[int] = field(default_factory=list)
    """Hours the protocol trains on (random: every hour it tests) with no ``_train`` file."""
    notes: list[str] = field(default_factory=list)

    def summary(self) -> list[dict[str, Any]]:
        """Per model: detection-weighted mean NLL (matched and all), unmatched, chi-square."""
        out = []
        for model in dict.fromkeys(r["model"] for r in self.rows):
            rows = [r for r in self.rows if r["model"] == model]
            n = sum(r["detections"] for r in rows)
            matched = sum(r["matched"] for r in rows)
            out.append(
                {
                    "model": model,
                    "detections": n,
                    "unmatched": n - matched,
                    "nll_matched": _weighted(rows, "nll_matched", "matched"),
                    "nll_all": _weighted(rows, "nll_all", "detections"),
                    "chi_square": _weighted(rows, "chi_square", "matched"),
                }
            )
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "protocol": self.protocol,
            "association_radius_m": self.radius,
            "train_detections": self.train_detections,
            "per_hour": self.rows,
            "summary": self.summary(),
            "model_bytes": self.sizes,
            "hours_without_training": self.hours_without_training,
            "notes": self.notes,
        }


def _weighted(rows: list[dict[str, Any]], key: str, weight: str) -> float:
    w = np.array([r[weight] for r in rows], dtype=float)
    v = np.array([r[key] for r in rows], dtype=float)
    ok = np.isfinite(v) & (w > 0)
    return float(np.sum(v[ok] * w[ok]) / np.sum(w[ok])) if np.any(ok) else float("nan")


def atc_files(data_dir: Path) -> dict[tuple[int, str], Path]:
    """``(hour, "train"|"test") -> path`` for the ATC files found in ``data_dir``."""
    found = {}
    for path in sorted(Path(data_dir).glob("atc-1024-*_*.csv")):
        match = _NAME.search(path.name)
        if match:
            found[(int(match.group(1)), match.group(2))] = path
    if not found:
        raise FileNotFoundError(f"no ATC files (atc-1024-H_train.csv) in {data_dir}")
    return found


def load(files: dict[tuple[int, str], Path], keys: list[tuple[int, str]]) -> DetectionBatch:
    """The detections of the given (hour, split) files, time-sorted."""
    batches = [read_tracks(files[k], layout="atc") for k in keys if k in files]
    return DetectionBatch.concat(batches).sorted_by_time()


def local_hour(t_ns: np.ndarray) -> np.ndarray:
    return ((t_ns // HOUR_NS) + int(JST_OFFSET_H)) % 24


def build_aion(train: DetectionBatch, config: ModelConfig, with_graph: bool) -> MapState:
    """aion's map of the training detections as a fixed sensor (optionally with a derived graph)."""
    start, end = int(train.t_ns.min()), int(train.t_ns.max()) + 1
    mapper = Mapper(config)
    mapper.set_fixed_sensor(start, end)
    if with_graph:
        occupancy = OccupancyGrid(config.derive_spacing)
        occupancy.add(train.xyz)
        mapper.add_graph(occupancy.graph(config.derive_min_detections, start))
    mapper.add_detections(train)
    mapper.advance(end + round(config.window_s * 1e9))
    return mapper.state


def run_atc(
    data_dir: Path,
    protocol: str = "random",
    config: ModelConfig | None = None,
    radius: float = 1.0,
    progress: Callable[[str], None] | None = None,
) -> AtcResult:
    """Train and score every model on ATC under ``protocol``."""
    if protocol not in PROTOCOLS:
        raise ValueError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
    radius = association_radius(radius)
    cfg = config or ModelConfig(timezone=JST)
    say = progress or (lambda _msg: None)
    files = atc_files(data_dir)
    hours = sorted({h for h, _ in files})
    if protocol == "random":
        train = load(files, [(h, "train") for h in hours])
        tests = {h: load(files, [(h, "test")]) for h in hours if (h, "test") in files}
    else:
        train = load(files, [(h, s) for h in hours if h <= 16 for s in ("train", "test")])
        tests = {h: load(files, [(h, "train"), (h, "test")]) for h in hours if h >= 17}
    _check_split(data_dir, protocol, files, len(train), len(tests))
    say(f"training on {len(train):,} detections")
    models = _train_models(train, cfg, radius, say)
    result = AtcResult(protocol, radius, len(train))
    result.sizes = {name: size for name, (_, size) in models.items()}
    trained = list(tests) if protocol == "random" else [h for h in hours if h <= 16]
    result.hours_without_training = [h for h in trained if (h, "train") not in files]
    if result.hours_without_training:
        result.notes.append(_untrained_note(protocol, result.hours_without_training))
    for hour, test in tests.items():
        headed = int(np.count_nonzero(np.isfinite(test.heading)))  # what the scores count
        unheaded = f", {headed:,} of them with a heading" if headed < len(test) else ""
        say(f"scoring {hour}:00 ({len(test):,} detections{unheaded})")
        for model, _size in models.values():
            score = score_headings(model, test, cfg.bins, window_s=cfg.window_s)
            result.rows.append({"hour": hour, **score.to_dict()})
    return result


def _check_split(
    data_dir: Path, protocol: str, files: dict[tuple[int, str], Path], train: int, tests: int
) -> None:
    """A folder of some of the ATC files (``--data``) must hold what ``protocol`` trains on
    and what it tests, else an :class:`InputError` naming the files it holds (no training
    detection failed inside; no test hour printed an empty table as a result)."""
    from aion_cli.errors import InputError

    held = ", ".join(sorted(p.name for p in files.values()))
    if protocol == "random":
        needs = "the random protocol trains on the _train files and tests each hour's _test file"
    else:
        needs = "the chronological protocol trains on 09:00-16:59 and predicts 17:00-20:59"
    if train == 0:
        raise InputError(f"no training detections for the {protocol} protocol in {data_dir} "
                         f"(it holds {held})", hint=needs)
    if tests == 0:
        raise InputError(f"no test hour for the {protocol} protocol in {data_dir} "
                         f"(it holds {held})", hint=needs)


def _untrained_note(protocol: str, untrained: list[int]) -> str:
    """What the scores of the hours without a ``_train`` file are (the real data lacks
    ``atc-1024-12_train.csv``): the random protocol scores their test people with models that
    saw nobody of that hour; the chronological one trains on their ``_test`` file alone."""
    hours = ", ".join(f"{h}:00" for h in untrained)
    files = ", ".join(f"atc-1024-{h}_train.csv" for h in untrained)
    one = len(untrained) == 1
    if protocol == "random":
        return (
            f"{hours} {'has' if one else 'have'} no training data ({files} not in the folder): "
            f"{'its' if one else 'their'} test people are scored by models trained on the "
            "other hours only"
        )
    return (
        f"{hours} {'has' if one else 'have'} no training file ({files} not in the folder): "
        f"trained on {'its' if one else 'their'} _test file alone (about a tenth of "
        f"{'its' if one else 'their'} people)"
    )


def _train_models(
    train: DetectionBatch, cfg: ModelConfig, radius: float, say: Callable[[str], None]
) -> dict[str, tuple[HeadingModel, int]]:
    say("building aion (hash cells)")
    cells = build_aion(train, cfg, with_graph=False)
    say("building aion with a derived navigational graph")
    graph = build_aion(train, cfg, with_graph=True)
    say("building the grid baseline")
    spec = GridSpec.covering(train.xyz[:, :2], 1.0)
    grid = GridMoD(spec, cfg)
    grid.fit(train)
    tod = TimeOfDayHistogram(spec, cfg.bins, utc_offset_h=JST_OFFSET_H)
    tod.fit(train)
    aion, aion_static, aion_historical = AionHeadingModel.readings(cells, radius)
    return {
        "aion": (aion, _state_bytes(cells)),
        "aion+graph": (AionHeadingModel(graph, radius, name="aion+graph"), _state_bytes(graph)),
        "aion static": (aion_static, 0),
        "aion historical": (aion_historical, 0),
        "grid": (GridHeadingModel(grid), grid.stored_bytes()),
        "time-of-day": (tod, int(tod.counts.nbytes)),
    }


def _state_bytes(state: MapState) -> int:
    """The bytes of the state's map members: the forecast priors (a map that forecasts
    stores them) counted by their member's size, not estimated (only their bytes matter)."""
    from aion_cli.engine.temporal.pool_priors import PoolPriors

    arrays, _meta = state.to_arrays(priors=False)
    if state.deferred is None:
        arrays.update(PoolPriors(0.0, 0.0, None, 0, 0).to_arrays())
    return int(sum(a.nbytes for a in arrays.values()))
