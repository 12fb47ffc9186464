"""A shard that recorded windows before its first scene graph, joined onto a map with a
graph: one pass closed those windows with the earlier map's places (binding the shard's
cells near them, and entering the places the robot saw), which the shard could not.
join_blocker refuses such joins (the build then learns the logs in sequence)."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from aion_cli.engine.join_blockers import join_blocker
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.shards import join_shard, start_shard
from aion_cli.engine.state import MapState
from tests.engine.engine_builders import check_invariants, detections, graph
from tests.engine.state_logs import (
    CFG,
    DAY,
    MORNING,
    NODES,
    Step,
    W,
    assert_same_state,
    fixed_sensor_log,
    robot_log,
    run_steps,
)


def _people_near_p2_then_graph(start: int, seed: int) -> list[Step]:
    """A fixed-sensor log with three people at (0.1, 3.9) in its first window (0.79 m from
    place 2 of the earlier map's graph, in reach) and its graph only at that window's end,
    place 2 0.3 m lower (out of reach of them), then the fixed-sensor log's other windows."""
    steps = fixed_sensor_log(start, seed=seed)
    moved = np.array(NODES, float)
    moved[2, 1] -= 0.3
    t = start + np.array([60, 120, 180]) * 10**9
    near = detections(t, np.array([[0.1, 3.9, 0.0]] * 3), np.zeros(3), np.ones(3))
    first = graph(start + W, list(range(5)), moved)
    return [
        steps[0],
        partial(Mapper.add_detections, batch=near),
        partial(Mapper.add_graph, snapshot=first),
        *steps[3:],
    ]


def _robot_then_graph_without_p4(start: int, seed: int) -> list[Step]:
    """A robot log whose first window has no graph, then a graph without place 4."""
    steps = robot_log(start, seed=seed)
    first = graph(start + W, [0, 1, 2, 3], np.array(NODES)[:4])
    return [steps[0], steps[2], partial(Mapper.add_graph, snapshot=first), *steps[3:]]


#: people only near places 0..2: the earlier map's place 4 has no entry
_SPOTS = np.array([[0.0, 0.5, 0.0], [2.5, 0.0, 0.0], [0.5, 2.5, 0.0]])


@pytest.mark.parametrize(
    ("earlier", "later", "reason"),
    [
        (  # one pass bound the people's cell to place 2 at the first window's end
            fixed_sensor_log(MORNING, seed=50),
            _people_near_p2_then_graph(MORNING + 3 * DAY, 150),
            "one pass bound their cells to the places of the map before them",
        ),
        (  # one pass gave place 4 an entry where the robot saw it, released at the graph
            fixed_sensor_log(MORNING, seed=51, spots=_SPOTS),
            _robot_then_graph_without_p4(MORNING + 3 * DAY, 151),
            "the robot of these logs saw places of the map before them",
        ),
    ],
    ids=["cells-bound-before-the-graph", "robot-saw-places-before-the-graph"],
)
def test_windows_before_the_first_graph_after_a_map_with_one_are_refused(
    earlier: list[Step], later: list[Step], reason: str
) -> None:
    whole = run_steps(earlier + later).state
    acc = run_steps(earlier).state
    shard = run_steps(later, Mapper(CFG, start_shard(MapState.empty(CFG)))).state
    blocker = join_blocker(acc, shard)
    assert blocker is not None
    assert reason in blocker
    joined = join_shard(acc, shard)  # forced anyway: counts kept, the map differs
    check_invariants(joined)
    live_w, live_j = whole.entries.live_rows(), joined.entries.live_rows()
    assert joined.entries.counts[live_j].sum() == whole.entries.counts[live_w].sum()
    with pytest.raises(AssertionError):
        assert_same_state(whole, joined)


def test_a_graph_after_the_first_window_that_binds_as_the_earlier_one_did_is_joined() -> None:
    """The same places, at the same positions, from the later log's second window on: one
    pass bound its first window's cells with the earlier map's places, the shard with its
    own at the next check; the join is exact and accepted."""
    steps = fixed_sensor_log(MORNING + 3 * DAY, seed=152)
    first = graph(MORNING + 3 * DAY + W, list(range(5)), np.array(NODES))
    later = [steps[0], steps[2], partial(Mapper.add_graph, snapshot=first), *steps[3:]]
    earlier = fixed_sensor_log(MORNING, seed=52)
    acc = run_steps(earlier).state
    shard = run_steps(later, Mapper(CFG, start_shard(MapState.empty(CFG)))).state
    assert join_blocker(acc, shard) is None
    assert_same_state(run_steps(earlier + later).state, join_shard(acc, shard))
