"""``aion evaluate holdout --observed`` on the corridor of :mod:`tests.cli.test_evaluate_holdout`:
a span apart from the test logs' messages (a mistyped year) is warned of, as ``aion build``
warns of the same span on the same log."""

from __future__ import annotations

from pathlib import Path

from tests.cli.conftest import run, run_json
from tests.cli.test_evaluate_holdout import corridor

__all__ = ["corridor"]  # the fixture, built once for this module


def test_an_observed_span_apart_from_the_test_logs_is_warned_of(
    corridor: tuple, tmp_path: Path
) -> None:
    """The test day is 2026-01-11, observed 08:00-18:00. ``--observed`` of that day in 2016
    (a year mistyped) added 60 windows observed and empty ten years before the logs, and the
    evaluation said nothing of it (its reading options had no spans as typed), where ``aion
    build`` of the same log and span warns. Both warn alike now; a span within the test day
    gets no warning."""
    site, _train, test, _truth = corridor
    span = "2016-01-11T08:00..2016-01-11T18:00"
    doc = run_json("evaluate", "holdout", site, test, "--format", "json", "--observed", span)
    assert doc["test"]["fixed_sensor_windows"] == 60 + 60  # the day, and the span declared
    (said,) = [w for w in doc["warnings"] if w.startswith("--observed")]
    assert said.startswith(
        f'--observed "{span}" (2016-01-11 08:00:00+00:00 .. 2016-01-11 18:00:00+00:00) lies '
        "wholly before the logs' messages (2026-01-11 08:00:00+00:00 .. "
    )
    built = run("build", test, "-o", tmp_path / "test.aion", "--observed", span, "-q")
    assert built.exit_code == 0, built.stderr
    assert f"warning: {said}" in built.stderr.replace("\n", " ")
    inside = run_json("evaluate", "holdout", site, test, "--format", "json",
                      "--observed", "2026-01-11T09:00..2026-01-11T10:00")  # fmt: skip
    assert not [w for w in inside["warnings"] if w.startswith("--observed")]


def test_the_warning_names_its_times_in_the_maps_zone(corridor: tuple, tmp_path: Path) -> None:
    """A map built in Europe/Berlin reads ``--observed`` in Berlin's time, and its warning
    named the span in UTC (``07:00:00+00:00``, not the ``08:00`` typed): it names both the
    span and the logs' messages in the map's zone, as ``aion build --tz Europe/Berlin`` of the
    same log and span does."""
    _site, train, test, _truth = corridor
    site = tmp_path / "berlin.aion"
    made = run("build", train, "-o", site, "--tz", "Europe/Berlin", "-q")
    assert made.exit_code == 0, made.stderr
    span = "2016-01-11T08:00..2016-01-11T18:00"
    doc = run_json("evaluate", "holdout", site, test, "--format", "json", "--observed", span)
    (said,) = [w for w in doc["warnings"] if w.startswith("--observed")]
    assert said.startswith(
        f'--observed "{span}" (2016-01-11 08:00:00+01:00 .. 2016-01-11 18:00:00+01:00) lies '
        "wholly before the logs' messages (2026-01-11 09:00:00+01:00 .. "  # 08:00 UTC
    )
    built = run("build", test, "-o", tmp_path / "test.aion", "--observed", span, "-q",
                "--tz", "Europe/Berlin")  # fmt: skip
    assert built.exit_code == 0, built.stderr
    assert f"warning: {said}" in built.stderr.replace("\n", " ")


def test_test_hours_the_map_never_observed_are_named(corridor: tuple) -> None:
    """The map observed 08:00-18:00 on each of its days; a test day declared observed
    06:00-20:00 adds four hours whose hour of the day no log of the map observed (06-08 and
    18-20), where aion's forecast is extrapolated: the evaluation scored them without a word,
    where ``aion predict`` at such an hour says so. The note counts them; the test day as
    observed (08:00-18:00) gets none."""
    site, _train, test, _truth = corridor
    doc = run_json("evaluate", "holdout", site, test, "--format", "json",
                   "--observed", "2026-01-11T06:00..2026-01-11T20:00")  # fmt: skip
    assert len(doc["hours"]) == 14
    (said,) = [n for n in doc["notes"] if "no log observed" in n]
    assert said.startswith(
        "4 of the 14 test hours fall in hours no log observed on any day (06:00-08:00, "
        "18:00-20:00 UTC; the map observed 08:00-18:00): their forecast is extrapolated"
    )
    plain = run_json("evaluate", "holdout", site, test, "--format", "json")
    assert len(plain["hours"]) == 10
    assert not [n for n in plain["notes"] if "no log observed" in n]
