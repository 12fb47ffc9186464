"""The day a forecast note names beside a time printed in another zone than the map's
(``aion_cli.forecast_notes.unseen_day``'s ``shown``)."""

from __future__ import annotations

from aion_cli.forecast_notes import forecast_notes, series_notes
from aion_cli.manifest import Manifest
from tests.test_forecast_notes import DAY_NS, HOUR_NS, MONDAY, _week_of


def test_the_day_is_named_with_the_maps_zone_where_the_time_shown_is_another_day() -> None:
    """A UTC map of weekdays asked about Saturday 20:00 UTC with --tz Asia/Tokyo sees the time
    printed as Sunday 05:00: its note names the Saturday as the map's clock has it, with that
    clock ("Saturday (UTC time)"; it had said "Saturday" beside a Sunday). Shown in UTC, or
    at a Tokyo time on the same day of the week, the day needs no zone; a Tokyo map shown in
    Tokyo names none either (it had named its zone at every time)."""
    from aion_cli.timeparse import resolve_zone

    tokyo = resolve_zone("Asia/Tokyo")
    saturday_20_utc = MONDAY + 5 * DAY_NS + 20 * HOUR_NS  # Sunday 05:00 in Tokyo
    weekdays = _week_of(5)
    (line,) = forecast_notes(weekdays, saturday_20_utc, shown=tokyo)
    assert "so a forecast for a Saturday (UTC time) follows the weekdays'" in line
    (plain,) = forecast_notes(weekdays, saturday_20_utc, shown=resolve_zone("UTC"))
    assert "so a forecast for a Saturday follows the weekdays'" in plain
    assert forecast_notes(weekdays, saturday_20_utc) == [plain]  # shown: UTC by default
    saturday_10_utc = saturday_20_utc - 10 * HOUR_NS  # Saturday 19:00 in Tokyo
    assert forecast_notes(weekdays, saturday_10_utc, shown=tokyo)[0].count("(UTC time)") == 0
    # a series shown in Tokyo that reaches that Saturday names it the same way
    friday_20_utc = saturday_20_utc - DAY_NS
    assert series_notes(weekdays, [friday_20_utc, saturday_20_utc], shown=tokyo) == [line]
    in_tokyo = _week_of(5, zone="Asia/Tokyo")
    in_tokyo = Manifest({}, in_tokyo.config, start_ns=MONDAY - 9 * HOUR_NS,
                        end_ns=MONDAY - 9 * HOUR_NS + 5 * DAY_NS, families=in_tokyo.families)
    (own,) = forecast_notes(in_tokyo, friday_20_utc, shown=tokyo)  # Saturday 05:00 in Tokyo
    assert "so a forecast for a Saturday follows the weekdays'" in own
