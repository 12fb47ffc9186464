"""Merging maps of one local day (merge approximation 4, narrowed at stop 71): when the later
map closed no day, the earlier map's windows of the day it ends on and the later map's are
one pending day, as one build of both logs holds them, so merge(A, B) and merge(B, A) predict
what that build predicts (flows, variances, rates, histograms to 1e-9), with every temporal
family, whatever days the earlier map closed before. Before, the earlier map's part of the
day was scored and absorbed at the merge, the later map's part again as a day of its own: the
day counted twice (window-count variances 24 to 33 times one build's, docs/ROBUSTNESS.md,
stop 69)."""

from __future__ import annotations

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from aion_cli.engine.mapper import Mapper
from aion_cli.engine.merge import merge_maps
from aion_cli.engine.merge_days import shared_first_day
from aion_cli.engine.state import MapState
from tests.engine.state_logs import CFG, DAY, HOUR, MORNING, Step, fixed_sensor_log, run_steps
from tests.engine.test_merge_predictions import _detections, assert_same_predictions

#: the earlier map's logs: days after the previous one's (the first: after MORNING's day),
#: windows, seed; each from 08:00 of its day, at most 70 minutes long
EARLIER = st.lists(
    st.tuples(st.integers(0, 2), st.integers(1, 7), st.integers(0, 10**6)), min_size=1,
    max_size=2,
)
#: the later log: hours after 08:00 of the earlier map's last day (the same local day)
LATER = st.tuples(st.integers(2, 14), st.integers(1, 7), st.integers(0, 10**6))
#: when to predict, from the first log's day (ns)
TIMES = st.lists(st.integers(-DAY, 8 * DAY), min_size=1, max_size=3)


def _logs(
    earlier: list[tuple[int, int, int]], later: tuple[int, int, int], graph: bool = True
) -> tuple[list[Step], list[Step]]:
    """The earlier map's logs (one after another, days apart) and the later log, which
    starts ``later[0]`` hours after 08:00 of the earlier map's last day; without ``graph``
    each log's graph step is left out (maps of hash cells only)."""
    steps, day = [], 0
    for k, (gap, windows, seed) in enumerate(earlier):
        day += gap if k else 0
        steps += _log(MORNING + day * DAY, seed, windows, graph)
        day += 1
    hours, windows, seed = later
    return steps, _log(MORNING + (day - 1) * DAY + hours * HOUR, seed, windows, graph)


def _log(start: int, seed: int, windows: int, graph: bool) -> list[Step]:
    steps = fixed_sensor_log(start, seed, windows=windows)
    return steps if graph else [steps[0], *steps[2:]]  # steps[1]: the graph


def _check(whole: MapState, merged: MapState, times: list[int]) -> None:
    assert _detections(merged) == _detections(whole)
    assert merged.accepted == whole.accepted
    assert merged.pending.windows == whole.pending.windows  # one pending day, as one build's
    for offset in times:
        assert_same_predictions(whole, merged, MORNING + offset)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(earlier=EARLIER, later=LATER, times=TIMES)
def test_maps_of_one_day_merged_in_either_order_predict_what_one_build_does(
    earlier: list[tuple[int, int, int]], later: tuple[int, int, int], times: list[int]
) -> None:
    first, second = _logs(earlier, later)
    whole = run_steps(first + second, Mapper(CFG)).state
    a, b = (run_steps(steps, Mapper(CFG)).state for steps in (first, second))
    assert shared_first_day(a, b) is not None
    for merged in (merge_maps(a, b), merge_maps(b, a)):
        _check(whole, merged, times)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(earlier=EARLIER, later=LATER, times=TIMES)
@example(earlier=[(0, 7, 1), (1, 7, 2)], later=(3, 1, 3), times=[0])  # the earlier larger
def test_maps_of_hash_cells_of_one_day_folded_in_place_predict_what_one_build_does(
    earlier: list[tuple[int, int, int]], later: tuple[int, int, int], times: list[int]
) -> None:
    """``aion merge``'s fold (``consume``): built in the earlier map when it is the larger
    (``engine.merge_cells``), else in the later one."""
    first, second = _logs(earlier, later, graph=False)
    whole = run_steps(first + second, Mapper(CFG)).state
    for order in (0, 1):
        a, b = (run_steps(steps, Mapper(CFG)).state for steps in (first, second))
        merged = merge_maps(*((a, b) if order else (b, a)), consume=True)
        _check(whole, merged, times)


def test_three_maps_of_one_day_folded_are_one_day() -> None:
    """Three logs of one day (08:00, 11:00, 15:00), folded as ``aion merge`` folds them."""
    logs = [fixed_sensor_log(MORNING + h * HOUR, seed, windows=4) for h, seed in
            ((0, 1), (3, 2), (7, 3))]
    whole = run_steps([s for steps in logs for s in steps], Mapper(CFG)).state
    acc = run_steps(logs[0], Mapper(CFG)).state
    for steps in logs[1:]:
        acc = merge_maps(acc, run_steps(steps, Mapper(CFG)).state, consume=True)
    _check(whole, acc, [DAY, 2 * DAY + 5 * HOUR, 6 * DAY])


def test_a_later_map_past_the_day_still_scores_it_twice() -> None:
    """The later map closed the day the earlier one ends on (it goes on to the next day):
    its part of the day is absorbed and cannot be joined; the merge keeps approximation 4."""
    early = run_steps(fixed_sensor_log(MORNING, 1, windows=3), Mapper(CFG)).state
    late = run_steps(
        fixed_sensor_log(MORNING + 15 * HOUR + 30 * 60 * 10**9, 2, windows=7), Mapper(CFG)
    ).state
    assert late.closed_a_day()
    assert shared_first_day(early, late) is None
    merged = merge_maps(early, late)
    assert merged.pending.windows == late.pending.windows  # the next day's alone
