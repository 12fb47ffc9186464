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
