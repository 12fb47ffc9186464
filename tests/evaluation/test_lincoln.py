"""The Lincoln corridor protocol: data handling, the activity scores, and the real run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.evaluation import lincoln
from aion_cli.evaluation.metrics import activity_scores
from tests.shared_data import SHARED_DATA

DATA = SHARED_DATA / "lincoln"
needs_lincoln = pytest.mark.skipif(
    not (DATA / "2017-06-09.txt").exists(),
    reason="the Lincoln corridor data (../shared/data/lincoln) is not available",
)


def test_activity_scores_match_their_definitions() -> None:
    truth = np.array([10.0, 0.0, 5.0, 20.0])
    pred = np.array([8.0, 1.0, 5.0, 25.0])
    got = activity_scores(truth, pred)
    deviance = 2 * (10 * math.log(10 / 8) - 2 + 1 + 0 + 20 * math.log(20 / 25) + 5)
    assert got["poisson_deviance"] == pytest.approx(deviance)
    assert got["mae"] == pytest.approx((2 + 1 + 0 + 5) / 4)
    assert got["spearman"] == pytest.approx(1.0)  # same ranks


def test_observed_windows_cover_the_spans() -> None:
    w = 600 * 10**9
    spans = [(10 * w + 5, 12 * w), (20 * w, 20 * w + 1)]
    np.testing.assert_array_equal(lincoln.observed_windows(spans, w), [10, 11, 20])


def test_a_window_a_session_starts_or_ends_in_counts_its_recorded_share() -> None:
    """A session from 4 minutes into window 10 to 3 minutes into window 12: 0.6, 1 and 0.3
    of the three windows, as the build counts them; whole without exposure."""
    from aion_cli.engine.config import ModelConfig

    w = 600 * 10**9
    spans = [(10 * w + 240 * 10**9, 12 * w + 180 * 10**9)]
    windows = lincoln.observed_windows(spans, w)
    got = lincoln.recorded_shares(spans, windows, w, ModelConfig())
    np.testing.assert_allclose(got, [0.6, 1.0, 0.3])
    whole = lincoln.recorded_shares(spans, windows, w, ModelConfig(exposure=False))
    np.testing.assert_array_equal(whole, [1.0, 1.0, 1.0])


@needs_lincoln
def test_each_day_comes_from_the_file_holding_most_of_it() -> None:
    days = lincoln.load_days(DATA)
    assert set(lincoln.TRAIN_DAYS) | {lincoln.TEST_DAY} <= set(days)
    # 05-25 is in two files; the single-day file holds more of its detections
    assert days["2017-05-25"].source == "2017-05-25.txt"
    assert days["2017-05-24"].source == "2017-05-24_25.txt"
    for day in days.values():
        assert len(day.spans) >= 1
        t = day.batch.t_ns
        first, last = day.spans[0][0], day.spans[-1][1]
        assert first <= int(t.min())
        assert int(t.max()) < last


@needs_lincoln
def test_the_corridor_forecast_beats_the_historical_map_and_a_static_rate() -> None:
    result = lincoln.run_lincoln(DATA)
    nll = {h["model"]: h["nll_all"] for h in result.headings}
    assert nll["aion"] < nll["aion historical"]
    assert nll["aion"] < nll["time-of-day histogram"]
    assert nll["aion"] < math.log(2 * math.pi)
    act = {a["model"]: a for a in result.activity}
    # ranks the hours better than static; forecasts them closer than the per-window profile
    # by Poisson deviance (Spearman against the profiles: docs/EVALUATION.md, a near tie)
    assert act["aion"]["spearman"] > act["static"]["spearman"]
    # the rates' Spearman beside it: a static rate (one at every hour) ranks nothing, however
    # much of each hour was recorded (its totals' 0.701 is the last, part hour ranked last)
    assert act["aion"]["spearman_rate"] > 0.0
    for model in ("static", "aion static", "grid"):
        assert math.isnan(act[model]["spearman_rate"]), model
        assert act[model]["spearman"] > 0.0, model
    assert act["aion"]["poisson_deviance"] < act["hour-of-day profile"]["poisson_deviance"]
    assert act["aion"]["mae"] < act["static"]["mae"]
    assert act["aion"]["mae"] < act["hour-of-day mean"]["mae"]
    assert act["aion"]["poisson_deviance"] < act["static"]["poisson_deviance"]
    assert len(result.hours) == len(result.series["truth"]) >= 8
    assert sum(result.families["flow"].values()) > 0


@needs_lincoln
def test_two_training_days_already_forecast_the_day_not_the_static_rate() -> None:
    """Trained on two days, the second still pending in the map: its day-ahead evidence
    (scored provisionally) makes the map follow its daily shape, so the hourly totals of the
    next day are far closer than a static rate's; and one scored day is not evidence enough
    for any entry to leave its static direction histogram."""
    result = lincoln.run_lincoln(
        DATA, train_days=("2017-05-24", "2017-05-25"), test_day="2017-05-26"
    )
    assert result.to_dict()["protocol"]["test"] == "2017-05-26"
    assert result.to_dict()["protocol"]["zone"] == "Europe/London"  # the default config's
    assert result.warnings == []
    act = {a["model"]: a for a in result.activity}
    assert act["aion"]["mae"] < 0.5 * act["static"]["mae"]
    assert act["aion"]["poisson_deviance"] < 0.5 * act["static"]["poisson_deviance"]
    nll = {h["model"]: h["nll_all"] for h in result.headings}
    assert nll["aion"] <= nll["aion static"]
    assert set(result.families["direction"]) == {"static"}


@needs_lincoln
@pytest.mark.parametrize(
    ("train", "test", "message"),
    [
        (("2017-05-24",), "2017-06-10", "2017-06-10"),
        (("2017-05-24", "2017-05-25"), "2017-05-25", "not one of them"),
        ((), "2017-05-26", "needs training days"),
    ],
)
def test_a_split_of_days_the_files_do_not_hold_is_refused(
    train: tuple[str, ...], test: str, message: str
) -> None:
    from aion_cli.errors import InputError

    with pytest.raises(InputError, match=message) as err:
        lincoln.run_lincoln(DATA, train_days=train, test_day=test)
    assert "2017-05-24" in str(err.value.hint)  # the days the files hold


@needs_lincoln
def test_a_config_of_another_zone_is_the_zone_reported_and_warned() -> None:
    """``--config`` from ``aion build --print-config`` says timezone = "UTC": the map learnt
    UTC's hours while the result said 'zone Europe/London', without a word."""
    from aion_cli.engine.config import ModelConfig

    result = lincoln.run_lincoln(
        DATA, ModelConfig(), train_days=("2017-05-24",), test_day="2017-05-25"
    )
    assert result.to_dict()["protocol"]["zone"] == "UTC"
    assert [w for w in result.warnings if "timezone" in w] == [
        "the config's timezone is UTC: aion learns the corridor's hours of the day in UTC, not "
        "in Europe/London, the clock its people keep (set timezone = \"Europe/London\" in the "
        "config to learn those)"
    ]
