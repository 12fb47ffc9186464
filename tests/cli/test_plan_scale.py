"""Planning normalises flow by the map's own busy level unless told a fixed scale."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.types import DetectionBatch, GraphSnapshot, Layer
from aion_cli.mapquery import LoadedMap, planning_config

P = np.uint64(ord("p") << 56)


def loaded_map(config: ModelConfig) -> LoadedMap:
    """Ten places on a line; place k sees k+1 detections per window for 6 windows."""
    xyz = np.column_stack([np.arange(10) * 3.0, np.zeros(10), np.zeros(10)])
    places = Layer(P | np.arange(10, dtype=np.uint64), xyz, np.zeros(10, np.uint64))
    edges = np.column_stack([np.arange(9), np.arange(1, 10)]).astype(np.int64)
    mapper = Mapper(config)
    t0 = 1_700_000_400 * 10**9
    mapper.set_fixed_sensor(t0, t0 + 6 * 600 * 10**9)
    mapper.add_graph(GraphSnapshot(t0, places, edges))
    rows = [(t0 + 60 * 10**9 + w * 600 * 10**9 + j, k) for w in range(6) for k in range(10)
            for j in range(k + 1)]
    t = np.array([r[0] for r in rows], dtype=np.int64)
    pos = xyz[[r[1] for r in rows]]
    mapper.add_detections(DetectionBatch.from_arrays(t, pos, np.zeros(len(t))))
    mapper.advance(t0 + 7 * 600 * 10**9)
    return LoadedMap(mapper.state, None, {})


def test_auto_scale_is_the_90th_percentile_of_place_flow() -> None:
    loaded = loaded_map(ModelConfig())
    scale = planning_config(loaded).plan_flow_scale
    # flows per window 1..10 (the first window's detections arrive before binding: still
    # counted at the places once bound), 90th percentile of 1..10 = 9.1
    assert scale == pytest.approx(np.percentile(np.arange(1, 11), 90.0), rel=0.05)


def test_fixed_scale_is_kept_when_auto_is_off() -> None:
    loaded = loaded_map(ModelConfig(plan_flow_auto=False, plan_flow_scale=42.0))
    assert planning_config(loaded).plan_flow_scale == 42.0
