"""Query tables: ids, historical flows, predictions from the temporal model, aggregation up the
hierarchy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.query import (
    BUILDING,
    ROOM,
    aggregate_table,
    historical_table,
    node_symbol,
    predict_table,
)
from aion_cli.engine.temporal.direction_prior import FALLBACK
from aion_cli.engine.types import Layer
from tests.engine.engine_builders import T0, S, detections, graph, pid

CFG = ModelConfig(window_s=600.0, stability_s=0.0)
W = 600 * S
HOUR = 3600 * S
DAY = 86400 * S


def test_node_symbols_print_like_spark_dsg() -> None:
    """Like NodeSymbol.str(); an id without a printable category stays the number it is (so
    ``--node 5`` finds it again), as the one formatter, ``node_label``, writes it."""
    from aion_cli.engine.node_ids import node_label

    ids = np.concatenate([pid([12, 0]), pid([7], "R"), np.array([5], np.uint64)])
    np.testing.assert_array_equal(node_symbol(ids), ["p12", "p0", "R7", "5"])
    assert node_symbol(ids).tolist() == [node_label(int(i)) for i in ids]


def _mapper_with_rooms(windows: int) -> Mapper:
    """p0, p1 in room R1 (building B1); p2 in room R2 (building B1); one far cell; a fixed
    sensor over the first ``windows`` windows (the open window after them is not observed)."""
    rooms = Layer(pid([2, 1], "R"), np.array([[9, 0, 0], [0, 0, 0.0]]), pid([1, 1], "B"))
    buildings = Layer(pid([1], "B"), np.zeros((1, 3)), np.zeros(1, np.uint64))
    g = graph(T0, [0, 1, 2, 3], [[0, 0, 0], [3, 0, 0], [9, 0, 0], [20, 0, 0]], [1, 1, 2, 2],
              rooms, buildings)
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + windows * W)
    m.add_graph(g)
    return m


def test_historical_table_flows_per_window_and_ids() -> None:
    m = _mapper_with_rooms(2)
    # window 0: p0 gets 4 (heading 0 -> bin 4) + 2 without heading; far cell gets 3
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 6, heading=[0, 0, 0, 0, np.nan, np.nan]))
    m.add_detections(detections(T0 + S, [[50.1, 0.1, 0]] * 3))
    m.add_graph(graph(T0 + 2 * S, [0, 1, 2, 3], [[0, 0, 0], [3, 0, 0], [9, 0, 0], [20, 0, 0]]))
    m.advance(T0 + 2 * W)  # window 1 observed and empty
    table = historical_table(m.state)
    by_id = {str(i): k for k, i in enumerate(table.ids)}
    assert set(by_id) >= {"p0", "p1", "p2", "p3"}
    cells = [i for i in by_id if i.startswith("c")]
    assert len(cells) == 1
    p0, cell = by_id["p0"], by_id[cells[0]]
    d = table.descriptors
    assert d.flow_per_window[p0] == pytest.approx(6 / 2)
    assert d.flow_per_hour[p0] == pytest.approx(3 * 6)
    assert d.dominant_bin[p0] == 4
    assert d.entropy[p0] == pytest.approx(0.0)
    assert d.flow_per_window[cell] == pytest.approx(3 / 2)
    assert table.layer[cell] == "cells"
    assert table.layer[p0] == "places"
    assert d.flow_per_window[by_id["p3"]] == 0.0  # graph node without any entry
    assert d.dominant_bin[by_id["p3"]] == -1
    # historical: the raw proportions of the directed detections, no prior, no spread
    np.testing.assert_array_equal(d.probabilities[p0], np.eye(8)[4])
    np.testing.assert_array_equal(table.rate[p0], 2 * np.eye(8)[4])  # 4 directed in 2 windows
    np.testing.assert_array_equal(table.rate[cell], 1.5 * np.eye(8)[4])
    assert np.all(np.isnan(table.flow_var))
    assert np.all(np.isnan(table.flow_quantile(0.9)))
    assert table.flow_family[p0] == "historical"


def test_predicted_flow_of_a_steady_entry_is_its_window_count() -> None:
    m = _mapper_with_rooms(30)
    for w in range(30):  # 5 detections heading east (bin 4) in every window near p1
        m.add_detections(detections(T0 + w * W + S, [[3.1, 0.1, 0]] * 5))
    m.advance(T0 + 30 * W)  # crosses midnight: T0's day absorbed, the next one pending
    assert m.state.pending
    assert m.state.temporal.glob.n[0] == 10
    table = predict_table(m.state, T0 + 40 * W)
    k = int(np.flatnonzero(table.ids == "p1")[0])
    d = table.descriptors
    assert d.flow_per_window[k] == pytest.approx(5.0, rel=1e-9)  # every family: 5 a window
    assert d.flow_per_hour[k] == pytest.approx(30.0, rel=1e-9)
    assert table.flow_family[k] == "static"  # no day was scored: nothing beats static
    assert table.direction_family[k] == "static"
    assert d.dominant_bin[k] == 4
    # the Dirichlet prior of DESIGN.md §4: map Laplace histogram, the room's (p1 alone in
    # R1) toward it, the entry's toward the room's; direction_prior "auto" with one entry
    # that tells: too few to estimate κ, so both pulls are the fallback's
    assert CFG.direction_prior == "auto"
    kappa, n = FALLBACK, 150.0
    counts = n * np.eye(8)[4]
    p_map = (counts + 1) / (n + 8)
    p_room = (counts + kappa * p_map) / (n + kappa)
    expected = (counts + kappa * p_room) / (n + kappa)
    np.testing.assert_allclose(d.probabilities[k], expected, rtol=1e-12)
    assert d.probabilities[k].min() > 0  # never a zero probability
    assert d.concentration[k] > 0.99
    # no scored window: the spread is Poisson (variance = mean), quantiles of Poisson(5)
    assert table.flow_var[k] == pytest.approx(5.0, rel=1e-9)
    assert table.flow_quantile(0.5)[k] == 5.0
    assert table.flow_quantile(0.99)[k] == stats.poisson.ppf(0.99, 5.0)


def test_with_only_the_static_family_and_no_prior_predict_equals_historical() -> None:
    cfg = CFG.replace(families=["static"], direction_prior=0.0)
    m = Mapper(cfg)
    m.set_fixed_sensor(T0, T0 + 3 * DAY)
    rng = np.random.default_rng(4)
    for w in range(0, 3 * 144, 7):  # three days of windows, busy at changing places
        n = int(rng.integers(1, 9))
        xyz = np.c_[rng.uniform(0, 4, (n, 2)), np.zeros(n)]
        heading = np.where(rng.random(n) < 0.2, np.nan, rng.uniform(-np.pi, np.pi, n))
        m.add_detections(detections(T0 + w * W + S, xyz, heading))
    m.advance(T0 + 3 * DAY)
    assert m.state.temporal.flow_scored.sum() > 0  # days were scored, static still wins
    hist = historical_table(m.state)
    for t in (T0 + 3 * DAY, T0 + 3 * DAY + 9 * HOUR):
        pred = predict_table(m.state, t)
        np.testing.assert_array_equal(pred.flow, hist.flow)
        np.testing.assert_array_equal(pred.rate, hist.rate)
        assert set(pred.flow_family.tolist()) == {"static"}
    # and the historical flow is N / W from an independent count of the stream
    n_windows = 3 * 144  # every window of the three days was observed (fixed sensor)
    total = m.state.entries.counts.sum(axis=1) + m.state.entries.nodir
    rows = m.state.entries.canonical_order()
    np.testing.assert_allclose(hist.flow[: len(rows)], total[rows] / n_windows, rtol=1e-12)


def test_aggregate_into_rooms_and_buildings_sums_place_flows() -> None:
    m = _mapper_with_rooms(1)
    m.add_detections(detections(T0 + S, [[0.1, 0.1, 0]] * 4, heading=np.zeros(4)))
    m.add_detections(detections(T0 + S, [[3.1, 0.1, 0]] * 2, heading=np.full(2, np.pi / 2)))
    m.add_detections(detections(T0 + S, [[9.1, 0.1, 0]] * 6, heading=np.full(6, np.pi / 2)))
    m.add_detections(detections(T0 + S, [[50.1, 0.1, 0]] * 5))  # a cell: belongs to no room
    m.advance(T0 + W)  # binds (stability_s = 0) and closes window 0
    state = m.state
    assert state.graph is not None
    table = historical_table(state)
    rooms = aggregate_table(table, state.graph, "rooms")
    np.testing.assert_array_equal(rooms.ids, ["R1", "R2"])
    np.testing.assert_array_equal(rooms.kind, [ROOM, ROOM])
    np.testing.assert_allclose(rooms.descriptors.flow_per_window, [6, 6])
    np.testing.assert_allclose(rooms.rate[0, [4, 6]], [4, 2])
    np.testing.assert_allclose(rooms.xyz, [[0, 0, 0], [9, 0, 0]])
    buildings = aggregate_table(table, state.graph, "buildings")
    np.testing.assert_array_equal(buildings.ids, ["B1"])
    assert buildings.kind[0] == BUILDING
    np.testing.assert_allclose(buildings.descriptors.flow_per_window, [12])
    assert buildings.descriptors.dominant_bin[0] == 6
    with pytest.raises(ValueError, match="level"):
        aggregate_table(table, state.graph, "floors")  # type: ignore[arg-type]
