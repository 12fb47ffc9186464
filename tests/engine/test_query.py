"""Query tables: ids, historical flows, predictions from FreMEn, aggregation up the hierarchy."""

from __future__ import annotations

import numpy as np
import pytest

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
from aion_cli.engine.types import Layer
from tests.engine.engine_builders import T0, S, detections, graph, pid

CFG = ModelConfig(window_s=600.0, stability_s=0.0, activity_scale=5.0, direction_floor=1e-3)
W = 600 * S


def test_node_symbols_print_like_spark_dsg() -> None:
    ids = np.concatenate([pid([12, 0]), pid([7], "R"), np.array([5], np.uint64)])
    np.testing.assert_array_equal(node_symbol(ids), ["p12", "p0", "R7", "?5"])


def _mapper_with_rooms() -> Mapper:
    """p0, p1 in room R1 (building B1); p2 in room R2 (building B1); one far cell."""
    rooms = Layer(pid([2, 1], "R"), np.array([[9, 0, 0], [0, 0, 0.0]]), pid([1, 1], "B"))
    buildings = Layer(pid([1], "B"), np.zeros((1, 3)), np.zeros(1, np.uint64))
    g = graph(T0, [0, 1, 2, 3], [[0, 0, 0], [3, 0, 0], [9, 0, 0], [20, 0, 0]], [1, 1, 2, 2],
              rooms, buildings)
    m = Mapper(CFG)
    m.set_fixed_sensor(T0, T0 + 10**4 * W)
    m.add_graph(g)
    return m


def test_historical_table_flows_per_window_and_ids() -> None:
    m = _mapper_with_rooms()
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


def test_predicted_flow_of_a_steady_entry_is_its_window_count() -> None:
    m = _mapper_with_rooms()
    for w in range(30):  # 5 detections heading east (bin 4) in every window near p1
        m.add_detections(detections(T0 + w * W + S, [[3.1, 0.1, 0]] * 5))
    m.advance(T0 + 30 * W)
    table = predict_table(m.state, T0 + 40 * W)
    k = int(np.flatnonzero(table.ids == "p1")[0])
    d = table.descriptors
    assert d.flow_per_window[k] == pytest.approx(5.0, rel=1e-6)  # -5 ln(1 - (1 - e^-1))
    assert d.dominant_bin[k] == 4
    assert d.probabilities[k, 4] == pytest.approx(1 / (1 + 7e-3))  # others floored at 1e-3
    assert d.concentration[k] > 0.99


def test_aggregate_into_rooms_and_buildings_sums_place_flows() -> None:
    m = _mapper_with_rooms()
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
