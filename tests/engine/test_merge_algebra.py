"""The algebra of maps, as properties over random fixed-sensor logs (``state_logs.py``):
one pass over all the logs equals the shards (parts) of any contiguous split joined in time
order, and a map saved, read back and continued; ordinary maps merge the same in either
argument order, and what they observed (``--historical``) does not depend on how a merge of
three is grouped (their day-ahead scores do: each map scored its own days, merge
approximation 2)."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from aion_cli.engine.compare import differences
from aion_cli.engine.join_blockers import join_blocker
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.merge import merge_maps
from aion_cli.engine.query import historical_table
from aion_cli.engine.shards import join_shard, start_shard
from aion_cli.engine.state import MapState
from tests.engine.engine_builders import graph
from tests.engine.state_logs import (
    CFG,
    DAY,
    MORNING,
    NODES,
    Step,
    W,
    assert_same_state,
    fixed_sensor_log,
    run_steps,
)

#: every log's people walk at these spots, all of them in its first window (so every entry
#: exists from each log's first window: the condition for exact ordinary merges)
SPOTS = np.c_[np.random.default_rng(11).uniform(-1, 8, (25, 2)), np.zeros(25)]

#: a log: (days after the previous log's day, windows, seed)
ONE_LOG = st.tuples(st.integers(0, 3), st.integers(1, 7), st.integers(0, 10**6))
LOGS = st.lists(ONE_LOG, min_size=2, max_size=4)


def _logs(specs: list[tuple[int, int, int]], spots: np.ndarray | None = SPOTS) -> list[list[Step]]:
    """The logs of ``specs`` in time order: each from 08:00 of its day (a log on the day of
    the previous one starts two hours after that one's start, after its last window); people
    at ``spots``, or (None) anywhere, each log at its own places."""
    logs, day, hour = [], 0, 0
    for gap, windows, seed in specs:
        day, hour = (day, hour + 2) if gap == 0 and logs else (day + gap, 0)
        start = MORNING + day * DAY + hour * 6 * W
        logs.append(fixed_sensor_log(start, seed, windows=windows, spots=spots))
    return logs


def _flat(logs: list[list[Step]]) -> list[Step]:
    return [step for steps in logs for step in steps]


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow],
          derandomize=True)
@given(specs=LOGS, cuts=st.lists(st.booleans(), min_size=3, max_size=3))
# parts of one window each, the same day and the next: the join closes the earlier part's
# window, whose own graph binds its cells then (join_blocker took them for cells the later
# part's graph reached late, and refused)
@example(specs=[(0, 1, 0), (0, 1, 1)], cuts=[True, False, False])
@example(specs=[(0, 1, 0), (1, 1, 1)], cuts=[True, False, False])
def test_parts_of_any_split_joined_in_order_equal_one_pass(
    specs: list[tuple[int, int, int]], cuts: list[bool]
) -> None:
    """``aion merge P1 P2 ...`` of parts (``build --part``) cut anywhere between the logs."""
    logs = _logs(specs)
    groups: list[list[Step]] = [list(logs[0])]
    for steps, cut in zip(logs[1:], cuts, strict=False):
        if cut:
            groups.append(list(steps))
        else:
            groups[-1] += steps
    whole = run_steps(_flat(logs)).state
    joined = MapState.empty(CFG)
    for steps in groups:
        part = run_steps(steps, Mapper(CFG, start_shard(MapState.empty(CFG)))).state
        assert join_blocker(joined, part) is None
        joined = join_shard(joined, part)
    assert_same_state(whole, joined)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(specs=LOGS, at=st.integers(1, 3))
def test_a_map_saved_and_continued_equals_one_pass(
    specs: list[tuple[int, int, int]], at: int
) -> None:
    """``aion build L2 --map build(L1)``: the map goes through its saved arrays between."""
    logs = _logs(specs)
    at = min(at, len(logs) - 1)
    first = run_steps(_flat(logs[:at])).state
    reread = MapState.from_arrays(*first.to_arrays())
    continued = run_steps(_flat(logs[at:]), Mapper(CFG, reread)).state
    assert_same_state(run_steps(_flat(logs)).state, continued)


def _historical(state: MapState) -> dict[tuple[int, int], np.ndarray]:
    """Per entry (cell key, node id): its observed rate, detections per bin, speed samples."""
    t = historical_table(state)
    n = len(t.key)
    values = np.c_[t.rate.reshape(n, -1), t.flow.reshape(n, -1), t.speed_n.reshape(n, -1)]
    keys = zip(t.key.tolist(), t.node_id.tolist(), strict=True)
    return dict(zip(keys, values, strict=True))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    specs=st.lists(ONE_LOG, min_size=3, max_size=3),
    present=st.lists(st.booleans(), min_size=len(NODES), max_size=len(NODES)),
)
def test_ordinary_merges_commute_and_observe_the_same_in_any_grouping(
    specs: list[tuple[int, int, int]], present: list[bool]
) -> None:
    """merge(a, b) == merge(b, a); merge(merge(a, b), c) and merge(a, merge(b, c)) hold what
    one pass observed, entry by entry (to 1e-9): a fixed sensor's windows count for every
    entry, so each log may have its own places. The first log's graph has the places of
    ``present`` only: its cells near the others bind once the later graphs add them (a
    merge left those cells unbound that no later log saw)."""
    specs = [(max(gap, 1), windows, seed) for gap, windows, seed in specs]  # days apart
    logs = _logs(specs, spots=None)
    ids = [k for k, keep in enumerate(present) if keep]
    start = MORNING + specs[0][0] * DAY  # the first log's (see _logs)
    logs[0][1] = lambda m: m.add_graph(graph(start, ids, np.array(NODES)[ids]))
    a, b, c = (run_steps(steps).state for steps in logs)
    assert differences(merge_maps(a, b), merge_maps(b, a)) == []
    left = _historical(merge_maps(merge_maps(a, b), c))
    right = _historical(merge_maps(a, merge_maps(b, c)))
    whole = _historical(run_steps(_flat(logs)).state)
    assert left.keys() == right.keys() == whole.keys()
    for key, value in whole.items():
        np.testing.assert_allclose(left[key], value, rtol=1e-9, atol=0, err_msg=str(key))
        np.testing.assert_allclose(right[key], value, rtol=1e-9, atol=0, err_msg=str(key))
