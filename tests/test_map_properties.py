"""Properties of maps over random logs (``tests/engine/state_logs.py``), through the map file:

* a map written (``write_map``) and read back (``load_map``, for a query and to continue) is
  the same map, member by member, and predicts what the state in memory predicts;
* ``aion build L --map M`` where ``M`` is the map of ``L``'s first messages: a log cut after
  any of its messages (a detection batch, the graph, the sensor's span), the first part saved
  and the rest learnt onto it, equals one build of the whole log;
* a prediction at any time, of a map of a fixed sensor or of a robot, has finite,
  non-negative flows and variances and direction histograms that sum to 1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aion_cli.engine.compare import differences
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.query import predict_table
from aion_cli.engine.state import MapState
from aion_cli.formats.mapfile import write_map
from aion_cli.mapquery import load_map
from tests.engine.state_logs import (
    CFG,
    DAY,
    MORNING,
    Step,
    assert_same_state,
    fixed_sensor_log,
    robot_log,
    run_steps,
)

SLOW = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
#: a log: robot or fixed sensor, windows, days (robot), seed
LOG = st.tuples(st.booleans(), st.integers(1, 7), st.integers(1, 3), st.integers(0, 10**6))


def _log(spec: tuple[bool, int, int, int]) -> list[Step]:
    robot, windows, days, seed = spec
    if robot:
        return robot_log(MORNING, seed, windows=windows, days=days)
    return fixed_sensor_log(MORNING, seed, windows=windows, move=0.4 if seed % 2 else 0.0)


def _saved(state: MapState, path: Path) -> Path:
    arrays, meta = state.to_arrays()
    write_map(path, arrays, {"state": meta})
    return path


def _same_prediction(a: MapState, b: MapState, t_ns: int) -> None:
    pa, pb = predict_table(a, t_ns), predict_table(b, t_ns)
    np.testing.assert_array_equal(pa.key, pb.key)
    np.testing.assert_array_equal(pa.node_id, pb.node_id)
    for name in ("flow", "flow_var", "rate"):
        np.testing.assert_allclose(getattr(pb, name), getattr(pa, name), rtol=1e-9, atol=1e-12,
                                   err_msg=name)
    np.testing.assert_allclose(pb.descriptors.probabilities, pa.descriptors.probabilities,
                               rtol=1e-9, atol=1e-12)


@settings(max_examples=15, deadline=None, suppress_health_check=SLOW)
@given(spec=LOG, hour=st.integers(-48, 24 * 9))
def test_a_map_written_and_read_back_is_itself(
    tmp_path: Path, spec: tuple[bool, int, int, int], hour: int
) -> None:
    state = run_steps(_log(spec)).state
    path = _saved(state, tmp_path / "m.aion")
    for writable in (False, True):
        back = load_map(path, writable=writable).state
        assert differences(state, back) == [], writable
        _same_prediction(state, back, MORNING + hour * 3600 * 10**9)


@settings(max_examples=20, deadline=None, suppress_health_check=SLOW)
@given(spec=LOG, cut=st.floats(0.0, 1.0))
def test_a_log_cut_after_any_message_and_continued_equals_one_build(
    tmp_path: Path, spec: tuple[bool, int, int, int], cut: float
) -> None:
    steps = _log(spec)
    at = 1 + round(cut * (len(steps) - 2))  # after message 1 .. before the last
    first = run_steps(steps[:at]).state
    reread = load_map(_saved(first, tmp_path / "first.aion"), writable=True).state
    continued = run_steps(steps[at:], Mapper(CFG, reread)).state
    assert_same_state(run_steps(steps).state, continued)


@settings(max_examples=25, deadline=None, suppress_health_check=SLOW)
@given(
    specs=st.lists(LOG, min_size=1, max_size=3),
    times=st.lists(
        st.integers(-10 * DAY, 30 * DAY).map(lambda offset: MORNING + offset)
        | st.integers(-(2**63), 2**63 - 1),
        min_size=1,
        max_size=4,
    ),
)
def test_a_prediction_at_any_time_is_finite_non_negative_and_its_histograms_sum_to_one(
    specs: list[tuple[bool, int, int, int]], times: list[int]
) -> None:
    """Logs days apart (so the map scored whole days and chose families), predicted from ten
    days before the first to a month after it, and at any int64 nanosecond time."""
    steps: list[Step] = []
    for k, (robot, windows, days, seed) in enumerate(specs):
        start = MORNING + 4 * k * DAY
        steps += (robot_log(start, seed, windows=windows, days=days) if robot
                  else fixed_sensor_log(start, seed, windows=windows))
    state = run_steps(steps).state
    rows, predictor = state.predictor()
    assert len(rows) > 0
    for t_ns in times:
        pred = predictor.at(t_ns)
        for values in (pred.flow, pred.variance):
            assert np.isfinite(values).all()
            assert (values >= 0).all(), values.min()
        assert ((pred.directed_share >= 0) & (pred.directed_share <= 1)).all()
        # every entry's direction histogram, whatever its flow
        assert np.isfinite(pred.probabilities).all()
        assert (pred.probabilities >= 0).all()
        np.testing.assert_allclose(pred.probabilities.sum(axis=1), 1.0, rtol=0, atol=1e-9)
        table = predict_table(state, t_ns)
        for name in ("flow", "flow_var", "rate"):
            values = getattr(table, name)
            assert np.isfinite(values).all(), name
            assert (values >= 0).all(), (name, values.min())
        # the directed rates are the flow's share of it; the descriptors' histograms sum to 1
        # where there is directed flow, to 0 (no flow) elsewhere
        directed = table.rate.sum(axis=1)
        assert (directed <= table.flow * (1 + 1e-9) + 1e-12).all()
        probs = table.descriptors.probabilities
        assert np.isfinite(probs).all()
        assert (probs >= 0).all()
        flowing = (directed > 0) & (table.flow > 0)
        np.testing.assert_allclose(probs.sum(axis=1), np.where(flowing, 1.0, 0.0), atol=1e-9)
