"""Which profile bins a map observed, per time (``aion_cli.bins_observed``): its hour of the
day on its own kind of day (``bin_observed``) and on any kind (``hour_observed``)."""

from __future__ import annotations

from datetime import UTC, datetime

from aion_cli.bins_observed import bin_observed, hour_observed, observed_hours
from aion_cli.manifest import Manifest

HOUR_NS = 3600 * 10**9
MONDAY = int(datetime(2026, 1, 5, tzinfo=UTC).timestamp()) * 10**9  # a Monday, 00:00 UTC
WEEK = [MONDAY + h * HOUR_NS for h in range(7 * 24)]  # every hour of that week


def _weekday_hour(t: int) -> tuple[int, int]:
    when = datetime.fromtimestamp(t // 10**9, UTC)
    return when.weekday(), when.hour


def _map(profile: str, bins: list[int], zone: str = "UTC") -> Manifest:
    return Manifest({}, {"profile": profile, "timezone": zone},
                    families={"flow": {"profile": 3}, "observed_bins": bins})


def test_a_map_of_weekdays_observed_no_weekend_hour_though_it_observed_those_hours() -> None:
    """Weekdays 09:00-18:00 observed (bins 9..17 of the weekday kind): a Saturday's 10:00 is
    a bin never observed, its hour observed; a night hour is observed on no kind of day."""
    manifest = _map("day_weekend", list(range(9, 18)))
    own, hour = bin_observed(manifest, WEEK), hour_observed(manifest, WEEK)
    assert own is not None
    assert hour is not None
    for t, seen, any_day in zip(WEEK, own, hour, strict=True):
        weekday, h = _weekday_hour(t)
        assert any_day == (9 <= h < 18)
        assert seen == (weekday < 5 and 9 <= h < 18)


def test_the_weekly_profile_tells_each_day_of_the_week_apart() -> None:
    """Observed Tuesdays 08:00-09:00 only (bin 24 + 8): Monday 08:00 is another kind of day."""
    manifest = _map("week", [24 + 8])
    own = bin_observed(manifest, WEEK)
    assert own is not None
    assert [t for t, seen in zip(WEEK, own, strict=True) if seen] == [MONDAY + 32 * HOUR_NS]
    assert hour_observed(manifest, [MONDAY + 8 * HOUR_NS]) == [True]


def test_the_map_zone_tells_the_kind_of_day_and_older_maps_say_nothing() -> None:
    """Friday 20:00 UTC is Saturday 05:00 in Tokyo: a map of Tokyo weekdays at 05:00 never
    observed it; the hour-of-day profile has one kind of day; a map without the list, None."""
    friday_20 = MONDAY + (4 * 24 + 20) * HOUR_NS
    assert bin_observed(_map("day_weekend", [5], "Asia/Tokyo"), [friday_20]) == [False]
    assert bin_observed(_map("day_weekend", [5], "UTC"), [friday_20 - 15 * HOUR_NS]) == [True]
    day = _map("day", [10])
    assert bin_observed(day, WEEK) == hour_observed(day, WEEK)
    older = Manifest({}, {}, families={"flow": {"profile": 1}})
    assert bin_observed(older, WEEK) is None
    assert hour_observed(older, WEEK) is None
    # a bin past the profile's (an untrusted file's) is left out, as aion info leaves it out:
    # 58 is no hour 10:00 of a map of weekdays and weekends
    junk = _map("day_weekend", [9, 48 + 10])
    assert hour_observed(junk, [MONDAY + 9 * HOUR_NS, MONDAY + 10 * HOUR_NS]) == [True, False]
    assert observed_hours(junk.families, junk.config, None) == (
        "weekdays 09:00-10:00; weekends none (UTC)"
    )


def test_the_hours_named_as_observed_leave_out_a_bin_past_the_profile() -> None:
    """The forecast notes name the hours a map observed (``hours_of``) beside the hour no
    log observed (``hour_observed``): both leave bin 58 out of a map of weekdays and
    weekends, so the note on Monday 10:00 does not say the map observed 10:00 too."""
    from aion_cli.bins_observed import hours_of
    from aion_cli.forecast_notes import forecast_notes

    junk = _map("day_weekend", [9, 48 + 10])
    assert hours_of(junk, 24) == [9]
    notes = " ".join(forecast_notes(junk, MONDAY + 10 * HOUR_NS))
    assert "10:00-11:00 (UTC) on any day (the map observed 09:00-10:00)" in notes
