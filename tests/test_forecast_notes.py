"""The notes beside a forecast's time (``aion_cli.forecast_notes``)."""

from __future__ import annotations

from aion_cli.forecast_notes import forecast_notes, series_notes
from aion_cli.manifest import Manifest

DAY_NS = 86_400 * 10**9
START = 1_700_000_000 * 10**9  # 2023-11-14 22:13:20 UTC
END = START + 3 * DAY_NS


def _manifest(
    flow: dict[str, int] | None, reconciled: bool = False, days: int = 3
) -> Manifest:
    families = {} if flow is None else {"flow": flow, "reconciled": reconciled, "scored_days": days}
    # the hour-of-day profile keeps no day kinds apart: no note about unseen weekdays here
    return Manifest({}, {"profile": "day"}, start_ns=START, end_ns=END, families=families)


def test_a_map_whose_entries_all_forecast_statically_says_so() -> None:
    (line,) = forecast_notes(_manifest({"static": 12}, days=1), START + DAY_NS)
    assert line.startswith("every entry forecasts its static rate, whatever the time")
    assert "has 1 scored day," in line
    assert forecast_notes(_manifest({"static": 12, "profile": 1}), START) == []
    # a map-wide rhythm scales static entries: the forecast changes with the time
    assert forecast_notes(_manifest({"static": 12}, reconciled=True), START) == []
    assert forecast_notes(_manifest(None), START) == []  # a map without the tally


def test_static_after_enough_days_says_no_rhythm_won_and_why_it_may_not_show() -> None:
    """With scored days enough, more days is not the advice: no rhythm won. A fixed sensor
    that observed a small share of its span (a tracker silent when nobody is there, so the
    empty hours were never seen) is pointed to build --observed; a robot's map is not."""
    families = {"flow": {"static": 7}, "reconciled": False, "scored_days": 6}
    silent = Manifest({}, {"profile": "day"}, start_ns=START, end_ns=END, families=families,
                      observation="fixed sensor over the 168 windows with messages (28.0 h "
                      "of a 155.0 h span)")
    (line,) = forecast_notes(silent, START + DAY_NS)
    assert line.startswith("every entry forecasts its static rate, whatever the time: on the "
                           "map's 6 scored days no daily or weekly rhythm forecast the next day "
                           "better than that rate (its fixed sensor observed 18% of the time")
    assert line.endswith("declare the spans it was recording with aion build --observed)")
    robot = Manifest({}, {"profile": "day"}, start_ns=START, end_ns=END, families=families,
                     observation="tf map->base_link")
    (plain,) = forecast_notes(robot, START + DAY_NS)
    assert plain.endswith("better than that rate")
    steady = Manifest({}, {"profile": "day"}, start_ns=START, end_ns=END, families=families,
                      observation="fixed sensor over the 1,000 windows with messages (166.7 h "
                      "of a 170.0 h span)")
    assert forecast_notes(steady, START + DAY_NS) == [plain]
    # logs recorded apart (days between the files): measured against the logs' own time
    apart = Manifest({}, {"profile": "day"}, start_ns=START, end_ns=END, families=families,
                     observation=silent.observation, counts={"recording_windows": 180})
    assert forecast_notes(apart, START + DAY_NS) == [plain]  # 168 of 180 windows
    quiet = Manifest({}, {"profile": "day"}, start_ns=START, end_ns=END, families=families,
                     observation=silent.observation, counts={"recording_windows": 840})
    (line,) = forecast_notes(quiet, START + DAY_NS)
    assert "(its fixed sensor observed 20% of its logs' time: only the windows" in line


def test_times_far_from_the_data_are_named() -> None:
    timed = _manifest({"shape": 5})
    assert forecast_notes(timed, END + 6 * DAY_NS) == []  # the week after the data
    (after,) = forecast_notes(timed, END + 30 * DAY_NS)
    assert after == (
        "this time is 4 weeks after the map's data (2023-11-14 to 2023-11-17): the forecast "
        "repeats the rhythm the map learnt and knows nothing of what changed since"
    )
    (before,) = forecast_notes(timed, START - 8 * DAY_NS - 5 * 3600 * 10**9)
    assert before.startswith("this time is 8 days before the map's data")
    assert before.endswith("repeats the rhythm the map learnt")
    # the week before the data is as near it as the week after: no note (52 seconds before
    # the first detection, or the night before, had been said to lie before the data)
    for ahead_ns in (1, 52 * 10**9, 5 * 3600 * 10**9, 6 * DAY_NS, 7 * DAY_NS):
        assert forecast_notes(timed, START - ahead_ns) == []
    (week,) = forecast_notes(timed, START - 7 * DAY_NS - 3600 * 10**9)
    assert week.startswith("this time is 7 days before the map's data")
    years = forecast_notes(timed, END + 800 * DAY_NS)
    assert "2.2 years after" in years[0]
    # a static map has no rhythm to repeat: only where the time lies
    static, where = forecast_notes(_manifest({"static": 3}), END + 9 * DAY_NS)
    assert static.startswith("every entry forecasts its static rate")
    assert where == "this time is 9 days after the map's data (2023-11-14 to 2023-11-17)"
    # the data's days in the map's zone: 22:13 UTC on the 14th is the 15th in Kolkata
    kolkata = Manifest({}, {"profile": "day"}, start_ns=START, end_ns=END,
                       families={"flow": {"shape": 5}}, timezone="Asia/Kolkata")
    (local,) = forecast_notes(kolkata, END + 30 * DAY_NS)
    assert "(2023-11-15 to 2023-11-18)" in local
    one_day = Manifest({}, {"profile": "day"}, start_ns=START, end_ns=START + 3600 * 10**9)
    assert forecast_notes(one_day, START - 10 * DAY_NS) == [
        "this time is 10 days before the map's data (2023-11-14): the forecast repeats the "
        "rhythm the map learnt"
    ]


MONDAY = 1_767_571_200 * 10**9  # 2026-01-05 00:00 UTC, a Monday
HOUR_NS = 3600 * 10**9


def _week_of(days: float, profile: str = "day_weekend", zone: str = "UTC") -> Manifest:
    """A map with a rhythm whose data span starts Monday 00:00 and lasts ``days``."""
    config = {"profile": profile, "timezone": zone}
    return Manifest({}, config, start_ns=MONDAY, end_ns=MONDAY + round(days * DAY_NS),
                    families={"flow": {"shape": 4}, "scored_days": 3})


def test_a_kind_of_day_the_map_never_saw_is_named() -> None:
    weekdays = _week_of(5)  # Monday 00:00 to Saturday 00:00: the weekdays only
    saturday = MONDAY + 5 * DAY_NS + 10 * HOUR_NS
    assert forecast_notes(weekdays, saturday) == [
        "the map's data (Mon 2026-01-05 to Fri 2026-01-09) holds no weekend day: its "
        "hour-of-day profiles know weekdays only, so a forecast for a Saturday follows the "
        "weekdays' rhythm and level"
    ]
    assert forecast_notes(weekdays, MONDAY + 2 * DAY_NS) == []  # a Wednesday: seen
    assert forecast_notes(_week_of(6), saturday) == []  # the span holds Saturday
    weekend = Manifest({}, {}, start_ns=MONDAY + 5 * DAY_NS, end_ns=MONDAY + 7 * DAY_NS,
                       families={"flow": {"profile": 2}})
    (line,) = forecast_notes(weekend, MONDAY + 8 * DAY_NS)
    assert line.endswith("know weekends only, so a forecast for a Tuesday follows the "
                         "weekends' rhythm and level")
    # the weekly profile names the day; a whole week leaves nothing unseen
    (tuesday,) = forecast_notes(_week_of(1, "week"), MONDAY + 8 * DAY_NS)
    assert "holds no Tuesday: its hour-of-week profiles have no Tuesday of their own" in tuesday
    assert forecast_notes(_week_of(7, "week"), MONDAY + 12 * DAY_NS) == []
    assert forecast_notes(_week_of(2, "day"), saturday) == []  # no day kinds to tell apart
    # the map's zone decides the day: Friday 23:30 UTC is Saturday in Tokyo
    late_friday = MONDAY + 4 * DAY_NS + 23 * HOUR_NS + 1800 * 10**9
    assert forecast_notes(_week_of(5), late_friday) == []
    (tokyo,) = forecast_notes(_week_of(4.5, zone="Asia/Tokyo"), late_friday)
    assert "a forecast for a Saturday" in tokyo
    # a static map says it is static, not which days it lacks
    static = Manifest({}, {}, start_ns=MONDAY, end_ns=MONDAY + 3 * DAY_NS,
                      families={"flow": {"static": 3}, "scored_days": 1})
    (only,) = forecast_notes(static, saturday)
    assert only.startswith("every entry forecasts its static rate")


def test_an_hour_no_log_observed_is_named() -> None:
    """A map that observed weekday hours 09-12 and 13-18 (bins 9..11, 13..17 of the default
    profile) and one Saturday morning hour (bin 24 + 10): 03:00 on any day and 12:00 on a
    weekday were never observed; 10:00 on a Sunday was (on the Saturday: the weekday hours
    are another kind of day, which the unseen-day note covers)."""
    observed = [9, 10, 11, 13, 14, 15, 16, 17, 34]
    manifest = Manifest({}, {"timezone": "UTC"}, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
                        families={"flow": {"profile": 4}, "scored_days": 5,
                                  "observed_bins": observed})
    (night,) = forecast_notes(manifest, MONDAY + 3 * HOUR_NS + 600 * 10**9)
    assert night == (
        "no log observed 03:00-04:00 (UTC) on any day (the map observed 09:00-12:00, "
        "13:00-18:00): the forecast at this hour is extrapolated from the hours observed, "
        "not measured: every entry at its static rate, its mean per window over all the hours "
        "observed (one busy hour raises it above the quiet ones)"
    )
    (noon,) = forecast_notes(manifest, MONDAY + 12 * HOUR_NS)
    assert noon.startswith("no log observed 12:00-13:00 (UTC)")
    assert forecast_notes(manifest, MONDAY + 9 * HOUR_NS) == []
    assert forecast_notes(manifest, MONDAY + 6 * DAY_NS + 10 * HOUR_NS) == []  # Sunday 10:00
    # the map's zone tells the hour: 03:00 UTC is 12:00 in Tokyo, which was not observed
    # either, while 02:00 UTC is 11:00 there, which was
    tokyo = Manifest({}, {"timezone": "Asia/Tokyo"}, families=manifest.families)
    (local,) = forecast_notes(tokyo, MONDAY + 3 * HOUR_NS)
    assert local.startswith("no log observed 12:00-13:00 (Asia/Tokyo)")
    assert forecast_notes(tokyo, MONDAY + 2 * HOUR_NS) == []
    # half-hour bins read as such; a map without the list (an older map) says nothing
    halves = Manifest({}, {"profile": "day", "profile_bin_s": 1800.0},
                      families={"flow": {"profile": 1}, "observed_bins": [18, 19, 20]})
    (half,) = forecast_notes(halves, MONDAY + 8 * HOUR_NS)
    assert "08:00-08:30" in half
    assert "(the map observed 09:00-10:30)" in half
    older = Manifest({}, {}, families={"flow": {"profile": 1}})
    assert forecast_notes(older, MONDAY + 3 * HOUR_NS) == []


def test_the_hours_observed_read_per_kind_of_day() -> None:
    from aion_cli.forecast_notes import observed_hours

    families = {"observed_bins": [9, 10, 11, 13, 14, 15, 16, 17, 34]}
    assert observed_hours(families, {}, "UTC") == (
        "weekdays 09:00-12:00, 13:00-18:00; weekends 10:00-11:00 (UTC)"
    )
    # the weekly profile groups days with the same hours, in order
    week = {"observed_bins": [24 * d + 8 for d in range(5)]}
    assert observed_hours(week, {"profile": "week"}, "Europe/London") == (
        "Mon, Tue, Wed, Thu, Fri 08:00-09:00; Sat, Sun none (Europe/London)"
    )
    assert observed_hours({"observed_bins": []}, {"profile": "day"}, None) == "none (UTC)"
    assert observed_hours({}, {}, "UTC") is None  # an older map


def test_a_series_names_every_hour_no_log_observed() -> None:
    from aion_cli.forecast_notes import hour_observed, series_notes

    manifest = Manifest({}, {"timezone": "UTC"}, start_ns=MONDAY, end_ns=MONDAY + 5 * DAY_NS,
                        families={"flow": {"profile": 4}, "scored_days": 4,
                                  "observed_bins": [9, 10, 11, 13]})
    times = [MONDAY + 7 * DAY_NS + h * HOUR_NS for h in range(8, 15)]  # the next Monday
    assert hour_observed(manifest, times) == [False, True, True, True, False, True, False]
    assert series_notes(manifest, times) == [
        "3 of the 7 times fall in hours no log observed on any day (08:00-09:00, "
        "12:00-13:00, 14:00-15:00 UTC; the map observed 09:00-12:00, 13:00-14:00): their "
        "forecast is extrapolated from the hours observed, not measured: every entry at its "
        "static rate, its mean per window over all the hours observed (one busy hour raises "
        "it above the quiet ones)"
    ]
    # the first time's other notes stay; a series within the observed hours adds none
    assert series_notes(manifest, times[1:4]) == []
    assert hour_observed(Manifest({}, {}, families={}), times) is None


def test_a_damaged_list_of_observed_hours_is_read_safely() -> None:
    """A map file is untrusted input: values that are not whole bin numbers are left out,
    never a crash (``int("x")``, ``int(None)``) or a wrong hour (``True`` read as 1)."""
    from aion_cli.forecast_notes import hour_observed, observed_hours

    junk = {"flow": {"profile": 1}, "observed_bins": ["x", None, True, 9.5, [1], -3, 10]}
    manifest = Manifest({}, {"timezone": "UTC", "profile": "day"}, families=junk)
    assert hour_observed(manifest, [MONDAY + 10 * HOUR_NS, MONDAY + HOUR_NS]) == [True, False]
    assert observed_hours(junk, {"profile": "day"}, "UTC") == "10:00-11:00 (UTC)"
    (line,) = forecast_notes(manifest, MONDAY + HOUR_NS)
    assert "(the map observed 10:00-11:00)" in line
    not_a_list = Manifest({}, {}, families={"flow": {"profile": 1}, "observed_bins": "9"})
    assert forecast_notes(not_a_list, MONDAY + HOUR_NS) == []


def test_a_static_only_model_says_so_not_that_no_rhythm_won() -> None:
    """A map built with ``families = ["static"]`` (every temporal family switched off) tried
    no rhythm: its note names the configuration, not scored days on which no rhythm beat the
    rate, and says whether its directions are the raw proportions ``--historical`` shows
    (``direction_prior = 0``) or pooled toward the neighbourhood's."""
    families = {"flow": {"static": 7}, "reconciled": False, "scored_days": 13}
    pooled = Manifest({}, {"profile": "day", "families": ["static"], "direction_prior": 10.0},
                      start_ns=START, end_ns=END, families=families)
    (line,) = forecast_notes(pooled, START + DAY_NS)
    assert line.startswith("every entry forecasts its static rate, whatever the time: the "
                           'map\'s model has the static family only (families = ["static"])')
    assert "scored days" not in line
    assert "better than that rate" not in line
    assert "flows are those of --historical" in line
    assert "pooled toward their neighbourhood's (direction_prior = 10)" in line
    auto = Manifest({}, {"profile": "day", "families": ["static"], "direction_prior": "auto"},
                    start_ns=START, end_ns=END, families=families)
    (line,) = forecast_notes(auto, START + DAY_NS)
    assert ('pooled toward their neighbourhood\'s (direction_prior = "auto": its strength '
            "estimated from the map)") in line
    raw = Manifest({}, {"profile": "day", "families": ["static"], "direction_prior": 0.0},
                   start_ns=START, end_ns=END, families=families)
    (line,) = forecast_notes(raw, START + DAY_NS)
    assert line.endswith("the forecast is the historical map (--historical) at every time")
    # a model with temporal families keeps the scored-days reason
    timed = Manifest({}, {"profile": "day", "families": ["static", "profile"]},
                     start_ns=START, end_ns=END, families=families)
    (line,) = forecast_notes(timed, START + DAY_NS)
    assert "on the map's 13 scored days no daily or weekly rhythm" in line


def test_a_kind_of_day_the_span_holds_but_no_log_observed_is_named() -> None:
    """Three weeks of a fixed sensor whose tracker is silent when nobody is there, people on
    weekdays only: the span holds six weekend days, but no window of theirs was observed
    (``observed_bins``: weekday hours only), so a Saturday forecast follows the weekdays'
    hours at their level — said, with the way to declare the silent spans (here: the sensor
    observed 71 % of its span, every weekday window); a map that observed weekend hours
    (empty ones) says nothing, and a robot's map gets no --observed advice."""
    weekday_hours = list(range(24))  # every weekday hour observed (bins 0..23)
    silent = Manifest(
        {}, {"profile": "day_weekend"}, start_ns=MONDAY, end_ns=MONDAY + 21 * DAY_NS,
        families={"flow": {"shape": 4}, "scored_days": 20, "observed_bins": weekday_hours},
        observation="fixed sensor over the 2,160 windows with messages (360.0 h of a 504.0 h "
        "span)",
    )
    saturday = MONDAY + 26 * DAY_NS + 9 * HOUR_NS
    (line,) = forecast_notes(silent, saturday)
    assert line.startswith(
        "the map observed no weekend day (its data, Mon 2026-01-05 to Sun 2026-01-25, holds "
        "6, but no log recorded a window of them): its hour-of-day profiles know weekdays "
        "only, so a forecast for a Saturday follows the weekdays' rhythm and level"
    )
    assert line.endswith("declare the spans it was recording with aion build --observed")
    assert forecast_notes(silent, MONDAY + 22 * DAY_NS + 9 * HOUR_NS) == []  # a Tuesday
    both = Manifest(
        {}, {"profile": "day_weekend"}, start_ns=MONDAY, end_ns=MONDAY + 21 * DAY_NS,
        families={"flow": {"shape": 4}, "scored_days": 20,
                  "observed_bins": list(range(48))},
        observation=silent.observation,
    )
    assert forecast_notes(both, saturday) == []
    robot = Manifest(
        {}, {"profile": "day_weekend"}, start_ns=MONDAY, end_ns=MONDAY + 21 * DAY_NS,
        families=silent.families, observation="tf map->base_link",
    )
    (line,) = forecast_notes(robot, saturday)
    assert line.endswith("follows the weekdays' rhythm and level")
    # below half its time observed, the sensor's own note gives the advice, once
    sparse = Manifest(
        {}, {"profile": "day_weekend"}, start_ns=MONDAY, end_ns=MONDAY + 21 * DAY_NS,
        families=silent.families, observation="fixed sensor over the 900 windows with "
        "messages (150.0 h of a 504.0 h span)",
    )
    weekend, sensor = forecast_notes(sparse, saturday)
    assert weekend.endswith("follows the weekdays' rhythm and level")
    assert sensor.startswith("the map's fixed sensor observed 30% of its logs' time")
    # the weekly profile: a Sunday the span holds but nothing observed
    week = Manifest(
        {}, {"profile": "week"}, start_ns=MONDAY, end_ns=MONDAY + 21 * DAY_NS,
        families={"flow": {"shape": 4}, "scored_days": 20,
                  "observed_bins": list(range(6 * 24))},  # Monday..Saturday
        observation="tf map->base_link",
    )
    (line,) = forecast_notes(week, MONDAY + 27 * DAY_NS + 9 * HOUR_NS)
    assert line.startswith("the map observed no Sunday (its data, Mon 2026-01-05 to Sun "
                           "2026-01-25, holds 3, but no log recorded a window of them): its "
                           "hour-of-week profiles have no Sunday of their own")


def test_the_day_named_is_the_maps_own_and_its_zone_is_said() -> None:
    """Friday 20:00 UTC is Saturday 05:00 in Tokyo: a weekdays-only map kept in Asia/Tokyo
    names the Saturday with its zone (a user reading 'Saturday' beside a Friday UTC time
    would otherwise think the note wrong); a UTC map says nothing at that time (Friday)."""
    friday_20_utc = MONDAY + 4 * DAY_NS + 20 * HOUR_NS
    tokyo = _week_of(5, zone="Asia/Tokyo")
    tokyo = Manifest({}, tokyo.config, start_ns=MONDAY - 9 * HOUR_NS,
                     end_ns=MONDAY - 9 * HOUR_NS + 5 * DAY_NS, families=tokyo.families)
    (line,) = forecast_notes(tokyo, friday_20_utc)
    assert "so a forecast for a Saturday (Asia/Tokyo time) follows the weekdays'" in line
    assert forecast_notes(_week_of(5), friday_20_utc) == []


def test_a_series_that_reaches_a_kind_of_day_the_map_never_saw_names_it() -> None:
    """A daily series Friday .. Monday from a map of weekdays: its Saturday and Sunday follow
    the weekdays' hours, as a --time on that Saturday says; the series' notes had been those
    of its first time (a Friday: seen) and said nothing. They now name the first unseen day
    it reaches (2026-01-10 is a Saturday), with every day of that kind it reaches: a series
    over Saturday and Sunday had named the Saturday only. A series of weekdays, or one on a
    map that saw both kinds of day, adds nothing."""
    weekdays = _week_of(5)
    friday_noon = MONDAY + 4 * DAY_NS + 12 * HOUR_NS  # Friday 2026-01-09
    days = [friday_noon + k * DAY_NS for k in range(4)]  # Fri, Sat, Sun, Mon
    saturday_note = forecast_notes(weekdays, days[1])
    (line,) = saturday_note
    assert "a forecast for a Saturday follows" in line
    both = [line.replace("a Saturday follows", "a Saturday or Sunday follows")]
    assert series_notes(weekdays, days) == both
    assert series_notes(weekdays, days[:2]) == saturday_note  # Friday and Saturday only
    assert series_notes(weekdays, [days[0], days[3]]) == []  # Friday and Monday: seen
    assert series_notes(_week_of(7), days) == []  # a whole week: both kinds seen
    # a series that starts on the unseen day names it once, with the Sunday it reaches
    assert series_notes(weekdays, days[1:]) == both
    assert series_notes(weekdays, days[1:], at=days[2]) == both  # asked at the Sunday


def test_a_series_that_runs_far_past_the_data_says_so() -> None:
    """A daily series from the map's last day to 30 days after it (the data end on
    2023-11-17): its first time is within the data, and the series said nothing of the
    weeks after, which --time at its last time names. The note now names the last (or
    first) time where the start has none of its own; nothing is said twice."""
    timed = _manifest({"shape": 5})
    days = [END - DAY_NS + k * DAY_NS for k in range(32)]  # the last data day .. 30 after
    assert series_notes(timed, days) == [
        "the last of the times is 4 weeks after the map's data (2023-11-14 to 2023-11-17): "
        "the forecast repeats the rhythm the map learnt and knows nothing of what changed "
        "since"
    ]
    assert series_notes(timed, days[:7]) == []  # within the week after the data
    (own,) = series_notes(timed, days[-3:])  # the start is far after: its own note only
    assert own.startswith("this time is 4 weeks after")
    (early,) = series_notes(timed, [START - 9 * DAY_NS + k * DAY_NS for k in range(11)],
                            at=START + DAY_NS, noun="departures")
    assert early.startswith("the first of the departures is 9 days before the map's data")
    assert series_notes(timed, [START - 3 * DAY_NS + k * DAY_NS for k in range(5)]) == []
