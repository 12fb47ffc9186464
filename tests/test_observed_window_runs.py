"""``--observed`` spans as runs of whole windows (``observed_spans._window_runs``, through the
engine's span merge): the runs cover exactly the windows some span overlaps, counted by
brute force, and are sorted, disjoint and never touching."""

from __future__ import annotations

from itertools import pairwise

from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.observed_spans import _window_runs

DELTA = 600


def _windows_overlapped(lo: int, hi: int) -> set[int]:
    """Every window ``[w·Δ, (w+1)·Δ)`` that shares time with ``[lo, hi)``, by scanning."""
    return {w for w in range(lo // DELTA - 1, hi // DELTA + 2)
            if w * DELTA < hi and (w + 1) * DELTA > lo}


spans = st.lists(
    st.tuples(st.integers(0, 20 * DELTA), st.integers(1, 4 * DELTA)).map(
        lambda t: (t[0], t[0] + t[1])),
    max_size=8,
)


@settings(max_examples=200, deadline=None)
@given(spans)
def test_runs_cover_the_overlapped_windows_and_nothing_else(
    declared: list[tuple[int, int]],
) -> None:
    runs = _window_runs(tuple(declared), DELTA)
    covered = [w for a, b in runs for w in range(a, b + 1)]
    expected: set[int] = set()
    for lo, hi in declared:
        expected |= _windows_overlapped(lo, hi)
    assert sorted(covered) == sorted(expected)
    assert len(covered) == len(set(covered))
    for (_, b), (a, _) in pairwise(runs):
        assert a > b + 1  # joined when touching: a gap of at least one window between runs


def test_two_spans_in_neighbouring_windows_make_one_run() -> None:
    assert _window_runs(((0, 100), (DELTA + 5, DELTA + 10)), DELTA) == [(0, 1)]
    assert _window_runs(((0, 100), (2 * DELTA, 2 * DELTA + 1)), DELTA) == [(0, 0), (2, 2)]
