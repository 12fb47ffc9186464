"""The temporal model on a real periodic signal: the door of gestom/hypertime-RAL (1-minute
samples), as `aion evaluate door` runs it. Ten training weeks (2016-01-04 .. 2016-03-13),
then nine later test weeks. The daily period must be among the strongest components and, on
every test week, FreMEn (its best order by day-ahead score) and the family the model chooses
must have a lower mean absolute error than the static mean. Run with ``-s`` to see the
per-week figures.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

import numpy as np
import pytest

from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.evaluation.door import run_door, train_door
from tests.shared_data import SHARED_DATA

DOOR = SHARED_DATA / "fremen_door"
pytestmark = pytest.mark.skipif(
    not (DOOR / "training_data.txt").is_file(),
    reason="the door data (../shared/data/fremen_door) is not here",
)


@pytest.fixture(scope="module")
def training() -> np.ndarray:
    return np.loadtxt(DOOR / "training_data.txt")


@pytest.fixture(scope="module")
def trained() -> tuple[TemporalParams, TemporalState]:
    return train_door(DOOR)


@pytest.fixture(scope="module")
def result() -> dict[str, Any]:
    return run_door(DOOR)


def test_training_absorbs_every_sample_in_its_profile_bin(
    training: np.ndarray, trained: tuple[TemporalParams, TemporalState]
) -> None:
    params, state = trained
    n = len(training)
    assert n == 96_480  # 67 days of minutes (ten weeks but for a three-day gap)
    # one always-observed entry: a fixed sensor's windows, counted in the global block
    assert state.glob.n[0] == n
    assert state.obs.n[0] == 0
    assert state.cnt_profile[0].sum() == training[:, 1].sum()  # the door-open minutes
    assert state.cnt_profile[0].sum() / state.glob.n[0] == pytest.approx(0.118, abs=5e-4)
    # windows and door-open minutes per (hour of day, weekday / weekend) bin, from datetime
    windows = np.zeros(params.n_profile)
    opened = np.zeros(params.n_profile)
    days, at = np.unique(training[:, 0].astype(np.int64) // 86_400, return_inverse=True)
    weekend = np.array([datetime.fromtimestamp(int(d) * 86_400, tz=UTC).weekday() >= 5
                        for d in days])
    h = (training[:, 0].astype(np.int64) % 86_400) // 3600 + 24 * weekend[at.reshape(-1)]
    np.add.at(windows, h, 1.0)
    np.add.at(opened, h, training[:, 1])
    np.testing.assert_array_equal(state.glob.profile[0], windows)
    np.testing.assert_array_equal(state.cnt_profile[0, -1], opened)  # the "no heading" bin
    assert set(windows.tolist()) == {47 * 60.0, 20 * 60.0}  # 47 weekdays, 20 weekend days
    # every day but the first was scored against the model of the days before it
    assert state.flow_scored[0] == n - 1440


def test_daily_period_is_among_the_three_strongest(result: dict[str, Any]) -> None:
    print("\nstrongest periods (h):", result["strongest_periods_h"],
          "amplitudes:", result["strongest_amplitudes"])
    assert 24.0 in result["strongest_periods_h"][:3]


def test_static_error_is_the_error_of_the_training_mean(
    training: np.ndarray, result: dict[str, Any]
) -> None:
    mean = training[:, 1].mean()
    for week in result["weeks"]:
        truth = np.loadtxt(DOOR / f"test_data_{week['week']}.txt")
        assert week["mae_static"] == pytest.approx(np.abs(mean - truth).mean(), rel=1e-12)


def test_temporal_families_beat_the_static_mean_on_each_test_week(
    result: dict[str, Any],
) -> None:
    print(f"\nchosen {result['chosen_family']}, FreMEn order {result['fremen_order']}")
    print("week: MAE FreMEn / profile / chosen vs static")
    assert len(result["weeks"]) == 9
    for w in result["weeks"]:
        print(f"  week {w['week']}: {w['mae_fremen']:.4f} / {w['mae_profile']:.4f} / "
              f"{w['mae_chosen']:.4f} vs {w['mae_static']:.4f}")
        assert w["samples"] == 10_081
        assert w["mae_fremen"] < w["mae_static"], w["week"]
        assert w["mae_chosen"] < w["mae_static"], w["week"]
    assert result["fremen_wins"] == 9
    assert 1 <= result["fremen_order"] <= 4
    # the model's own choice is a temporal family, the best by day-ahead score
    scores = result["day_ahead_scores"]
    assert result["chosen_family"] != "static"
    assert scores[result["chosen_family"]] > scores["static"] + 3.0  # beyond family_margin
    best_fremen = max((f for f in scores if f.startswith("fremen")), key=scores.__getitem__)
    assert best_fremen == f"fremen{result['fremen_order']}"


def test_door_check_over_some_weeks() -> None:
    part = run_door(DOOR, weeks=range(1, 4))
    assert [w["week"] for w in part["weeks"]] == [1, 2, 3]
    assert part["fremen_wins"] == 3
