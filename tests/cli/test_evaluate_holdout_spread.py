"""``aion evaluate holdout`` judges aion's spread: how its flow_p10..flow_p90 band holds the
held-out counts (``spread_coverage``; ``evaluation.spread``), on the corridor of
:mod:`tests.cli.test_evaluate_holdout` (walkers at random times and places)."""

from __future__ import annotations

import pytest

from tests.cli.conftest import run, run_json
from tests.cli.test_evaluate_holdout import corridor

__all__ = ["corridor"]  # the fixture, built once for this module


def test_the_spread_coverage_of_the_held_out_day(corridor: tuple) -> None:
    """Every place in each of the 60 fixed-sensor windows is a judged pair, the ten hours
    sum them; walkers at random times and places give each place a Poisson-like count, so
    aion's band holds about its 80 % (a band too narrow for them would read far less)."""
    import aion_cli as aion

    site, _train, test, _truth = corridor
    doc = run_json("evaluate", "holdout", site, test, "--format", "json")
    cover = doc["spread_coverage"]
    pairs, hours = cover["place_windows"], cover["hours"]
    assert pairs["counts"] > 0
    assert pairs["counts"] % 60 == 0
    assert hours["counts"] == 10
    for part in (pairs, hours):
        assert part["inside"] + part["below"] + part["above"] == pytest.approx(1.0)
    assert 0.7 < pairs["pit"] < 0.95
    assert aion.Map.load(site).holdout(test).spread == cover
    # the table's run says it in a line
    shown = run("evaluate", "holdout", site, test)
    assert shown.exit_code == 0, shown.stderr
    assert f"of the {pairs['counts']:,} (place, window) test counts" in shown.stderr
