"""The notes beside a forecast's time (``aion_cli.forecast_notes``)."""

from __future__ import annotations

from aion_cli.forecast_notes import forecast_notes
from aion_cli.manifest import Manifest

DAY_NS = 86_400 * 10**9
START = 1_700_000_000 * 10**9  # 2023-11-14 22:13:20 UTC
END = START + 3 * DAY_NS


def _manifest(
    flow: dict[str, int] | None, reconciled: bool = False, days: int = 3
) -> Manifest:
    families = {} if flow is None else {"flow": flow, "reconciled": reconciled, "scored_days": days}
    return Manifest({}, {}, start_ns=START, end_ns=END, families=families)


def test_a_map_whose_entries_all_forecast_statically_says_so() -> None:
    (line,) = forecast_notes(_manifest({"static": 12}, days=1), START + DAY_NS)
    assert line.startswith("every entry forecasts its static rate, whatever the time")
    assert "has 1 scored day," in line
    assert forecast_notes(_manifest({"static": 12, "profile": 1}), START) == []
    # a map-wide rhythm scales static entries: the forecast changes with the time
    assert forecast_notes(_manifest({"static": 12}, reconciled=True), START) == []
    assert forecast_notes(_manifest(None), START) == []  # a map without the tally


def test_times_far_from_the_data_are_named() -> None:
    timed = _manifest({"shape": 5})
    assert forecast_notes(timed, END + 6 * DAY_NS) == []  # the week after the data
    (after,) = forecast_notes(timed, END + 30 * DAY_NS)
    assert after == (
        "this time is 4 weeks after the map's data (2023-11-14 to 2023-11-17): the forecast "
        "repeats the rhythm the map learnt and knows nothing of what changed since"
    )
    (before,) = forecast_notes(timed, START - 5 * 3600 * 10**9)
    assert before.startswith("this time is 5 hours before the map's data")
    assert before.endswith("repeats the rhythm the map learnt")
    (hour,) = forecast_notes(timed, START - 3600 * 10**9)
    assert hour.startswith("this time is 1 hour before the map's data")
    years = forecast_notes(timed, END + 800 * DAY_NS)
    assert "2.2 years after" in years[0]
    # a static map has no rhythm to repeat: only where the time lies
    static, where = forecast_notes(_manifest({"static": 3}), END + 9 * DAY_NS)
    assert static.startswith("every entry forecasts its static rate")
    assert where == "this time is 9 days after the map's data (2023-11-14 to 2023-11-17)"
    one_day = Manifest({}, {}, start_ns=START, end_ns=START + 3600 * 10**9)
    assert forecast_notes(one_day, START - 3 * DAY_NS) == [
        "this time is 3 days before the map's data (2023-11-14): the forecast repeats the "
        "rhythm the map learnt"
    ]
