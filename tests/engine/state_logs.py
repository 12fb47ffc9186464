"""Logs built in memory for the MapState tests: each log is a list of steps (calls on an engine
:class:`~aion_cli.engine.mapper.Mapper`) over a graph of five places, detections in several
10-minute windows, a fixed sensor or a robot driving. Shared by ``test_state.py``,
``test_state_merge.py``, ``test_shards.py`` and ``tests/test_merging*.py``."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from aion_cli.engine.compare import differences
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.state import MapState
from aion_cli.engine.types import Trajectory
from tests.engine.engine_builders import T0_DAY_END, S, detections, graph

#: the model of every map built here: 10-minute windows, places stable after 30 s
CFG = ModelConfig(window_s=600.0, stability_s=30.0)
W = 600 * S  # a window of CFG
DAY = 86400 * S
HOUR = 3600 * S
#: the places of every log's graph, p0..p4
NODES = [[0, 0, 0], [3, 0, 0], [0, 3, 0], [3, 3, 0], [6, 6, 0.0]]
#: 08:00 on the day after T0's
MORNING = T0_DAY_END + 8 * HOUR

#: one step of a log: a call on the Mapper
Step = Callable[[Mapper], object]


def fixed_sensor_log(
    start: int, seed: int, windows: int = 6, move: float = 0.0, spots: np.ndarray | None = None
) -> list[Step]:
    """One "log": a graph, a fixed sensor over its span, detections in several windows.

    With ``spots`` every detection is at one of those positions and the first window visits
    all of them (so every entry exists from the log's first window on).
    """
    rng = np.random.default_rng(seed)
    steps: list[Step] = []
    end = start + windows * W
    steps.append(lambda m: m.set_fixed_sensor(start, end))
    steps.append(lambda m: m.add_graph(graph(start, list(range(5)), np.array(NODES))))
    for w in range(windows):
        n = int(rng.integers(5, 60)) if spots is None else int(rng.integers(len(spots), 90))
        t = start + w * W + np.sort(rng.integers(0, W, n))
        if spots is None:
            xyz = np.c_[rng.uniform(-1, 8, (n, 2)), np.zeros(n)]
        else:
            pick = rng.integers(0, len(spots), n)
            if w == 0:
                pick[: len(spots)] = np.arange(len(spots))
            xyz = spots[pick]
        heading = np.where(rng.random(n) < 0.1, np.nan, rng.uniform(-np.pi, np.pi, n))
        batch = detections(t, xyz, heading, rng.uniform(0.2, 2, n))
        steps.append(partial(Mapper.add_detections, batch=batch))
        if w == windows // 2 and move:
            moved = np.array(NODES) + np.array([move, 0, 0])
            g_moved = graph(start + w * W + W // 2, [0, 1, 2, 3], moved[:4])
            steps.append(partial(Mapper.add_graph, snapshot=g_moved))
    return steps


def robot_log(start: int, seed: int, windows: int = 6, days: int = 1) -> list[Step]:
    """A robot's log: it drives along a line through the floor (sensor range covers part of
    it), people appear everywhere; a graph of five places."""
    rng = np.random.default_rng(seed)
    steps: list[Step] = []
    for d in range(days):
        t0 = start + d * DAY
        t = t0 + np.arange(0, windows * W, 20 * 10**9)
        x = 4 + 4 * np.sin(np.arange(t.size) / 7.0 + seed)
        traj = Trajectory(t, np.c_[x, np.full(t.size, 1.0), np.zeros(t.size)])
        steps.append(partial(Mapper.add_trajectory, trajectory=traj))
        steps.append(lambda m, t0=t0: m.add_graph(graph(t0, list(range(5)), np.array(NODES))))
        for w in range(windows):
            n = int(rng.integers(5, 40))
            tw = t0 + w * W + np.sort(rng.integers(0, W, n))
            xyz = np.c_[rng.uniform(-1, 12, (n, 2)), np.zeros(n)]
            batch = detections(tw, xyz, rng.uniform(-np.pi, np.pi, n), rng.uniform(0.2, 2, n))
            steps.append(partial(Mapper.add_detections, batch=batch))
    return steps


def run_steps(steps: list[Step], m: Mapper | None = None) -> Mapper:
    """The steps applied in order to ``m`` (a new Mapper of :data:`CFG` when None)."""
    m = m if m is not None else Mapper(CFG)
    for step in steps:
        step(m)
    return m


def assert_same_state(a: MapState, b: MapState, rtol: float = 1e-12) -> None:
    """Equal maps: metadata and integer members exactly, float members to ``rtol``."""
    problems = differences(a, b, rtol)
    assert not problems, "\n".join(problems)


def fold_in_earlier_map(
    make_maps: Callable[[], list[MapState]], exact: tuple[str, ...]
) -> MapState:
    """``aion merge``'s fold of the maps ``make_maps()`` gives, built in place (``consume``),
    checked against the pairwise fold of copies (each step built in the later map): the
    result is the first map's own storage, the same state, consistent, and the same to the
    bit in the ``exact`` members (sums of one value per map, or min/max). Returns the fold."""
    from aion_cli.engine.compare import pending_sorted, plain
    from aion_cli.engine.merge import merge_maps
    from tests.engine.engine_builders import check_invariants

    def fold(maps: list[MapState], consume: bool) -> MapState:
        acc = maps[0]
        for state in maps[1:]:
            acc = merge_maps(acc, state, consume=consume)
        return acc

    pairwise = fold(make_maps(), consume=False)  # copies: always built in the later map
    maps = make_maps()
    built = fold(maps, consume=True)
    assert built is maps[0]  # before: every step was built in the later map, copying the fold
    assert_same_state(pairwise, built)
    check_invariants(built)
    a, b = (pending_sorted(plain(s.to_arrays()[0])) for s in (pairwise, built))
    for name in exact:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    return built
