"""The FreMEn check on a real periodic signal: the door of ``gestom/hypertime-RAL``.

Ten training weeks of 1-minute door states (open 1 / closed 0), then nine later test weeks.
The signal is learnt by aion's temporal model as one entry observed every minute (windows of
60 s) whose "count" in a minute is the door state, day by day as a build records windows; each
family's order and score come from the same day-ahead scoring as a map's. On every test week
the mean absolute error of FreMEn (its best order by day-ahead score) is compared with the
static mean's; the family the model itself would choose and the periodic profile are reported
beside them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal import model as temporal
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.forecast import Forecaster
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.errors import InputError

WINDOW_NS = 60_000_000_000
_ONE = np.zeros(1, np.int64)


def door_config() -> ModelConfig:
    """Minute windows; everything else aion's defaults."""
    return ModelConfig(window_s=60.0)


def train_door(data_dir: Path) -> tuple[TemporalParams, TemporalState]:
    """The door signal learnt as one always-observed entry (see the module docstring)."""
    train = _table(Path(data_dir) / "training_data.txt", 2, "time_s state")
    params = TemporalParams.from_config(door_config())
    state = temporal.empty_state(params, 1)
    windows = np.floor_divide(np.round(train[:, 0]).astype(np.int64) * 10**9, WINDOW_NS)
    windows, first = np.unique(windows, return_index=True)
    open_ = np.flatnonzero(train[first, 1] > 0)
    values = np.zeros((open_.size, params.values))
    values[:, -1] = train[first[open_], 1]  # the "no heading" bin carries the state
    day = DayWindows(
        windows,
        np.ones(windows.size, bool),
        np.zeros(0, np.int64),
        np.zeros(0, np.int64),
        np.zeros(open_.size, np.int64),
        open_.astype(np.int64),
        values,
    )
    temporal.learn(params, state, day, _ONE, _ONE, 1, WINDOW_NS)
    return params, state


def _mae(fc: Forecaster, family: str, t_ns: np.ndarray, truth: np.ndarray) -> float:
    """Mean absolute error of a family's prediction (clamped to [0, 1]) at the test times."""
    e = np.zeros(t_ns.size, np.int64)
    h = fc.params.calendar.profile_bin(t_ns)
    pred = np.clip(fc.flow(family, e, h, fc.params.model_seconds(t_ns)), 0.0, 1.0)
    return float(np.mean(np.abs(pred - truth)))


def _table(path: Path, columns: int, names: str) -> np.ndarray:
    """The numbers of one door file (``columns`` per line: ``names``), finite and not
    empty; :class:`InputError` naming the file otherwise."""
    import warnings

    if not path.is_file():
        raise InputError(f"door data file not found: {path}", hint="pass the folder with --data")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            table = np.loadtxt(path, ndmin=2 if columns > 1 else 1)
    except ValueError as exc:
        raise InputError(
            f"{path}: not a table of numbers ({exc})", hint=f"each line holds: {names}"
        ) from exc
    shape_ok = table.ndim == (2 if columns > 1 else 1) and (
        columns == 1 or table.shape[1] == columns
    )
    if table.size == 0 or not shape_ok or not np.isfinite(table).all():
        raise InputError(
            f"{path}: {'no rows' if table.size == 0 else 'rows that are not finite numbers'}"
            f" (each line holds: {names})"
        )
    out: np.ndarray = table
    return out


def run_door(data_dir: Path, weeks: range = range(1, 10)) -> dict[str, Any]:
    """Per test week: MAE of FreMEn (best order), of the static mean and of the model's own
    choice, and who wins."""
    params, state = train_door(data_dir)
    if not state.flow_days[0]:  # every family's score 0: no "best" order, no choice to report
        raise InputError(
            f"{Path(data_dir) / 'training_data.txt'}: no day of the training data could be "
            "scored against the days before it, so no FreMEn order or family can be chosen",
            hint="give at least two days of 1-minute states (the door's file holds ten weeks)",
        )
    predictor = temporal.Predictor.of(params, state, _ONE, _ONE, 1)
    fc = predictor.forecaster
    scores = state.flow_score[0]
    fremen = [f for f in params.flow if f.startswith("fremen")]
    best_fremen = max(fremen, key=lambda f: scores[params.flow.index(f)])
    chosen = params.flow[int(predictor.flow_choice[0])]
    rows = []
    for k in weeks:
        times = _table(Path(data_dir) / f"test_times_{k}.txt", 1, "time_s")
        truth = _table(Path(data_dir) / f"test_data_{k}.txt", 1, "state")
        if len(times) != len(truth):
            raise InputError(
                f"test week {k}: {len(times):,} times but {len(truth):,} states",
                hint="test_times_k.txt and test_data_k.txt hold one line per minute each",
            )
        t_ns = np.round(times).astype(np.int64) * 10**9 + WINDOW_NS // 2
        row: dict[str, Any] = {"week": k, "samples": len(truth)}
        for key, family in (
            ("fremen", best_fremen),
            ("static", "static"),
            ("profile", "profile"),
            ("chosen", chosen),
        ):
            row[f"mae_{key}"] = _mae(fc, family, t_ns, truth)
        rows.append(row)
    gamma = fc.coef_total[0]
    periods = np.asarray(params.config.periods)[fc.period_idx[0]]
    return {
        "chosen_family": chosen,
        "fremen_order": int(best_fremen.removeprefix("fremen")),
        "day_ahead_scores": {f: float(scores[i]) for i, f in enumerate(params.flow)},
        "strongest_periods_h": [round(float(p) / 3600.0, 3) for p in periods],
        "strongest_amplitudes": [round(float(abs(g)), 5) for g in gamma],
        "weeks": rows,
        "fremen_wins": sum(r["mae_fremen"] < r["mae_static"] for r in rows),
    }
