"""Parallel-build shards joined in time order equal one pass over all their logs."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.join_blockers import join_blocker
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.shards import join_shard, start_shard
from aion_cli.engine.state import MapState
from tests.engine.engine_builders import check_invariants
from tests.engine.state_logs import (
    CFG,
    DAY,
    MORNING,
    Step,
    W,
    assert_same_state,
    fixed_sensor_log,
    robot_log,
    run_steps,
)


def _days(start: int, seed: int, days: int, windows: int = 5) -> list[Step]:
    """A multi-day log: ``windows`` windows from 08:00 on each of ``days`` days."""
    steps: list[Step] = []
    for d in range(days):
        steps += fixed_sensor_log(start + d * DAY, seed=seed * 100 + d, windows=windows)
    return steps


def _moving(start: int, seed: int, days: int, extra: bool = False, move: bool = True) -> list[Step]:
    """Fixed-sensor days whose graph (five places, or six with ``extra``: one more at
    (9, 9), where people also walk) moves by 0.6 m halfway through each day (with ``move``)
    and back at the start of the next."""
    from functools import partial

    from tests.engine.engine_builders import detections, graph
    from tests.engine.state_logs import NODES

    nodes = np.array([*NODES, [9.0, 9.0, 0.0]] if extra else NODES)
    ids = list(range(len(nodes)))
    rng = np.random.default_rng(seed)
    steps: list[Step] = []
    for d in range(days):
        t0 = start + d * DAY
        steps.append(lambda m, t0=t0: m.set_fixed_sensor(t0, t0 + 6 * W))
        steps.append(lambda m, t0=t0: m.add_graph(graph(t0, ids, nodes)))
        for w in range(6):
            n = int(rng.integers(5, 60))
            t = t0 + w * W + np.sort(rng.integers(0, W, n))
            xyz = np.c_[rng.uniform(-1, 10, (n, 2)), np.zeros(n)]
            batch = detections(t, xyz, rng.uniform(-np.pi, np.pi, n), rng.uniform(0.2, 2, n))
            steps.append(partial(Mapper.add_detections, batch=batch))
            if w == 3 and move:
                moved = graph(t0 + w * W + W // 2, ids, nodes + np.array([0.6, 0, 0]))
                steps.append(partial(Mapper.add_graph, snapshot=moved))
    return steps


def _robot_at_p0(
    start: int, seed: int, windows: int, graphs: list[tuple[int, list[int]]]
) -> list[Step]:
    """A robot standing at (1, 1) (places 0 and 1 in its range), people near place 0 only;
    ``graphs``: (window, places) a graph of those places comes in, halfway through it."""
    from functools import partial

    from aion_cli.engine.types import Trajectory
    from tests.engine.engine_builders import detections, graph
    from tests.engine.state_logs import NODES

    rng = np.random.default_rng(seed)
    t = start + np.arange(0, windows * W, 20 * 10**9)
    still = Trajectory(t, np.tile([1.0, 1.0, 0.0], (t.size, 1)))
    steps: list[Step] = [partial(Mapper.add_trajectory, trajectory=still)]
    for w in range(windows):
        for at, ids in graphs:
            if at == w:
                g = graph(start + w * W + W // 2, ids, np.array(NODES)[ids])
                steps.append(partial(Mapper.add_graph, snapshot=g))
        tw = start + w * W + np.sort(rng.integers(0, W, 20))
        xyz = np.c_[rng.uniform(-1, 1, (20, 2)), np.zeros(20)]
        batch = detections(tw, xyz, rng.uniform(-3, 3, 20), rng.uniform(0.2, 2, 20))
        steps.append(partial(Mapper.add_detections, batch=batch))
    return steps


def _graph_last(start: int, seed: int) -> list[Step]:
    """A two-window fixed-sensor log whose only graph comes after its detections, in its last
    nanosecond: none of its own checks sees the places stable."""
    from tests.engine.engine_builders import graph
    from tests.engine.state_logs import NODES

    steps = fixed_sensor_log(start, seed, windows=2)
    last = graph(start + 2 * W - 1, list(range(5)), np.array(NODES))
    return [steps[0], *steps[2:], lambda m: m.add_graph(last)]


def _joined(
    logs: list[list[Step]], acc: MapState | None = None, blockers: list[str | None] | None = None
) -> MapState:
    """The logs built as shards and joined in order; what :func:`join_blocker` said about
    each join goes to ``blockers`` (the joins that must be exact expect None)."""
    state = acc if acc is not None else MapState.empty(CFG)
    for steps in logs:
        shard = run_steps(steps, Mapper(CFG, start_shard(MapState.empty(CFG)))).state
        reason = join_blocker(state, shard)
        if blockers is None:
            assert reason is None, reason
        else:
            blockers.append(reason)
        state = join_shard(state, shard)
    return state


@pytest.mark.parametrize(
    "logs",
    [
        # three multi-day logs with gaps of days between them
        [_days(MORNING, 1, 3), _days(MORNING + 5 * DAY, 2, 2), _days(MORNING + 9 * DAY, 3, 3)],
        # back to back: the next log starts on the day the previous one ends
        [
            _days(MORNING, 4, 2),
            fixed_sensor_log(MORNING + DAY + 10 * W, seed=5),
            _days(MORNING + 2 * DAY, 6, 1),
        ],
        # one day each
        [
            fixed_sensor_log(MORNING, seed=7),
            fixed_sensor_log(MORNING + DAY, seed=8),
            fixed_sensor_log(MORNING + 3 * DAY, seed=9),
        ],
    ],
    ids=["gaps", "same-day", "single-days"],
)
def test_shards_joined_in_time_order_equal_one_pass(logs: list[list[Step]]) -> None:
    whole = run_steps([step for steps in logs for step in steps]).state
    joined = _joined(logs)
    check_invariants(joined)
    assert whole.temporal.flow_scored.sum() > 0  # days were scored: the join had to rescore
    assert_same_state(whole, joined)


def test_a_shard_joined_onto_a_continued_map_equals_one_pass() -> None:
    first, second = _days(MORNING, 11, 3), _days(MORNING + 4 * DAY, 12, 2)
    whole = run_steps(first + second).state
    joined = _joined([second], acc=run_steps(first).state)
    assert_same_state(whole, joined)


def test_a_shard_without_the_other_shards_scores_differently() -> None:
    """The join is not trivially equal: scoring the later log against its own history only
    (an ordinary build of it, merged) gives other day-ahead scores than one pass."""
    first, second = _days(MORNING, 13, 3), _days(MORNING + 4 * DAY, 14, 3)
    whole = run_steps(first + second).state
    alone = run_steps(second).state
    shard_scores = alone.temporal.flow_score.sum()
    joined = _joined([first, second])
    assert joined.temporal.flow_score.sum() == pytest.approx(whole.temporal.flow_score.sum())
    assert whole.temporal.flow_score.sum() != pytest.approx(
        run_steps(first).state.temporal.flow_score.sum() + shard_scores
    )


def test_only_an_empty_map_starts_a_shard_and_only_shards_join() -> None:
    busy = run_steps(fixed_sensor_log(MORNING, seed=15)).state
    with pytest.raises(ValueError, match="empty map"):
        start_shard(busy)
    with pytest.raises(ValueError, match="start_shard"):
        join_shard(MapState.empty(CFG), run_steps(fixed_sensor_log(MORNING, seed=16)).state)
    np.testing.assert_equal(busy.deferred, None)


def test_robot_shards_record_the_empty_windows_of_cells_earlier_shards_made() -> None:
    logs = [robot_log(MORNING, 21, days=2), robot_log(MORNING + 3 * DAY, 22, days=2)]
    whole = run_steps([step for steps in logs for step in steps]).state
    joined = _joined(logs)
    check_invariants(joined)
    assert_same_state(whole, joined)


def test_a_graph_new_in_a_later_shard_binds_the_earlier_cells_it_covers() -> None:
    """The second log's graph has a place more, at (9, 9), where the first log left unbound
    cells: the join binds them to it, as one pass does once the place is stable."""
    logs = [
        _moving(MORNING, 40, days=1, move=False),
        _moving(MORNING + 3 * DAY, 41, 2, True, False),
    ]
    whole = run_steps([step for steps in logs for step in steps]).state
    joined = _joined(logs)
    assert_same_state(whole, joined)
    node = joined.node_entry_rows(joined.nodes.ids[-1:])
    assert node[0] >= 0
    assert joined.entries.counts[node].sum() > 0


def _jittering(start: int, seed: int, leave: bool = False, visit: bool = False) -> list[Step]:
    """A fixed-sensor log whose graph has place 2 0.2 m nearer (0, 2.8) for two windows
    (within the stability tolerance: its timer runs on), or without it (``leave``), or a
    sixth place at (1.5, 1.5) (``visit``), and then is as it was."""
    from functools import partial

    from tests.engine.engine_builders import graph
    from tests.engine.state_logs import NODES

    steps = fixed_sensor_log(start, seed=seed)
    home, moved = np.array(NODES, float), np.array(NODES, float)
    moved[2, 1] -= 0.2
    ids = [0, 1, 3, 4] if leave else list(range(6 if visit else 5))
    xyz = home[ids] if leave else np.r_[home, [[1.5, 1.5, 0.0]]] if visit else moved
    between = graph(start + 2 * W, ids, xyz)
    steps.insert(4, partial(Mapper.add_graph, snapshot=between))
    steps.insert(7, partial(Mapper.add_graph, snapshot=graph(start + 4 * W, list(range(5)), home)))
    return steps


@pytest.mark.parametrize(
    ("logs", "reason"),
    [
        (  # every place moves halfway through each day and back the next morning
            [_moving(MORNING, 30, days=2), _moving(MORNING + 3 * DAY, 32, days=2, extra=True)],
            "ownership changed inside these logs",
        ),
        (  # a place leaves the graph every day and returns the next
            [
                [
                    st
                    for d in range(2)
                    for st in fixed_sensor_log(MORNING + d * DAY, seed=30 + d, move=0.6)
                ],
                [
                    st
                    for d in range(2)
                    for st in fixed_sensor_log(MORNING + (3 + d) * DAY, 32 + d, move=0.6)
                ],
            ],
            "ownership changed inside these logs",
        ),
        (  # no graph before; a one-window log whose graph is stable at none of its checks:
            # one pass leaves the earlier cells unbound, the join would bind them
            [
                [st for k, st in enumerate(fixed_sensor_log(MORNING, 34, windows=3)) if k != 1],
                fixed_sensor_log(MORNING + 3 * DAY, seed=35, windows=1),
            ],
            "stable at none of their ownership checks",
        ),
        (  # place 1 comes in the earlier log's last window: the robot observes it stable
            # when the join closes that window (an entry, empty), and the later log's first
            # graph lacks it (one pass releases that entry, then binds its cell again)
            [
                _robot_at_p0(MORNING, 36, 2, [(0, [0]), (1, [0, 1])]),
                _robot_at_p0(MORNING + 3 * DAY, 37, 3, [(0, [0]), (1, [0, 1])]),
            ],
            "lacks places of the map before them",
        ),
        (  # the later log's only graph comes at its end: one pass, with the timers the
            # earlier log gave the places, binds the later log's cells near them there
            [fixed_sensor_log(MORNING, seed=38, windows=2), _graph_last(MORNING + 3 * DAY, 39)],
            "stable at none of their ownership checks",
        ),
        (  # no graph before; the later log's place 4 (near cells the earlier log made)
            # leaves its graph halfway: one pass released what those cells held into the
            # place's cell, the join left them where they were
            [
                [st for k, st in enumerate(fixed_sensor_log(MORNING, 40, windows=3)) if k != 1],
                fixed_sensor_log(MORNING + 3 * DAY, seed=41, move=0.1),
            ],
            "left the graph later on",
        ),
        (  # the later log's place 2 comes 0.2 m nearer cells the earlier log left unbound
            # for two windows: one pass binds them at its check there, the join knows the
            # place's first and last positions (out of reach) only
            [fixed_sensor_log(MORNING, seed=51), _jittering(MORNING + 3 * DAY, 151)],
            "came within reach of cells of the map before them",
        ),
        (  # the later log's graph lacks place 2 for two windows: one pass released the
            # earlier log's entry of it and dropped the redirects to it, the join kept them
            [fixed_sensor_log(MORNING, seed=50), _jittering(MORNING + 3 * DAY, 150, leave=True)],
            "left the scene graph during them and came back",
        ),
        (  # a place new in the later log's graph for two windows, amid cells the earlier log
            # left unbound: one pass bound them to it there and released them when it left
            [fixed_sensor_log(MORNING, seed=52), _jittering(MORNING + 3 * DAY, 152, visit=True)],
            "came within reach of cells of the map before them",
        ),
    ],
    ids=[
        "moving-places",
        "vanishing-place",
        "never-stable",
        "entered-at-the-join",
        "graph-at-the-end",
        "place-left-later",
        "place-jittered-into-reach",
        "place-left-and-came-back",
        "place-came-and-went",
    ],
)
def test_joins_that_would_not_be_exact_say_why(logs: list[list[Step]], reason: str) -> None:
    """What engine/shards.py cannot join exactly is refused by join_blocker (the parallel
    build then learns those logs in sequence). Forced anyway, the join still conserves
    counts (and differs from one pass, or the blocker would be needless)."""
    whole = run_steps([step for steps in logs for step in steps]).state
    blockers: list[str | None] = []
    joined = _joined(logs[1:], acc=run_steps(logs[0]).state, blockers=blockers)  # as a build does
    assert blockers[0] is not None
    assert reason in blockers[0]
    check_invariants(joined)
    live_w, live_j = whole.entries.live_rows(), joined.entries.live_rows()
    assert joined.entries.counts[live_j].sum() == whole.entries.counts[live_w].sum()
    assert joined.accepted == whole.accepted
    with pytest.raises(AssertionError):
        assert_same_state(whole, joined)


def _drifting(start: int, seed: int) -> list[Step]:
    """A one-day log whose first graph has place 0 0.2 m from where the earlier logs had it
    and a later graph 0.4 m: within the stability tolerance (0.25 m) of the log's own first
    position all along, beyond it from the earlier reference."""
    from functools import partial

    from tests.engine.engine_builders import graph
    from tests.engine.state_logs import NODES

    steps = fixed_sensor_log(start, seed=seed)
    first, later = np.array(NODES, float), np.array(NODES, float)
    first[0, 0] += 0.2
    later[0, 0] += 0.4
    steps[1] = partial(Mapper.add_graph, snapshot=graph(start, list(range(5)), first))
    steps.insert(
        4, partial(Mapper.add_graph, snapshot=graph(start + W + W // 2, list(range(5)), later))
    )
    return steps


def test_a_place_that_drifts_from_the_earlier_reference_is_refused() -> None:
    """One pass restarts place 0's stability timer at the second graph of the later log (it
    is 0.4 m from the reference the earlier log left); the shard does not (0.2 m from its
    own first position). The join gave the earlier timer silently; it is now refused, and
    forced anyway it differs from one pass (in that timer)."""
    logs = [fixed_sensor_log(MORNING, seed=50), _drifting(MORNING + 3 * DAY, 51)]
    whole = run_steps([step for steps in logs for step in steps]).state
    blockers: list[str | None] = []
    joined = _joined(logs[1:], acc=run_steps(logs[0]).state, blockers=blockers)
    assert blockers[0] is not None
    assert "stability timers" in blockers[0]
    with pytest.raises(AssertionError, match="stable_since"):
        assert_same_state(whole, joined)


def test_a_place_that_moves_within_the_tolerance_of_both_joins_exactly() -> None:
    """The same later log with place 0 0.1 m off at first and 0.2 m later: within the
    tolerance of the earlier reference all along, so one pass keeps the earlier timer and
    the join gives it."""
    from functools import partial

    from tests.engine.engine_builders import graph
    from tests.engine.state_logs import NODES

    start = MORNING + 3 * DAY
    steps = _drifting(start, 52)
    first, later = np.array(NODES, float), np.array(NODES, float)
    first[0, 0] += 0.1
    later[0, 0] += 0.2
    steps[1] = partial(Mapper.add_graph, snapshot=graph(start, list(range(5)), first))
    steps[4] = partial(Mapper.add_graph, snapshot=graph(start + W + W // 2, list(range(5)), later))
    logs = [fixed_sensor_log(MORNING, seed=50), steps]
    whole = run_steps([step for steps in logs for step in steps]).state
    joined = _joined(logs[1:], acc=run_steps(logs[0]).state)
    assert_same_state(whole, joined)
    assert joined.nodes.stable_since_ns.min() < start  # the earlier timer, kept


def _rooms(
    start: int, seed: int, parents: list[list[int]], where: tuple[float, float] = (-1, 7)
) -> list[Step]:
    """Fixed-sensor days, one per entry of ``parents``: each starts with the five places in
    the rooms ``parents[d]`` (room index per place), then people walk in the square ``where``
    (x and y range; the places lie in the default one)."""
    from functools import partial

    from tests.engine.engine_builders import detections, graph
    from tests.engine.state_logs import NODES

    rng = np.random.default_rng(seed)
    steps: list[Step] = []
    for d, rooms in enumerate(parents):
        t0 = start + d * DAY
        steps.append(lambda m, t0=t0: m.set_fixed_sensor(t0, t0 + 6 * W))
        steps.append(partial(Mapper.add_graph, snapshot=graph(t0, list(range(5)), NODES, rooms)))
        for w in range(6):
            n = int(rng.integers(20, 80))
            t = t0 + w * W + np.sort(rng.integers(0, W, n))
            xyz = np.c_[rng.uniform(*where, (n, 2)), np.zeros(n)]
            batch = detections(t, xyz, rng.uniform(-np.pi, np.pi, n), rng.uniform(0.2, 2, n))
            steps.append(partial(Mapper.add_detections, batch=batch))
    return steps


def test_a_shard_whose_rooms_change_after_a_held_day_is_refused() -> None:
    """Place 2 moves from room 1 to room 0 at the start of the later log's second day: its
    first day was held, and one pass pooled that day by the rooms it had then, the join by
    the rooms at the end (forced, its direction scores differ). Refused; with the same rooms
    on every day the join is exact."""
    first = _rooms(MORNING, 60, [[0, 0, 1, 1, 1]])
    moved = _rooms(MORNING + 3 * DAY, 61, [[0, 0, 1, 1, 1], [0, 0, 0, 1, 1], [0, 0, 0, 1, 1]])
    blockers: list[str | None] = []
    forced = _joined([moved], acc=run_steps(first).state, blockers=blockers)
    assert blockers[0] is not None
    assert "other rooms" in blockers[0]
    with pytest.raises(AssertionError, match="temporal_dir_score"):  # the refusal is needed
        assert_same_state(run_steps(first + moved).state, forced)
    same = _rooms(MORNING + 3 * DAY, 61, [[0, 0, 1, 1, 1]] * 3)
    whole = run_steps(first + same).state
    assert_same_state(whole, _joined([same], acc=run_steps(first).state))


def test_a_shard_that_held_a_day_before_its_first_graph_compares_the_earlier_rooms() -> None:
    """The later log's first day has no graph and people far from the places (nothing binds:
    one pass pooled that day by the earlier log's rooms); its graph, from the second day on,
    puts place 2 in another room: refused."""
    first = _rooms(MORNING, 62, [[0, 0, 1, 1, 1]])
    later = _rooms(MORNING + 3 * DAY, 63, [[0, 0, 0, 1, 1]] * 2, where=(30, 40))
    day = _rooms(MORNING + 2 * DAY, 64, [[0, 0, 0, 1, 1]], where=(30, 40))
    no_graph = [step for k, step in enumerate(day) if k != 1]  # the day without its graph
    blockers: list[str | None] = []
    _joined([no_graph + later], acc=run_steps(first).state, blockers=blockers)
    assert blockers[0] is not None
    assert "other rooms" in blockers[0]


def test_a_part_map_keeps_that_its_checks_reached_cells_near_places_not_yet_stable() -> None:
    """``aion build --part`` then ``aion merge``: the shard of the graph-at-the-end case goes
    through its saved arrays and is still refused (one pass binds its cells at that graph)."""
    first = fixed_sensor_log(MORNING, seed=38, windows=2)
    later = _graph_last(MORNING + 3 * DAY, 39)
    shard = run_steps(later, Mapper(CFG, start_shard(MapState.empty(CFG)))).state
    reread = MapState.from_arrays(*shard.to_arrays())
    assert reread.deferred is not None
    assert reread.deferred.unstable_keys.size
    blocker = join_blocker(run_steps(first).state, reread)
    assert blocker is not None
    assert "stable at none of their ownership checks" in blocker


def test_a_part_map_keeps_where_its_stable_places_reached() -> None:
    """``aion build --part`` then ``aion merge``: the shard of the place-came-and-went case
    goes through its saved arrays and is still refused (one pass bound the earlier cells to
    the place that came and went)."""
    later = _jittering(MORNING + 3 * DAY, 152, visit=True)
    shard = run_steps(later, Mapper(CFG, start_shard(MapState.empty(CFG)))).state
    reread = MapState.from_arrays(*shard.to_arrays())
    assert shard.deferred is not None
    assert shard.deferred.reach is not None
    assert reread.deferred is not None
    assert reread.deferred.reach is not None
    for kept, saved in zip(reread.deferred.reach, shard.deferred.reach, strict=True):
        np.testing.assert_array_equal(kept, saved)
    assert np.isin(shard.nodes.ids, reread.deferred.reach[0]).all()
    assert reread.deferred.reach[0].size == len(shard.nodes) + 1  # the place that went
    blocker = join_blocker(run_steps(fixed_sensor_log(MORNING, seed=52)).state, reread)
    assert blocker is not None
    assert "came within reach of cells of the map before them" in blocker
