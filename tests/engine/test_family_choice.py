"""Family choice against ``static``: the margin, and the small-sample t-test on daily gains."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.temporal.choice import _choose, t_critical
from aion_cli.engine.types import F64


def test_t_critical_matches_the_tables() -> None:
    """One-sided 5 % quantiles of Student's t (standard tables), the normal's in the limit,
    decreasing with the degrees of freedom."""
    assert t_critical(1) == pytest.approx(6.314)
    assert t_critical(2) == pytest.approx(2.920)
    assert t_critical(10) == pytest.approx(1.812)
    assert t_critical(30) == pytest.approx(1.697)
    assert t_critical(60) == pytest.approx(1.671, abs=2e-3)
    assert t_critical(120) == pytest.approx(1.658, abs=2e-3)
    assert t_critical(10**6) == pytest.approx(1.645, abs=1e-3)
    values = t_critical(np.arange(1, 500))
    assert np.all(np.diff(values) < 0)


def _entries(daily_gains: list[list[float]]) -> tuple[F64, tuple[F64, F64, int]]:
    """Scores of (static, other) per entry from its daily gains of ``other`` over static."""
    totals = np.array([sum(g) for g in daily_gains])
    scores = np.column_stack([np.zeros(len(totals)), totals])
    gain_sq = np.column_stack([np.zeros(len(totals)), [sum(x * x for x in g) for g in daily_gains]])
    days: F64 = np.array([float(len(g)) for g in daily_gains])
    return scores, (gain_sq, days, 0)


def test_a_family_must_win_consistently_the_more_so_the_fewer_the_days() -> None:
    """Every entry gains 6 nats a day on average over ``static``; only those whose daily gains
    pass the one-sided 5 % t-test (sample variance, n - 1 degrees of freedom) switch. Entry 3
    (gains 4 and 8: t = 3.0 on one degree of freedom) passed the old fixed two-standard-error
    rule with the population variance (4.2) but is not evidence enough from two days."""
    gains = [
        [5.0, 6.0, 7.0],  # t = 10.4 > 2.92: switches
        [1.0, 12.0, 5.0],  # t = 1.87 < 2.92: stays static
        [10.0, 10.5],  # t = 41 > 6.31: switches
        [4.0, 8.0],  # t = 3.0 < 6.31: stays static
        [6.0] * 8,  # no spread at all: switches
        [30.0],  # one day: the margin alone decides
    ]
    scores, consistency = _entries(gains)
    chosen = _choose(scores, np.zeros(len(gains), np.int64), np.array([True, True]), 3.0,
                     consistency)
    np.testing.assert_array_equal(chosen, [1, 0, 1, 0, 1, 1])


def test_the_margin_still_applies() -> None:
    """A consistent but small total gain (2 nats over 4 days) stays below the 3-nat margin."""
    scores, consistency = _entries([[0.5, 0.5, 0.5, 0.5]])
    chosen = _choose(scores, np.zeros(1, np.int64), np.array([True, True]), 3.0, consistency)
    assert chosen.tolist() == [0]
    disabled = _choose(scores * 10, np.zeros(1, np.int64), np.array([True, False]), 3.0,
                       consistency)
    assert disabled.tolist() == [0]
