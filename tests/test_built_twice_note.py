"""The note on shards a parallel build learnt twice names why, for each reason the join gives.

It said "because the scene graph changed between them: a Hydra graph that grows or is
corrected binds cells as it goes" whatever the reason was (a graph that moved places inside a
shard's own logs after a day had closed, a place that drifted about the stability tolerance).
Each scenario below is built so that one known reason refuses the join.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from aion_cli.engine.join_blockers import join_blocker
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.shards import start_shard
from aion_cli.engine.state import MapState
from aion_cli.shard_reports import built_twice_note
from tests.engine.engine_builders import graph
from tests.engine.state_logs import (
    CFG,
    DAY,
    MORNING,
    NODES,
    Step,
    W,
    fixed_sensor_log,
    run_steps,
)

HYDRA_BLAME = "binds cells as it goes"


def _with_graphs(start: int, seed: int, *graphs: tuple[int, np.ndarray]) -> list[Step]:
    """A one-day fixed-sensor log whose first graph has the places at ``graphs[0]``'s
    positions, and later graphs (inserted after the first window) at the others'."""
    steps = fixed_sensor_log(start, seed=seed)
    (_, first), *later = graphs
    steps[1] = partial(Mapper.add_graph, snapshot=graph(start, list(range(5)), first))
    for k, (at, xyz) in enumerate(later):
        steps.insert(4 + k, partial(Mapper.add_graph, snapshot=graph(at, list(range(5)), xyz)))
    return steps


def _swapped() -> tuple[list[Step], list[Step]]:
    """The later log's graph has places 0 and 1 at each other's positions: cells near (0, 0)
    go to place 1 in it, to place 0 in the map before."""
    later = MORNING + 3 * DAY
    xyz = np.array(NODES, float)[[1, 0, 2, 3, 4]]
    return fixed_sensor_log(MORNING, seed=50), _with_graphs(later, 51, (later, xyz))


def _vanishing() -> tuple[list[Step], list[Step]]:
    """Places move 0.6 m halfway through each day of a two-day log (and back the next
    morning): ownership changes after the shard's first day had closed."""
    def two_days(first: int, seed: int) -> list[Step]:
        return [
            st
            for d in range(2)
            for st in fixed_sensor_log(MORNING + (first + d) * DAY, seed + d, move=0.6)
        ]

    return two_days(0, 30), two_days(3, 32)


def _drifting() -> tuple[list[Step], list[Step]]:
    """Place 0 is 0.2 m off in the later log's first graph, 0.4 m in a later one: within the
    stability tolerance (0.25 m) of its own first position, beyond it from the earlier one
    (as tests/engine/test_shards.py's drift test)."""
    later = MORNING + 3 * DAY
    first, moved = np.array(NODES, float), np.array(NODES, float)
    first[0, 0] += 0.2
    moved[0, 0] += 0.4
    return fixed_sensor_log(MORNING, seed=50), _with_graphs(
        later, 51, (later, first), (later + W + W // 2, moved)
    )


def _place_added() -> tuple[list[Step], list[Step]]:
    """Both logs' first graph has places 0 to 3; the later log's second graph (15 minutes
    in, after the check at its first window's end) adds place 4, near cells the map before
    left unbound."""
    later = MORNING + 3 * DAY
    four = np.array(NODES, float)[:4]
    before = fixed_sensor_log(MORNING, seed=3, windows=3)
    before[1] = partial(Mapper.add_graph, snapshot=graph(MORNING, [0, 1, 2, 3], four))
    steps = fixed_sensor_log(later, seed=4, windows=3)
    steps[1] = partial(Mapper.add_graph, snapshot=graph(later, [0, 1, 2, 3], four))
    five = graph(later + W + W // 2, list(range(5)), NODES)
    steps.insert(4, partial(Mapper.add_graph, snapshot=five))
    return before, steps


def _never_stable() -> tuple[list[Step], list[Step]]:
    """The map before has no scene graph; the later log, one window long, has one graph at
    its start: its places are stable at none of the log's checks (the graph's own, before
    their 30 s; the next would be at the window's end, after the log)."""
    before = [step for k, step in enumerate(fixed_sensor_log(MORNING, seed=3, windows=3)) if k != 1]
    return before, fixed_sensor_log(MORNING + 3 * DAY, seed=4, windows=1)


@pytest.mark.parametrize(
    ("logs", "cause"),
    [
        (_swapped, "cells bound to other places than the map before them"),
        (_vanishing, "ownership that changed inside their logs after one of their days had closed"),
        (_drifting, "places that drifted about the stability tolerance"),
        # a place new in a later graph, near cells left unbound: since the join checks where
        # each stable place reached (moved there, or new there), it is named for that
        (_place_added, "places that came within reach of cells of the map before them"),
        (_never_stable, "a scene graph stable at none of the ownership checks inside their logs"),
    ],
    ids=[
        "cells-bound-elsewhere",
        "ownership-changed-inside",
        "timers-drifted",
        "place-added-later",
        "never-stable",
    ],
)
def test_the_note_names_the_reason_the_join_was_refused(logs: object, cause: str) -> None:
    before, later = logs()  # type: ignore[operator]
    acc = run_steps(before).state
    shard = run_steps(later, Mapper(CFG, start_shard(MapState.empty(CFG)))).state
    blocker = join_blocker(acc, shard)
    assert blocker is not None
    assert blocker.cause == cause
    note = built_twice_note([blocker.cause], 3)
    assert note.startswith(
        f"1 of 3 shards was built twice (in a worker, then in sequence) because of {cause}, "
    ), note
    assert HYDRA_BLAME not in note
    assert "--workers 1 is faster" in note


def test_several_reasons_are_counted_each() -> None:
    causes = [
        "cells bound to other places than the map before them",
        "places that drifted about the stability tolerance",
        "cells bound to other places than the map before them",
    ]
    note = built_twice_note(causes, 4)
    assert note.startswith(
        "3 of 4 shards were built twice (in a worker, then in sequence) because of cells bound "
        "to other places than the map before them (2) and places that drifted about the "
        "stability tolerance (1), "
    ), note
