"""closing_binds and closing_entries say, without closing, which cells closing the open
windows binds and to which places, and which places it gives entries: what close_windows
then does (the join's blocker asks them about the map before a shard)."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.closing import close_windows, closing_binds, closing_entries
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.types import Trajectory
from tests.engine.engine_builders import detections, graph
from tests.engine.state_logs import CFG, MORNING, W

S = 10**9
#: places stable 25 minutes after they appear: 2.5 windows of 10 minutes
SLOW = ModelConfig(window_s=600.0, stability_s=1500.0)
#: places 0, 1 and 2; the bind radius is 1 m
PLACES = [[0, 0, 0], [3, 3, 0], [4.2, 3, 0]]
#: people in the first window: next to place 0, in reach of places 1 and 2 (their cell's
#: centre, (3.75, 3.25), 0.79 m from place 1 and 0.51 m from place 2), far from every place
PEOPLE = np.array([[0.2, 0.0, 0.0], [3.7, 3.0, 0.0], [20.0, 20.0, 0.0]])


def _mapper(fixed: bool) -> Mapper:
    """Places 0 and 1 from 10 s into the first window, place 2 from 400 s: stable at the
    end of the third window and of the fourth. With ``fixed``, a
    fixed sensor covers six windows (each recorded when closed); without, only the first
    window (its detections) is."""
    m = Mapper(SLOW)
    if fixed:
        m.set_fixed_sensor(MORNING, MORNING + 6 * W)
    m.add_graph(graph(MORNING + 10 * S, [0, 1], PLACES[:2]))
    m.add_detections(detections(MORNING + 20 * S + np.arange(3) * S, PEOPLE))
    m.add_graph(graph(MORNING + 400 * S, [0, 1, 2], PLACES))
    return m


@pytest.mark.parametrize(
    ("fixed", "windows", "bound"),
    [
        (True, 6, {0: 0, 1: 1}),  # place 1 is stable first: the second person's cell binds
        # to it, though place 2 is nearer
        (True, 2, {}),  # no place is stable by the end of the second window
        (False, 6, {}),  # one recorded window, ending before any place is stable
    ],
)
def test_closing_binds_predicts_what_closing_binds(
    fixed: bool, windows: int, bound: dict[int, int]
) -> None:
    state = _mapper(fixed).state
    cells = state.entries.cell_rows()
    person_of = {
        int(r): int(np.argmin(np.abs(state.entries.xyz[r] - PEOPLE).sum(1))) for r in cells
    }
    stop = int(state.open_window or 0) + windows
    rows, ids = closing_binds(state, stop)
    predicted = {person_of[int(r)]: int(i) & 0xFF for r, i in zip(rows, ids, strict=True)}
    assert predicted == bound
    keys = state.entries.key[cells].copy()
    close_windows(state, stop)
    nodes, found = state.redirects.lookup(keys)
    done = {
        person_of[int(r)]: int(n) & 0xFF for r, n, f in zip(cells, nodes, found, strict=True) if f
    }
    assert done == bound


def _robot(poses: bool) -> Mapper:
    """Place 0 from 10 s into the first window, where people walk; places 1 (3, 0), 2 (20, 0)
    and 3 (40, 0) from 300 s, stable before the window ends, with no entry (nobody near). The
    robot stands at (1, 1) in the first window (place 1 in its 8 m range), at (19, 0) in the
    second and third (place 2); with ``poses`` false it has no trajectory."""
    m = Mapper(CFG)
    if poses:
        t = MORNING + np.arange(0, 3 * W, 20 * S)
        xyz = np.where((t < MORNING + W)[:, None], [1.0, 1.0, 0.0], [19.0, 0.0, 0.0])
        m.add_trajectory(Trajectory(t, xyz))
    m.add_graph(graph(MORNING + 10 * S, [0], [[0, 0, 0]]))
    m.add_detections(detections(MORNING + 20 * S + np.arange(3) * S, PEOPLE[:1].repeat(3, 0)))
    four = [[0, 0, 0], [3, 0, 0], [20, 0, 0], [40, 0, 0]]
    m.add_graph(graph(MORNING + 300 * S, [0, 1, 2, 3], four))
    return m


@pytest.mark.parametrize(
    ("poses", "windows", "entered"), [(True, 1, {1}), (True, 3, {1, 2}), (False, 3, set())]
)
def test_closing_entries_predicts_the_places_closing_enters(
    poses: bool, windows: int, entered: set[int]
) -> None:
    state = _robot(poses).state
    stop = int(state.open_window or 0) + windows
    predicted = {int(i) & 0xFF for i in closing_entries(state, stop)}
    assert predicted == entered
    before = set(state.entries.node_id[state.entries.node_rows()].tolist())
    close_windows(state, stop)
    after = set(state.entries.node_id[state.entries.node_rows()].tolist())
    assert {int(i) & 0xFF for i in after - before} == entered
