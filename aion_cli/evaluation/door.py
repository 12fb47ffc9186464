"""The FreMEn check on a real periodic signal: the door of ``gestom/hypertime-RAL``.

Ten training weeks of 1-minute door states (open 1 / closed 0), then nine later test weeks.
FreMEn is trained on the training weeks (batched one day per update, as the mapper batches
windows) and scored on every test week by the mean absolute error of its prediction with the
chosen order against that of the static mean (order 0).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.config import default_periods
from aion_cli.engine.fremen import FremenModel, FremenState, to_model_seconds

SAMPLES_PER_DAY = 1440


def _model_seconds(unix_s: np.ndarray) -> np.ndarray:
    return to_model_seconds(np.round(unix_s).astype(np.int64) * 1_000_000_000)


def train_door(data_dir: Path) -> tuple[FremenModel, FremenState]:
    """FreMEn (default 31 periods) fed the training signal one day at a time."""
    train = np.loadtxt(Path(data_dir) / "training_data.txt", ndmin=2)
    model = FremenModel(default_periods())
    state = model.empty(1)
    t = _model_seconds(train[:, 0])
    for start in range(0, len(t), SAMPLES_PER_DAY):
        values = train[None, start : start + SAMPLES_PER_DAY, 1]
        model.update(
            state,
            [0],
            t[start : start + SAMPLES_PER_DAY],
            values,
            np.ones(values.shape, dtype=bool),
        )
    return model, state


def run_door(data_dir: Path, weeks: range = range(1, 10)) -> dict[str, Any]:
    """Per test week: MAE of FreMEn (chosen order) and of the static mean, and who wins."""
    model, state = train_door(data_dir)
    amplitude, _phase = model.spectrum(state)
    strongest = np.argsort(-amplitude[0])[:5]
    order = int(model.chosen_order(state)[0])
    rows = []
    for k in weeks:
        times = np.loadtxt(Path(data_dir) / f"test_times_{k}.txt", ndmin=1)
        truth = np.loadtxt(Path(data_dir) / f"test_data_{k}.txt", ndmin=1)
        t = _model_seconds(times)
        fremen = model.predict(state, t)[0]
        static = model.predict(state, t, order=0)[0]
        rows.append(
            {
                "week": k,
                "samples": len(truth),
                "mae_fremen": float(np.mean(np.abs(fremen - truth))),
                "mae_static": float(np.mean(np.abs(static - truth))),
            }
        )
    return {
        "chosen_order": order,
        "strongest_periods_h": [round(model.periods[i] / 3600.0, 3) for i in strongest],
        "strongest_amplitudes": [round(float(amplitude[0, i]), 5) for i in strongest],
        "weeks": rows,
        "fremen_wins": sum(r["mae_fremen"] < r["mae_static"] for r in rows),
    }
