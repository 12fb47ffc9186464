"""Where in its bin the flow goes: each entry keeps the sums of its headings' unit vectors per
direction bin, so the dominant direction is the circular mean of the detections' headings and
not of the bins' centres. The bins' edges fall on the axes (the paper's convention), so before
this a corridor along +x was drawn at 22.5°, its bin's centre."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.descriptors import bin_centres, historical
from aion_cli.engine.entries import HEADING_SUMS, EntryStore
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.query import ROOM, aggregate_table, historical_table, predict_table
from aion_cli.engine.types import Layer
from tests.engine.engine_builders import T0, S, detections, graph, pid

CFG = ModelConfig(window_s=600.0, stability_s=0.0)
W = 600 * S


def _corridor(headings: list[float], at: tuple[float, float] = (0.1, 0.1)) -> Mapper:
    """One observed window; detections at one cell with these headings (radians)."""
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 2 * W)
    m.add_detections(detections(T0 + S, [[at[0], at[1], 0.0]] * len(headings), heading=headings))
    m.advance(T0 + W)
    return m


def _only_row(table_descriptors: np.ndarray, flow: np.ndarray) -> float:
    (row,) = np.flatnonzero(np.nan_to_num(flow) > 0)
    return float(table_descriptors[row])


def _expected_angle(probabilities: np.ndarray, headings: np.ndarray) -> float:
    """The circular mean of ``probabilities`` over the 8 bins, each bin at the mean direction
    of the ``headings`` that fall in it (the bin's centre if none), worked out here from the
    headings themselves."""
    bins = len(probabilities)
    of = np.floor((np.asarray(headings) + math.pi) / (2 * math.pi / bins)).astype(int) % bins
    c = s = 0.0
    for b, p in enumerate(probabilities):
        mine = np.asarray(headings)[of == b]
        if len(mine):
            direction = math.atan2(np.sin(mine).sum(), np.cos(mine).sum())
        else:
            direction = -math.pi + (b + 0.5) * 2 * math.pi / bins
        c += p * math.cos(direction)
        s += p * math.sin(direction)
    return math.atan2(s, c)


def test_a_corridor_along_x_points_along_x_not_at_the_bins_centre() -> None:
    # headings of people walking along +x, with a little noise either side of 0: the bins'
    # edge at 0 splits them between the bins centred at -22.5 and +22.5 degrees
    rng = np.random.default_rng(3)
    east = rng.normal(0.0, math.radians(4.0), 200)
    d = historical_table(_corridor(list(east)).state).descriptors
    angle = _only_row(d.mean_angle, d.flow_per_window)
    row = np.flatnonzero(np.nan_to_num(d.flow_per_window) > 0)[0]
    assert angle == pytest.approx(_expected_angle(d.probabilities[row], east), abs=1e-9)
    assert abs(math.degrees(angle)) < 1.5  # the bins' centres would say 22.5 or -22.5
    # the dominant direction: the mean heading of the larger side, a few degrees off 0
    larger = east[east >= 0] if (east >= 0).sum() > (east < 0).sum() else east[east < 0]
    dominant = _only_row(d.dominant_angle, d.flow_per_window)
    assert dominant == pytest.approx(math.atan2(np.sin(larger).sum(), np.cos(larger).sum()))
    assert abs(math.degrees(dominant)) < 6.0
    # all of them on one side of the edge: the mean of the headings, not 22.5 degrees
    ten = math.radians(10.0)
    d = historical_table(_corridor([ten] * 5).state).descriptors
    assert _only_row(d.dominant_angle, d.flow_per_window) == pytest.approx(ten, abs=1e-12)
    assert _only_row(d.mean_angle, d.flow_per_window) == pytest.approx(ten, abs=1e-12)
    assert _only_row(d.concentration, d.flow_per_window) == pytest.approx(1.0)


def test_the_predicted_direction_keeps_the_headings_too() -> None:
    """A forecast weighs each bin by its predicted rate; the bin still points where its
    detections went."""
    headings = np.radians([10.0] * 5 + [-170.0] * 2)
    m = _corridor(list(headings))
    d = predict_table(m.state, T0 + 3 * W).descriptors
    angle = _only_row(d.mean_angle, d.flow_per_window)
    row = np.flatnonzero(np.nan_to_num(d.flow_per_window) > 0)[0]
    assert angle == pytest.approx(_expected_angle(d.probabilities[row], headings), abs=1e-12)
    centres_only = _expected_angle(d.probabilities[row], np.zeros(0))
    assert abs(angle - centres_only) > math.radians(5.0)  # the headings made a difference
    # the most frequent bin, [0, 45), where five walked at exactly 10 degrees
    assert _only_row(d.dominant_angle, d.flow_per_window) == pytest.approx(math.radians(10.0))


def test_bins_without_sums_are_described_by_their_centres() -> None:
    """Maps written before the sums read them as zeros: the descriptors are those of before
    (the bins' centres), as they are for a table given none."""
    counts = np.array([[0, 0, 0, 0, 3, 1, 0, 0.0]])
    zeros = np.zeros_like(counts)
    before = historical(counts, zeros, zeros, np.ones(1), 600.0)
    with_zero_sums = historical(counts, zeros, zeros, np.ones(1), 600.0, zeros, zeros)
    centres = bin_centres(8)
    c = (3 * np.cos(centres[4]) + np.cos(centres[5])) / 4
    s = (3 * np.sin(centres[4]) + np.sin(centres[5])) / 4
    assert before.mean_angle[0] == pytest.approx(math.atan2(s, c), abs=1e-12)
    assert with_zero_sums.mean_angle[0] == before.mean_angle[0]
    assert before.dominant_angle[0] == pytest.approx(centres[4], abs=1e-12)  # 22.5 degrees
    assert with_zero_sums.dominant_angle[0] == before.dominant_angle[0]
    # a store read from arrays without the members has zeros there
    m = _corridor([0.3] * 4)
    arrays = m.state.entries.to_arrays(np.arange(m.state.entries.n))
    assert {f"entry_{name}" for name in HEADING_SUMS} <= set(arrays)
    old = {k: v for k, v in arrays.items() if k.removeprefix("entry_") not in HEADING_SUMS}
    store = EntryStore.from_arrays(old, CFG.bins)
    for name in HEADING_SUMS:
        assert not getattr(store, name)[: store.n].any()
    n = m.state.entries.n
    np.testing.assert_array_equal(store.counts[: store.n], m.state.entries.counts[:n])


def test_a_room_points_where_its_places_detections_went() -> None:
    """p0 and p1 in room R1: the room's bins carry the sums of both places' headings."""
    rooms = Layer(pid([1], "R"), np.zeros((1, 3)), np.zeros(1, np.uint64))
    g = graph(T0, [0, 1], [[0, 0, 0], [3, 0, 0]], [1, 1], rooms)
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 2 * W)
    m.add_graph(g)
    a, b = math.radians(5.0), math.radians(40.0)  # the same bin (0 to 45 degrees)
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 3, heading=[a] * 3))
    m.add_detections(detections(T0 + S, [[3.1, 0.1, 0]] * 1, heading=[b]))
    m.add_graph(graph(T0 + 2 * S, [0, 1], [[0, 0, 0], [3, 0, 0]], [1, 1], rooms))
    m.advance(T0 + W)
    table = aggregate_table(historical_table(m.state), g, "rooms")
    assert table.kind.tolist() == [ROOM]
    angle = float(table.descriptors.dominant_angle[0])
    expected = math.atan2(3 * math.sin(a) + math.sin(b), 3 * math.cos(a) + math.cos(b))
    assert angle == pytest.approx(expected, abs=1e-12)


def test_moving_a_cell_into_its_node_moves_its_sums() -> None:
    """A bind adds the cell's sums into the node's entry (as every other count)."""
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 3 * W)
    heading = math.radians(30.0)
    m.add_detections(detections(T0 + S, [[0.2, 0.2, 0]] * 2, heading=[heading] * 2))
    before = m.state.entries.heading_sin[: m.state.entries.n].sum()
    m.add_graph(graph(T0 + 2 * S, [0], [[0.0, 0.0, 0.0]]))
    m.advance(T0 + 2 * W)
    ent = m.state.entries
    nodes = np.flatnonzero(ent.kind[: ent.n] == 1)
    assert ent.heading_sin[nodes].sum() == pytest.approx(before)
    assert ent.heading_sin[nodes].sum() == pytest.approx(2 * math.sin(heading))


def test_bins_filled_by_the_room_point_where_the_room_walked() -> None:
    """p1 saw people at 100 degrees only; its forecast gives its other bins the room's
    share, mostly bin [0, 45) where p0's people walk at exactly 0 degrees. That bin is placed
    where the room's detections went (0), not at its centre (22.5)."""
    rooms = Layer(pid([1], "R"), np.zeros((1, 3)), np.zeros(1, np.uint64))
    places = [[0, 0, 0], [3, 0, 0]]
    g = graph(T0, [0, 1], places, [1, 1], rooms)
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 2 * W)
    m.add_graph(g)
    east, north = [0.0] * 40, [math.radians(100.0)] * 2
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * len(east), heading=east))
    m.add_detections(detections(T0 + S, [[3.1, 0.1, 0]] * len(north), heading=north))
    m.add_graph(graph(T0 + 2 * S, [0, 1], places, [1, 1], rooms))
    m.advance(T0 + W)
    table = predict_table(m.state, T0 + 3 * W)
    row = int(np.flatnonzero(table.node_id == pid(1))[0])
    d = table.descriptors
    p = d.probabilities[row]
    assert p[4] > 0.2  # the room's share in the bin of p0's walkers
    room_headings = np.array(east + north)
    assert d.mean_angle[row] == pytest.approx(_expected_angle(p, room_headings), abs=1e-12)
    own_only = _expected_angle(p, np.array(north))  # bin 4 at its centre
    assert abs(d.mean_angle[row] - own_only) > math.radians(2.0)
