"""FreMEn's clock (``ModelConfig.fremen_clock``): UTC plus the zone's daylight-saving shift, so a
routine learnt by FreMEn keeps its local hour across clock changes; UTC and fixed-offset maps
keep the numbers (and stored config) of maps built before the clock existed, and an older map
in a zone with daylight saving keeps its UTC clock."""

from __future__ import annotations

from datetime import datetime, timedelta
from types import SimpleNamespace
from zoneinfo import ZoneInfo

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.temporal import model as temporal
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.temporal.pending import DayWindows
from aion_cli.engine.windows import to_model_seconds
from aion_cli.errors import ConfigError
from aion_cli.merge_config import check_compatible

S = 1_000_000_000
WINDOW_NS = 600 * S
BERLIN = ZoneInfo("Europe/Berlin")


def _local_ns(day: datetime, hour: int, minute: int = 0) -> int:
    """UNIX ns of ``hour:minute`` Berlin wall-clock time on ``day``."""
    return int(day.replace(hour=hour, minute=minute, tzinfo=BERLIN).timestamp()) * S


def _rush_predictor(config: ModelConfig, first: datetime, days: int) -> temporal.Predictor:
    """A fixed sensor's one place, 6 detections in every window between 08:00 and 09:00 Berlin
    time (the local clock, whatever the offset), none otherwise, learnt over ``days`` days."""
    params = TemporalParams.from_config(config)
    start = _local_ns(first, 0) // WINDOW_NS
    end = _local_ns(first + timedelta(days=days), 0) // WINDOW_NS
    windows = np.arange(start, end, dtype=np.int64)
    centres = windows * WINDOW_NS + WINDOW_NS // 2
    local_hour = np.array(
        [datetime.fromtimestamp(int(c) / S, BERLIN).hour for c in centres.tolist()]
    )
    has = np.flatnonzero(local_hour == 8)
    values = np.zeros((has.size, params.values))
    values[:, -1] = 6.0
    day = DayWindows(
        windows, np.ones(windows.size, bool), np.zeros(0, np.int64), np.zeros(0, np.int64),
        np.zeros(has.size, np.int64), has.astype(np.int64), values,
    )
    state = temporal.empty_state(params, 1)
    one = np.zeros(1, np.int64)
    temporal.learn(params, state, day, one, one, 1, WINDOW_NS)
    return temporal.Predictor.of(params, state, one, one, 1)


def _peak_hour(pred: temporal.Predictor, day: datetime) -> int:
    """The Berlin hour (at half past) with the highest predicted flow on ``day``, 05..11."""
    hours = list(range(5, 12))
    t = np.array([_local_ns(day, h, 30) for h in hours], np.int64)
    flow = pred.flows(np.zeros(t.size, np.int64), t)
    return hours[int(np.argmax(flow))]


FREMEN_ONLY = ModelConfig(timezone="Europe/Berlin", families=("fremen",), reconcile=False)


def test_a_rush_learnt_in_winter_keeps_its_local_hour_after_the_spring_change() -> None:
    pred = _rush_predictor(FREMEN_ONLY, datetime(2026, 3, 1), 28)  # before 29 March
    assert _peak_hour(pred, datetime(2026, 3, 16)) == 8
    assert _peak_hour(pred, datetime(2026, 4, 6)) == 8  # UTC phases: 9
    assert _peak_hour(pred, datetime(2026, 11, 2)) == 8


def test_a_rush_learnt_in_summer_keeps_its_local_hour_after_the_autumn_change() -> None:
    pred = _rush_predictor(FREMEN_ONLY, datetime(2026, 6, 1), 28)
    assert _peak_hour(pred, datetime(2026, 6, 29)) == 8
    assert _peak_hour(pred, datetime(2026, 11, 2)) == 8  # UTC phases: 7


def test_a_rush_learnt_across_the_spring_change_peaks_at_its_local_hour_on_both_sides() -> None:
    pred = _rush_predictor(FREMEN_ONLY, datetime(2026, 3, 15), 28)  # 29 March in the middle
    assert _peak_hour(pred, datetime(2026, 3, 16)) == 8
    assert _peak_hour(pred, datetime(2026, 4, 13)) == 8


def test_an_older_map_keeps_fremen_on_utc() -> None:
    """A stored config without the key (a map built before it) in a zone with daylight saving
    reads as the UTC clock, writes it back so when continued, and predicts as it always did:
    the winter rush an hour late in April."""
    stored = FREMEN_ONLY.to_dict()
    assert stored["fremen_clock"] == "standard"  # new builds record the new clock
    del stored["fremen_clock"]
    old = ModelConfig.from_stored(stored)
    assert old.fremen_clock == "utc"
    assert ModelConfig.from_stored(old.to_dict()) == old  # continued: still the old clock
    t = np.array([_local_ns(datetime(2026, 4, 6), 8)], np.int64)
    np.testing.assert_array_equal(TemporalParams(old).model_seconds(t), to_model_seconds(t))
    pred = _rush_predictor(old, datetime(2026, 3, 1), 28)
    assert _peak_hour(pred, datetime(2026, 4, 6)) == 9


@pytest.mark.parametrize("zone", ["UTC", "+05:30", "UTC-03:00"])
def test_utc_and_fixed_offset_maps_keep_their_numbers_and_stored_config(zone: str) -> None:
    """No daylight saving: FreMEn's times are exactly the UTC model seconds, and the stored
    config has no new key (a map's bytes are those of a map built before it)."""
    t = np.arange(_local_ns(datetime(2026, 3, 28), 0), _local_ns(datetime(2026, 3, 31), 0),
                  7 * 60 * S + 123, dtype=np.int64)
    for clock in ("standard", "utc"):
        config = ModelConfig(timezone=zone, fremen_clock=clock)
        np.testing.assert_array_equal(
            TemporalParams(config).model_seconds(t), to_model_seconds(t)
        )
        assert "fremen_clock" not in config.to_dict()
        assert ModelConfig.from_stored(config.to_dict()) == ModelConfig(timezone=zone)


def test_the_clock_is_utc_plus_the_daylight_saving_shift() -> None:
    """An independent reading: ``datetime.dst()`` per time, around both 2026 changes."""
    params = TemporalParams(FREMEN_ONLY)
    times = [datetime(2026, 3, 29, 0, 0) + timedelta(minutes=10 * k) for k in range(20)]
    times += [datetime(2026, 10, 25, 0, 0) + timedelta(minutes=10 * k) for k in range(20)]
    utc = np.array([int(t.replace(tzinfo=ZoneInfo("UTC")).timestamp()) * S for t in times])
    shift = [
        datetime.fromtimestamp(int(u) / S, BERLIN).dst() or timedelta(0) for u in utc.tolist()
    ]
    expected = to_model_seconds(utc) + np.array([d.total_seconds() for d in shift])
    np.testing.assert_array_equal(params.model_seconds(utc), expected)
    assert {d.total_seconds() for d in shift} == {0.0, 3600.0}


def _map(name: str, config: ModelConfig, first: datetime, last: datetime) -> SimpleNamespace:
    return SimpleNamespace(
        name=name,
        head=SimpleNamespace(config=config),
        manifest=SimpleNamespace(
            timezone=config.timezone, observation="fixed",
            start_ns=_local_ns(first, 0), end_ns=_local_ns(last, 0),
        ),
    )


def test_merging_an_older_map_is_refused_only_where_its_clock_matters() -> None:
    """An older Berlin map that held summer time has sums on UTC that the local clock would
    misread: refused. One of winter days only has the same sums on either clock: merged on the
    new clock. UTC maps old and new: the same map config, nothing to take."""
    old_berlin = ModelConfig.from_stored(
        {k: v for k, v in FREMEN_ONLY.to_dict().items() if k != "fremen_clock"}
    )
    winter = (datetime(2026, 1, 5), datetime(2026, 3, 28))
    summer = (datetime(2026, 3, 20), datetime(2026, 4, 2))  # the clocks go forward 29 March
    new = _map("new.aion", FREMEN_ONLY, *winter)
    refused = r"cannot merge old\.aion with the other maps: its FreMEn phases follow UTC"
    with pytest.raises(ConfigError, match=refused):
        check_compatible([new, _map("old.aion", old_berlin, *summer)])
    with pytest.raises(ConfigError, match=r"cannot merge old2\.aion with"):
        check_compatible(
            [_map("old.aion", old_berlin, *winter), new, _map("old2.aion", old_berlin, *summer)]
        )
    taken = check_compatible([_map("old.aion", old_berlin, *winter), new])
    assert taken == FREMEN_ONLY
    utc = ModelConfig(families=("fremen",))
    old_utc = ModelConfig.from_stored(utc.to_dict())
    both = [_map("new.aion", utc, *summer), _map("old.aion", old_utc, *summer)]
    assert check_compatible(both) is None
