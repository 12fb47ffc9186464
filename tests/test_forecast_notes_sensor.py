"""The notes beside a forecast's time (``aion_cli.forecast_notes``) about a fixed sensor that
observed a part of its logs' time (only the windows with a message): said at every time, with
the advice to declare its spans, once; not when its spans were declared."""

from __future__ import annotations

from aion_cli.forecast_notes import forecast_notes, series_notes
from aion_cli.manifest import Manifest
from tests.test_forecast_notes import DAY_NS, HOUR_NS, MONDAY


def test_a_fixed_sensor_that_observed_under_half_its_time_says_so_at_every_time() -> None:
    """A fixed sensor that observed 18 % of its span (only the windows with a message) and a
    rhythm inside them: if its tracker is silent when nobody is there, every window observed
    held someone, so the forecast runs high (a corridor whose nights had 5 walkers an hour
    was forecast at twice that). The note says so at any time, with how to declare the
    spans, once (an all-static map's note carries the advice already); 03:00, never
    observed, is named as before; a robot's map says neither."""
    silent_text = "fixed sensor over the 168 windows with messages (28.0 h of a 155.0 h span)"
    families = {"flow": {"profile": 4}, "scored_days": 5, "observed_bins": [8, 9]}
    silent = Manifest({}, {"profile": "day"}, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
                      families=families, observation=silent_text)
    sensor = (
        "the map's fixed sensor observed 18% of its logs' time (only the windows in which a "
        "log recorded a message; the rest is unknown, not empty): if its tracker is silent "
        "when nobody is there, the windows observed are those with someone in them and the "
        "forecast runs high, most in quiet hours: declare the spans it was recording with "
        "aion build --observed"
    )
    assert forecast_notes(silent, MONDAY + 8 * HOUR_NS) == [sensor]
    night = forecast_notes(silent, MONDAY + 3 * HOUR_NS)
    assert night == [sensor, (
        "no log observed 03:00-04:00 (UTC) on any day (the map observed 08:00-10:00): the "
        "forecast at this hour is extrapolated from the hours observed, not measured: every "
        "entry at its static rate, its mean per window over all the hours observed (one busy "
        "hour raises it above the quiet ones)"
    )]
    robot = Manifest({}, {"profile": "day"}, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
                     families=families, observation="tf map->base_link")
    assert forecast_notes(robot, MONDAY + 3 * HOUR_NS) == night[1:]
    static = Manifest({}, {"profile": "day"}, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
                      families={**families, "flow": {"static": 4}}, observation=silent_text)
    notes = forecast_notes(static, MONDAY + 3 * HOUR_NS)
    assert sum("aion build --observed" in n for n in notes) == 1
    # a series gives it once too, beside the hours it names
    series = series_notes(silent, [MONDAY + h * HOUR_NS for h in (3, 8, 12)])
    assert series[0] == sensor
    assert series[1].startswith("2 of the 3 times fall in hours no log observed on any day")


def test_a_silent_sensor_is_named_whatever_makes_every_entry_static() -> None:
    """A fixed sensor that observed 18 % of its span, every entry static because the map has
    one scored day or its model has the static family only: the all-static note carries no
    word of the silent tracker there, so the sensor's own note must (it was left out for
    every all-static map, as if the all-static note always held the advice); once only."""
    silent_text = "fixed sensor over the 168 windows with messages (28.0 h of a 155.0 h span)"
    for config, days in (({"profile": "day"}, 1), ({"families": ["static"]}, 5)):
        static = Manifest(
            {}, config, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
            families={"flow": {"static": 4}, "scored_days": days, "observed_bins": [8, 9]},
            observation=silent_text,
        )
        notes = forecast_notes(static, MONDAY + 8 * HOUR_NS)
        assert notes[0].startswith("every entry forecasts its static rate")
        assert notes[1].startswith("the map's fixed sensor observed 18% of its logs' time")
        assert sum("aion build --observed" in n for n in notes) == 1


def test_a_silent_sensor_is_named_from_the_windows_text_and_from_old_maps_texts() -> None:
    """Maps describe a fixed sensor in windows now ("(168 of the 930 windows of 10 min from
    the first to the last)"); those written before gave times ("(28.0 h of a 155.0 h
    span)"). Read back, both say it observed 18 % of its time (168 of 930 windows) and give
    the advice to declare its spans; the same sensor with spans declared gets none."""
    from aion_cli.fixed_sensor import fixed_sensor_text

    delta = 600 * 10**9
    texts = (
        fixed_sensor_text(168, 0, 929, delta),
        "fixed sensor over the 168 windows with messages (28.0 h of a 155.0 h span)",
    )
    assert texts[0].endswith("(168 of the 930 windows of 10 min from the first to the last)")
    families = {"flow": {"profile": 4}, "scored_days": 5, "observed_bins": [8, 9]}
    for text in texts:
        silent = Manifest({}, {"profile": "day"}, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
                          families=families, observation=text)
        (note,) = forecast_notes(silent, MONDAY + 8 * HOUR_NS)
        assert note.startswith("the map's fixed sensor observed 18% of its logs' time"), text
        assert note.endswith("declare the spans it was recording with aion build --observed")
    declared = Manifest({}, {"profile": "day"}, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
                        families=families,
                        observation=fixed_sensor_text(168, 0, 929, delta, declared=True))
    assert forecast_notes(declared, MONDAY + 8 * HOUR_NS) == []


def test_a_sensor_whose_spans_were_declared_is_not_told_to_declare_them() -> None:
    """A fixed sensor recording 08:00-10:00 only, built with those spans declared (its
    description reads 'windows with messages or --observed'): under half of its logs' time
    is observed because it recorded no more, which build says nothing of; predict said 'only
    the windows in which a log recorded a message ... declare the spans it was recording with
    aion build --observed' at every time, for a map built so."""
    declared = Manifest(
        {}, {"profile": "day"}, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
        families={"flow": {"profile": 4}, "scored_days": 5, "observed_bins": [8, 9]},
        observation="fixed sensor over the 84 windows with messages or --observed (14.0 h of "
        "a 155.0 h span)",
    )
    assert forecast_notes(declared, MONDAY + 8 * HOUR_NS) == []
    static = Manifest(
        {}, {"profile": "day"}, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
        families={**declared.families, "flow": {"static": 4}},
        observation=declared.observation,
    )
    assert not any("--observed" in n for n in forecast_notes(static, MONDAY + 8 * HOUR_NS))


def test_a_sensor_that_observed_a_sliver_of_its_time_does_not_read_0_percent() -> None:
    """2 windows with messages of a 500-window span is 0.4 %: the note read "observed 0% of
    its logs' time", as if nothing had been observed; it reads "<1%"."""
    from aion_cli.fixed_sensor import share_text

    sliver = "fixed sensor over the 2 windows with messages (0.3 h of a 83.3 h span)"
    manifest = Manifest({}, {"profile": "day"}, start_ns=MONDAY, end_ns=MONDAY + 7 * DAY_NS,
                        families={"flow": {"profile": 4}, "scored_days": 5,
                                  "observed_bins": [8, 9]}, observation=sliver)
    notes = forecast_notes(manifest, MONDAY + 8 * HOUR_NS)
    assert notes[0].startswith("the map's fixed sensor observed <1% of its logs' time"), notes
    assert [share_text(s) for s in (0.0, 0.004, 0.005, 0.0051, 0.18, 0.994, 0.996, 1.0)] == [
        "0%", "<1%", "<1%", "1%", "18%", "99%", ">99%", "100%"
    ]
