"""The paper's comparison (Table I): aion against a STeF-style grid on the simulated office.

Per scene (``docs/EVALUATION.md`` has the full definition):

1. ``aion simulate`` writes one office scene (6 people, a patrolling robot, a Hydra-like
   scene-graph stream with loop closures) as an MCAP log; detections are published in the map
   frame so aion and the grid see exactly the same detections.
2. aion builds its map from the log through the real ``aion build`` pipeline.
3. The grid (1 m, 8 bins, 600 s windows, max-normalised, FreMEn per cell and bin) learns from the
   same detections, observing a cell in a window when the robot's sensor range covered it, for
   the share of the window aion would count (its ``exposure``).
4. aion's output is discretised onto the grid: each grid cell takes the nearest aion entry
   (node or unbound cell) within ``radius`` metres. Cells where both maps have flow are compared.
5. Per map type, historical (counts) and predicted (FreMEn, averaged over ``eval_hours`` times of
   the last simulated day):

   - Entropy and Flow: Jensen–Shannon divergence (bits) and Bhattacharyya distance between the
     two spatial distributions (each map's values over the common cells, normalised to sum 1);
     Wasserstein-1 distance between the two sets of values, each map divided by its maximum
     (so in units of "the busiest cell"; entropy is already in [0, 1]).
   - Direction: mean angular displacement (degrees) between the dominant directions (the
     Wasserstein distance on the circle for single directions) and circular correlation.

The mean ± standard deviation over scenes forms the table; the paper's numbers are printed beside.
Ground truth: the simulator's true flow per place and window (every agent, seen or not) is
compared with aion's predictions per node (direction JS divergence, correlation of flow with
one day's true counts and with the expected counts, the other scenes' mean): that comparison
lives in :mod:`.office_truth` and is re-exported here; the paper's table and the comparison of
two maps on the common grid (steps 4 and 5) in :mod:`.office_compare`.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.query import EntryTable, historical_table, predict_table
from aion_cli.engine.types import DetectionBatch, Trajectory
from aion_cli.evaluation.grid import GridMoD, GridSpec
from aion_cli.evaluation.office_compare import (
    METRICS,
    PAPER_TABLE,
    MapView,
    compare_views,
    discretise,
    grid_view,
)
from aion_cli.evaluation.office_directions import (
    direction_truth_scores,
    direction_truth_table,
    mean_normalised,
)
from aion_cli.evaluation.office_scenes import (
    check_kept_files,
    check_scenes,
    scene_config,
    scene_files,
)
from aion_cli.evaluation.office_truth import (
    TRUTH_FIELDS,
    FlowSeries,
    SceneTruth,
    _truth_scores,
    expected_flow_correlations,
    place_rows,
    reference_forecasts,
    separable_flow_correlations,
    truth_sentence,
)

F64 = npt.NDArray[np.float64]

@dataclass
class OfficeResult:
    scenes: list[dict[str, Any]] = field(default_factory=list)
    figure: dict[str, Any] | None = None
    series: list[FlowSeries] = field(default_factory=list)  # not serialised

    def table(self) -> list[dict[str, Any]]:
        """Rows as the paper's Table I: map type, data type, mean and std of each metric."""
        rows = []
        for (kind, data), paper in PAPER_TABLE.items():
            row: dict[str, Any] = {"map_type": kind, "data_type": data}
            for metric in METRICS:
                values = np.array(
                    [s["table"][f"{kind}/{data}"].get(metric, math.nan) for s in self.scenes],
                    dtype=float,
                )
                ok = values[np.isfinite(values)]
                applicable = paper[metric] is not None
                row[metric] = (
                    (float(ok.mean()), float(ok.std())) if applicable and len(ok) else None
                )
                row[f"paper_{metric}"] = paper[metric]
            rows.append(row)
        return rows

    def to_dict(self) -> dict[str, Any]:
        return {"table": self.table(), "directions": self.directions(), "scenes": self.scenes}

    def directions(self) -> list[dict[str, Any]]:
        """aion's and the grid's directions against the truth, mean and std over the scenes
        (:func:`~aion_cli.evaluation.office_directions.direction_truth_table`)."""
        return direction_truth_table(self.scenes)

    def truth_means(self) -> dict[str, float]:
        """The mean over scenes of each ground-truth figure (:data:`TRUTH_FIELDS`; NaN-skipping,
        NaN where no scene has it); empty when no scene was compared with the truth."""
        truth = [s["truth"] for s in self.scenes if s.get("truth", {}).get("places_compared")]
        if not truth:
            return {}
        out = {}
        for key in TRUTH_FIELDS:
            values = np.array([t.get(key, math.nan) for t in truth], dtype=float)
            out[key] = float(np.nanmean(values)) if np.isfinite(values).any() else math.nan
        return out


def evaluated_times(scene_end_ns: int, eval_hours: int) -> npt.NDArray[np.int64]:
    """The times a scene is evaluated at: ``eval_hours`` evenly spaced over its last 24 hours
    (the day before ``scene_end_ns``, exclusive), the first at that day's start, so each
    falls at the start of its window and hour (at 24 a day: 00:00, 01:00, ..., 23:00)."""
    day = 86_400_000_000_000
    out: npt.NDArray[np.int64] = scene_end_ns - day + np.arange(eval_hours, dtype=np.int64) * (
        day // eval_hours
    )
    return out


def run_scene(
    scene: int,
    days: float,
    agents: int,
    seed: int,
    config: ModelConfig,
    radius: float,
    eval_hours: int,
    work: Path,
    keep_figure: bool,
) -> tuple[dict[str, Any], dict[str, Any] | None, FlowSeries | None]:
    """Simulate, build both maps, compare; returns the scene's figures (and plot arrays) and
    its flow forecasts beside the truth (None if no place became a node)."""
    from aion_cli.mapquery import load_map
    from aion_cli.pipeline import BuildOptions, build_map
    from aion_cli.sim.scenario import build_scene, load_environment
    from aion_cli.sim.scenario import run_scene as write_scene

    sim = scene_config(days, agents, seed)
    env = load_environment(sim)
    log, *_truth, out = scene_files(work, scene)
    written = write_scene(sim, env, scene, log)
    if not written.meta.get("detections"):
        from aion_cli.errors import InputError

        raise InputError(
            f"scene {scene + 1}: the robot detected nobody in {days:g} simulated day(s) from "
            "midnight (the office's people come in from about 7:00 on weekdays)",
            hint="give --days 1 or more",
        )
    data = build_scene(sim, env, scene)
    report = build_map(
        BuildOptions(logs=(log,), output=out, config=config)
    )
    state = load_map(report.output).state
    batch = _detections(data)
    grid = GridMoD(GridSpec.covering(batch.xyz[:, :2], 1.0), config)
    grid.fit(batch, data.t0_ns, data.end_ns + 1, _robot_observation(data))
    centres = grid.spec.centres()
    views = {
        "Historical": (discretise(historical_table(state), centres, radius), grid_view(grid, None))
    }
    last_day = evaluated_times(data.t0_ns + data.n_ticks * data.dt_ns, eval_hours)
    tables = [predict_table(state, int(t)) for t in last_day]  # for the grid and the truth
    predicted = [
        compare_views(discretise(table, centres, radius), grid_view(grid, int(t)))
        for t, table in zip(last_day, tables, strict=True)
    ]
    table = {f"{k}/Historical": v for k, v in compare_views(*views["Historical"]).items()}
    for kind in ("Entropy", "Flow", "Direction"):  # each figure's mean over the hours
        table[f"{kind}/Predicted"] = {
            ("mean_cells" if m == "cells" else m): float(
                np.nanmean([p[kind].get(m, math.nan) for p in predicted])
            )
            for m in predicted[0][kind]
        }  # the cells compared (a count each hour) too: their mean, named so
    scene_truth = SceneTruth.load(written.truth_npz)
    truth, series = _truth_scores(scene_truth, state, last_day, tables)
    directions = _direction_scores(scene_truth, state, grid, last_day, tables)
    figure = None
    if keep_figure:
        aion_view, grid_v = views["Historical"]
        figure = {"centres": centres, "grid": grid_v, "aion": aion_view}
    return (
        {
            "scene": scene,
            "detections": len(batch),
            "nodes": report.nodes,
            "cells": report.cells,
            "bound_cells": report.bound_cells,
            "table": table,
            "truth": truth,
            "directions": directions,
            "grid_bytes": grid.stored_bytes(),
            "aion_bytes": report.map_bytes,
        },
        figure,
        series,
    )


def _direction_scores(
    scene: SceneTruth,
    state: Any,
    grid: GridMoD,
    times_ns: npt.NDArray[np.int64],
    tables: list[EntryTable],
) -> dict[str, Any]:
    """aion's and the grid's direction histograms, historical and predicted, at each place that
    became an aion node, against the true histogram of every agent over the evaluated day (the
    windows from the first evaluated time's on): :mod:`.office_directions`."""
    starts = scene.window_start_ns
    table = historical_table(state)
    pairs = place_rows(scene.place_ids, table.node_id)
    if len(pairs) == 0:
        return direction_truth_scores(np.zeros((0, grid.bins)), {})
    rows, columns = pairs[:, 0], pairs[:, 1]
    first = max(int(np.searchsorted(starts, int(times_ns[0]), side="right")) - 1, 0)
    truth = scene.flow_counts[first:, columns, :].sum(axis=0).astype(np.float64)
    cells = grid.spec.cell_of(table.xyz[rows, :2])
    inside = cells >= 0

    def at_places(values: F64) -> F64:  # the grid's rows at the places (zeros outside it)
        out = np.zeros((len(rows), grid.bins))
        out[inside] = values[cells[inside], : grid.bins]
        return out

    maps = {
        "aion historical": table.rate[rows],
        "aion predicted": mean_normalised([t.rate[rows] for t in tables]),
        "grid historical": at_places(grid.historical()),
        "grid predicted": mean_normalised([at_places(grid.predict(int(t))) for t in times_ns]),
    }
    return direction_truth_scores(truth, maps)


def _detections(data: Any) -> DetectionBatch:
    """The scene's published detections (map frame) as a batch."""
    obs = data.obs
    heading = np.arctan2(obs.velocity[:, 1], obs.velocity[:, 0])
    speed = np.hypot(obs.velocity[:, 0], obs.velocity[:, 1])
    t = data.t0_ns + obs.tick * data.dt_ns
    return DetectionBatch.from_arrays(t, obs.xyz, heading, speed, obs.track_id)


def _robot_observation(data: Any) -> ObservationSource | None:
    if data.robot is None:
        return None
    source = ObservationSource()
    ticks = np.arange(data.n_ticks)
    xyz = np.column_stack([data.robot.pose[:, :2], np.zeros(data.n_ticks)])
    source.add_trajectory(Trajectory(data.t0_ns + ticks * data.dt_ns, xyz))
    return source


def run_office(
    scenes: int = 20,
    days: float = 3.0,
    agents: int = 6,
    seed: int = 0,
    config: ModelConfig | None = None,
    radius: float = 1.0,
    eval_hours: int = 24,
    work_dir: Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> OfficeResult:
    """Run the comparison over ``scenes`` simulated office scenes. :class:`InputError`
    for numbers it cannot run with (the simulator's own checks, a radius that is not a
    positive number of metres, a model of other than 8 direction bins: the simulator's truth
    and the grid are kept in 8)."""
    from aion_cli.errors import InputError
    from aion_cli.evaluation.heading import association_radius
    from aion_cli.formats.outputs import check_output_folder

    cfg = config or ModelConfig()
    radius = association_radius(radius)
    if not (math.isfinite(days) and days > 0):
        raise InputError(f"--days must be a positive number, got {days!r}",
                         hint="e.g. --days 2 (the default): simulated days per scene")
    if seed < 0:
        raise InputError(f"--seed must be a whole number from 0, got {seed}",
                         hint="e.g. --seed 0 (the default)")
    if cfg.bins != 8:
        raise InputError(
            f"the office comparison keeps 8 direction bins (its truth and the grid), got "
            f"bins = {cfg.bins} in the config",
            hint="leave bins out of the config for evaluate office",
        )
    check_scenes(days, agents, seed)
    say = progress or (lambda _msg: None)
    result = OfficeResult()
    with tempfile.TemporaryDirectory(prefix="aion-office-") as tmp:
        work = Path(work_dir) if work_dir is not None else Path(tmp)
        check_output_folder(work, f"--keep {work}")  # --keep's folder is made, not those above
        if work_dir is not None:
            check_kept_files(work, scenes)  # before the first scene, not at the one it holds
        work.mkdir(exist_ok=True)
        for scene in range(scenes):
            say(f"scene {scene + 1}/{scenes}: simulate, build, compare")
            figures, figure, series = run_scene(
                scene, days, agents, seed, cfg, radius, eval_hours, work, keep_figure=scene == 0
            )
            result.scenes.append(figures)
            if series is not None:
                result.series.append(series)
            if figure is not None:
                result.figure = figure
    with_series = [s for s in result.scenes if s["truth"].get("places_compared", 0) > 0]
    for scene_figures, corr, apart in zip(
        with_series,
        expected_flow_correlations(result.series),
        separable_flow_correlations(result.series),
        strict=True,
    ):
        scene_figures["truth"]["flow_correlation_expected"] = corr
        scene_figures["truth"].update(apart)
    return result


__all__ = [
    "PAPER_TABLE",
    "TRUTH_FIELDS",
    "FlowSeries",
    "MapView",
    "OfficeResult",
    "compare_views",
    "expected_flow_correlations",
    "reference_forecasts",
    "run_office",
    "run_scene",
    "separable_flow_correlations",
    "truth_sentence",
]
