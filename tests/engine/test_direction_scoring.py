"""The day-ahead direction scoring evaluates each family only at the (pair, bin) positions
that hold detections: equal to the bit to the full histograms it replaces."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from aion_cli.engine.temporal.direction_scoring import DetectionBins
from aion_cli.engine.temporal.forecast import Forecaster
from aion_cli.engine.temporal.fremen_parts import _running_sum
from aion_cli.engine.temporal.pooling import PoolStats
from aion_cli.engine.windows import to_model_seconds
from tests.engine.temporal_data import DAY, HOUR, MONDAY, corridor


def _rush(d: int, h: int) -> float:
    return 40.0 if h in (8, 9, 17, 18) else 2.0


def _turning(d: int, h: int) -> float:
    return 0.0 if h < 12 else np.pi / 2  # east in the morning, north in the afternoon


def test_direction_at_equals_the_full_histograms_at_the_asked_bins() -> None:
    mapper = corridor(6, _rush, seed=3, heading=_turning)
    state = mapper.state
    params = state.params
    view = state.query_temporal()
    rows = state.entries.canonical_order()
    groups = np.zeros(rows.size, np.int64)
    fc = Forecaster(params, view, rows, groups, PoolStats.of(params, view, rows, groups, 1))
    rng = np.random.default_rng(0)
    pairs = 500
    e = rng.integers(0, rows.size, pairs)
    t_ns = MONDAY + 6 * DAY + rng.integers(0, 24, pairs) * HOUR + 30 * 60 * 10**9
    h = params.calendar.profile_bin(t_ns)
    t_s = to_model_seconds(t_ns)
    counts = np.zeros((pairs, params.bins))
    counts[np.arange(pairs), rng.integers(0, params.bins, pairs)] = rng.integers(1, 5, pairs)
    counts[::3, 0] += 1.0  # some pairs with detections in two bins
    counted = DetectionBins.of(counts)
    assert counted.pair.size > pairs  # two bins for a third of the pairs
    np.testing.assert_array_equal(counts[counted.pair, counted.bin], counted.count)
    assert np.all(np.diff(counted.pair) >= 0)
    timed = [name for name in params.direction if name != "static"]
    assert "profile" in timed
    assert any(n.startswith("fremen") for n in timed)
    for name in params.direction:
        full = fc.direction(name, e, h, t_s)
        at = fc.direction_at(name, e, h, t_s, counted.pair, counted.bin)
        np.testing.assert_array_equal(at, full[counted.pair, counted.bin])
    keep = rng.random(pairs) < 0.5
    sub = counted.subset(keep)
    np.testing.assert_array_equal(sub.count, counts[keep][sub.pair, sub.bin])
    # renumbered among the kept pairs: every kept pair with detections, and only those
    kept_with = np.flatnonzero(counts[keep].any(axis=1))
    np.testing.assert_array_equal(np.unique(sub.pair), kept_with)


@settings(max_examples=60, deadline=None)
@given(
    hnp.arrays(
        np.float64,
        hnp.array_shapes(min_dims=1, max_dims=3, min_side=1, max_side=6),
        elements=st.floats(-1e6, 1e6, allow_nan=False),
    )
)
def test_running_sum_is_numpys_cumsum_to_the_bit(terms: np.ndarray) -> None:
    expected = np.cumsum(terms, axis=-1)
    got = _running_sum(terms.copy())
    np.testing.assert_array_equal(got, expected)
