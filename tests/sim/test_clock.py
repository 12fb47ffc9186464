"""The scene's clock (``aion simulate --tz``): people keep their wall-clock hours across a
daylight-saving change, so in UTC their day moves by an hour; a fixed offset is the constant
shift it always was. Checked against the zone's rules worked out by hand (Europe/London: BST,
UTC+1, until 01:00 UTC on 2026-10-25, and from 01:00 UTC on 2026-03-29)."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.errors import InputError
from aion_cli.sim.clock import SceneClock
from aion_cli.sim.scenario import ScenarioConfig, build_scene, load_environment, start_ns

H = 3600.0
DAY = 86400.0


def _unix(text: str) -> float:
    return dt.datetime.fromisoformat(text).replace(tzinfo=dt.UTC).timestamp()


def test_a_fixed_offset_is_a_constant_shift() -> None:
    clock = SceneClock(dt.date(2026, 1, 5), 8 * H, utc_offset_h=9.0)
    wall = np.array([8 * H, 9.5 * H, DAY + 8 * H])
    np.testing.assert_array_equal(clock.elapsed(wall), wall - 8 * H)
    assert clock.start_unix_s() == _unix("2026-01-04T23:00:00")  # 08:00 at UTC+9
    np.testing.assert_array_equal(clock.wall(clock.elapsed(wall)), wall)


def test_when_the_clocks_go_back_nine_on_the_wall_is_an_hour_later_in_utc() -> None:
    """Thursday 2026-10-22 midnight, Europe/London: 09:00 on the Friday is 08:00 UTC (BST),
    09:00 on the Monday after the change 09:00 UTC; the Sunday has 25 hours."""
    clock = SceneClock(dt.date(2026, 10, 22), 0.0, timezone="Europe/London")
    friday, monday = 1 * DAY + 9 * H, 4 * DAY + 9 * H
    unix = clock.wall_to_unix_s([friday, monday])
    assert unix.tolist() == [_unix("2026-10-23T08:00:00"), _unix("2026-10-26T09:00:00")]
    assert clock.start_unix_s() == _unix("2026-10-21T23:00:00")
    sunday, next_day = 3 * DAY, 4 * DAY  # local midnights
    lengths = np.diff(clock.elapsed([sunday, next_day]))
    assert lengths.tolist() == [25 * H]
    # the inverse, away from the repeated hour
    wall = np.array([friday, monday, 2 * DAY + 13.25 * H])
    np.testing.assert_allclose(clock.wall(clock.elapsed(wall)), wall)


def test_when_the_clocks_go_forward_the_day_has_23_hours_and_time_never_runs_back() -> None:
    clock = SceneClock(dt.date(2026, 3, 28), 0.0, timezone="Europe/London")
    saturday, sunday, monday = 0.0, DAY, 2 * DAY
    assert np.diff(clock.elapsed([sunday, monday])).tolist() == [23 * H]
    assert np.diff(clock.elapsed([saturday, sunday])).tolist() == [24 * H]
    # 01:00-02:00 on the Sunday does not exist on the wall: it runs forward, not back
    wall = DAY + np.arange(0.0, 4 * H, 60.0)
    elapsed = clock.elapsed(wall)
    assert (np.diff(elapsed) >= 0).all()
    assert clock.elapsed([DAY + 3 * H])[0] - clock.elapsed([DAY + 0.5 * H])[0] <= 2.5 * H


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(0.0, 30 * DAY, allow_nan=False), min_size=1, max_size=40),
    st.sampled_from(["Europe/London", "America/New_York", "Australia/Lord_Howe", "UTC"]),
    st.dates(dt.date(2024, 1, 1), dt.date(2027, 12, 31)),
)
def test_elapsed_time_never_decreases_with_the_wall(
    walls: list[float], zone: str, day: dt.date
) -> None:
    clock = SceneClock(day, 0.0, timezone=zone)
    wall = np.sort(np.asarray(walls))
    elapsed = clock.elapsed(wall)
    assert (np.diff(elapsed) >= 0).all()
    # and differs from the wall time by the zone's offsets only (at most a day either way)
    assert (np.abs(elapsed - wall) <= DAY).all()


def test_the_simulated_office_keeps_its_hours_on_the_wall() -> None:
    """Six days from Thursday 2026-10-22 in Europe/London, a fixed sensor seeing everyone:
    the first detection of each weekday is about 08:30 on the wall, so about 07:30 UTC before
    the change and 08:30 UTC after it."""
    config = ScenarioConfig(
        days=6.0, robot="fixed", start="2026-10-22", timezone="Europe/London", agents=6
    )
    config.validate()
    data = build_scene(config, load_environment(config), 0)
    t_ns = data.t0_ns + data.obs.tick * data.dt_ns
    utc = [dt.datetime.fromtimestamp(t / 1e9, dt.UTC) for t in t_ns.tolist()]
    first: dict[dt.date, float] = {}
    for d in utc:
        first.setdefault(d.date(), d.hour + d.minute / 60.0)
    before = [first[dt.date(2026, 10, 22)], first[dt.date(2026, 10, 23)]]
    after = [first[dt.date(2026, 10, 26)], first[dt.date(2026, 10, 27)]]
    assert all(6.5 <= h < 8.0 for h in before), before  # arrivals 07:30-09:45 BST
    assert all(7.5 <= h < 9.0 for h in after), after  # the same hours GMT
    assert np.mean(after) - np.mean(before) == pytest.approx(1.0, abs=0.5)
    assert data.t0_ns == start_ns("2026-10-22", 0.0, "Europe/London")
    assert data.t0_ns == round(_unix("2026-10-21T23:00:00") * 1e9)


def test_tz_and_utc_offset_together_are_refused() -> None:
    with pytest.raises(InputError, match="--tz or --utc-offset"):
        ScenarioConfig(timezone="Europe/London", utc_offset_h=1.0).validate()
    with pytest.raises(InputError, match="Mars/Olympus"):
        ScenarioConfig(timezone="Mars/Olympus").validate()
