"""FreMEn on a real periodic signal: the door of gestom/hypertime-RAL (1-minute samples).

Ten training weeks (2016-01-04 .. 2016-03-13), then nine later test weeks. The daily period must
be among the strongest components and, on every test week, the prediction with the chosen order
must have a lower mean absolute error than the static mean (order 0). Run with ``-s`` to see the
per-week figures.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.config import DAY_S, ModelConfig, default_periods
from aion_cli.engine.fremen import FremenModel, FremenState, to_model_seconds

DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "fremen_door"


def _seconds(unix_s: np.ndarray) -> np.ndarray:
    return to_model_seconds(unix_s.astype(np.int64) * 1_000_000_000)


@pytest.fixture(scope="module", params=[1, ModelConfig().score_stride], ids=lambda k: f"stride{k}")
def trained(request: pytest.FixtureRequest) -> tuple[FremenModel, FremenState]:
    """Trained with every observation scored, and with the mapper's default scoring stride."""
    train = np.loadtxt(DATA / "training_data.txt")
    model = FremenModel(default_periods(), score_stride=request.param)
    state = model.empty(1)
    t = _seconds(train[:, 0])
    day = 1440
    for a in range(0, t.size, day):  # one call per day, as the mapper batches windows
        s = train[None, a : a + day, 1]
        model.update(state, [0], t[a : a + day], s, np.ones(s.shape, bool))
    return model, state


def test_training_absorbs_every_sample(trained: tuple[FremenModel, FremenState]) -> None:
    _, state = trained
    assert state.n[0] == 96_480
    assert state.sum_s[0] / state.n[0] == pytest.approx(0.118, abs=5e-4)
    # every observation after the first day (1,440 samples with no earlier model to forecast
    # them): scored, or stood for by a scored one (weight k)
    assert state.order_n[0] == 96_480 - 1_440


def test_daily_period_is_among_the_three_strongest(
    trained: tuple[FremenModel, FremenState],
) -> None:
    model, state = trained
    amp, _ = model.spectrum(state)
    top = np.argsort(-amp[0])[:3]
    print(
        "\ntop periods (h, amplitude):",
        [(model.periods[k] / 3600, round(amp[0, k], 4)) for k in top],
    )
    assert model.periods.index(DAY_S) in top


def test_fremen_beats_static_mean_on_each_test_week(
    trained: tuple[FremenModel, FremenState],
) -> None:
    model, state = trained
    chosen = int(model.chosen_order(state)[0])
    print(f"\nstride {model.score_stride}, chosen order {chosen}; week: MAE FreMEn vs static")
    assert chosen >= 1
    for k in range(1, 10):
        t = _seconds(np.loadtxt(DATA / f"test_times_{k}.txt"))
        truth = np.loadtxt(DATA / f"test_data_{k}.txt")
        assert t.size == truth.size == 10_081
        fremen = float(np.abs(model.predict(state, t)[0] - truth).mean())
        static = float(np.abs(model.predict(state, t, order=0)[0] - truth).mean())
        print(f"  week {k}: {fremen:.4f} vs {static:.4f}")
        assert fremen < static, k
