"""What merged maps predict, as properties over random fixed-sensor logs days apart
(``state_logs.py``): with the static family alone (no map scored days the other lacked: merge
approximation 2 does not apply) merge(A, B) and merge(B, A) predict, at any time, what one
build of A's and B's logs predicts, to 1e-9, and hold as many detections as A and B; parts of
the logs (``build --part``) joined in time order predict what one build does with every
family."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.engine.mapper import Mapper
from aion_cli.engine.merge import merge_maps
from aion_cli.engine.query import EntryTable, predict_table
from aion_cli.engine.shards import join_shard, start_shard
from aion_cli.engine.state import MapState
from tests.engine.state_logs import CFG, DAY, MORNING, Step, fixed_sensor_log, run_steps

STATIC = CFG.replace(families=("static",))
#: a log: days after the previous one's, windows, seed
ONE_LOG = st.tuples(st.integers(1, 3), st.integers(1, 7), st.integers(0, 10**6))
#: when to predict, from the first log's day (ns)
TIMES = st.lists(st.integers(-2 * DAY, 12 * DAY), min_size=1, max_size=3)


def _logs(specs: list[tuple[int, int, int]]) -> list[list[Step]]:
    """Each log from 08:00 of its day, days apart (each scores whole days of its own)."""
    logs, day = [], 0
    for gap, windows, seed in specs:
        day += gap
        logs.append(fixed_sensor_log(MORNING + day * DAY, seed, windows=windows))
    return logs


def _run(logs: list[list[Step]], mapper: Mapper) -> MapState:
    return run_steps([step for steps in logs for step in steps], mapper).state


def _rows(table: EntryTable) -> dict[tuple[int, int], int]:
    keys = zip(table.key.tolist(), table.node_id.tolist(), strict=True)
    return {key: k for k, key in enumerate(keys)}


def assert_same_predictions(whole: MapState, other: MapState, t_ns: int) -> None:
    """Entry by entry (cell key, node id): flows, variances, rates, histograms to 1e-9."""
    a, b = predict_table(whole, t_ns), predict_table(other, t_ns)
    ra, rb = _rows(a), _rows(b)
    assert ra.keys() == rb.keys()
    ia = np.array(list(ra.values()), dtype=np.int64)
    ib = np.array([rb[key] for key in ra], dtype=np.int64)
    for name in ("flow", "flow_var", "rate"):
        np.testing.assert_allclose(getattr(b, name)[ib], getattr(a, name)[ia], rtol=1e-9,
                                   atol=1e-12, err_msg=name)
    np.testing.assert_allclose(b.descriptors.probabilities[ib], a.descriptors.probabilities[ia],
                               rtol=1e-9, atol=1e-12)


def _detections(state: MapState) -> float:
    """Σ over live entries of their directed and undirected counts."""
    e, rows = state.entries, state.entries.live_rows()
    return float(e.counts[rows].sum() + e.nodir[rows].sum())


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(specs=st.lists(ONE_LOG, min_size=2, max_size=2), times=TIMES)
def test_merges_of_static_maps_in_either_order_predict_what_one_build_does(
    specs: list[tuple[int, int, int]], times: list[int]
) -> None:
    logs = _logs(specs)
    whole = _run(logs, Mapper(STATIC))
    a, b = (_run([steps], Mapper(STATIC)) for steps in logs)
    total = _detections(a) + _detections(b)
    ab, ba = merge_maps(a, b), merge_maps(b, a)
    for merged in (ab, ba):
        assert _detections(merged) == total == _detections(whole)
        assert merged.accepted == whole.accepted
        for offset in times:
            assert_same_predictions(whole, merged, MORNING + offset)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(specs=st.lists(ONE_LOG, min_size=2, max_size=3), times=TIMES)
def test_parts_joined_in_order_predict_what_one_build_does(
    specs: list[tuple[int, int, int]], times: list[int]
) -> None:
    logs = _logs(specs)
    whole = _run(logs, Mapper(CFG))
    joined = MapState.empty(CFG)
    for steps in logs:
        joined = join_shard(joined, _run([steps], Mapper(CFG, start_shard(MapState.empty(CFG)))))
    for offset in times:
        assert_same_predictions(whole, joined, MORNING + offset)
