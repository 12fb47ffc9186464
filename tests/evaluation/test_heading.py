"""Heading scores: a uniform model gives log(2π); models that learned the flow beat it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.types import DetectionBatch
from aion_cli.evaluation.grid import GridMoD, GridSpec
from aion_cli.evaluation.heading import (
    FLOOR,
    UNIFORM_NLL,
    AionHeadingModel,
    GridHeadingModel,
    score_headings,
)
from tests.evaluation.corridor_flows import HOUR, corridor_flow


class Uniform:
    name = "uniform"

    def probabilities(self, xyz: np.ndarray, t_ns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.ones((len(xyz), 8)), np.ones(len(xyz), dtype=bool)


def split(batch: DetectionBatch) -> tuple[DetectionBatch, DetectionBatch]:
    test = np.arange(len(batch)) % 10 == 0
    return batch.select(~test), batch.select(test)


def test_uniform_model_scores_log_two_pi() -> None:
    batch = corridor_flow(4)
    score = score_headings(Uniform(), batch, bins=8)
    assert score.nll_matched == pytest.approx(math.log(2 * math.pi))
    assert score.nll_all == pytest.approx(UNIFORM_NLL)
    assert score.unmatched == 0


def test_learned_models_beat_uniform_and_unmatched_are_counted() -> None:
    train, test = split(corridor_flow(24, seed=5))
    config = ModelConfig(window_s=600.0)
    mapper = Mapper(config)
    mapper.set_fixed_sensor(int(train.t_ns.min()), int(train.t_ns.max()) + 1)
    mapper.add_detections(train.sorted_by_time())
    mapper.advance(int(train.t_ns.max()) + HOUR)
    far = DetectionBatch.from_arrays(
        test.t_ns[:3], np.array([[500.0, 500.0, 0.0]] * 3), test.heading[:3]
    )
    probe = DetectionBatch.concat([test, far])
    aion = score_headings(AionHeadingModel(mapper.state, radius=1.0), probe, bins=8)
    assert aion.unmatched == 3
    assert aion.nll_matched < UNIFORM_NLL - 1.0
    static = score_headings(
        AionHeadingModel(mapper.state, radius=1.0, static=True, name="static"), test, bins=8
    )
    assert static.model == "static"
    assert static.nll_matched < UNIFORM_NLL - 1.0
    grid = GridMoD(GridSpec.covering(train.xyz[:, :2], 1.0), config)
    grid.fit(train)
    g = score_headings(GridHeadingModel(grid), test, bins=8)
    assert g.nll_matched < UNIFORM_NLL - 1.0
    assert 0.0 <= g.chi_square < 1.0


def test_the_three_readings_of_a_map_share_one_tree_and_answer_as_built_apart() -> None:
    """``AionHeadingModel.readings``: forecast, static and raw histograms of one map on one
    KD-tree and predictor, each scoring exactly as the model built on its own."""
    batch = corridor_flow(4)
    train, test = split(batch)
    mapper = Mapper(ModelConfig())
    mapper.set_fixed_sensor(int(train.t_ns.min()), int(train.t_ns.max()) + 1)
    mapper.add_detections(train.sorted_by_time())
    mapper.advance(int(test.t_ns.max()))
    readings = AionHeadingModel.readings(mapper.state, radius=1.0)
    assert [m.name for m in readings] == ["aion", "aion static", "aion historical"]
    assert readings[1].tree is readings[0].tree is readings[2].tree
    apart = [
        AionHeadingModel(mapper.state, radius=1.0),
        AionHeadingModel(mapper.state, radius=1.0, static=True, name="aion static"),
        AionHeadingModel(mapper.state, radius=1.0, historical=True, name="aion historical"),
    ]
    for shared, own in zip(readings, apart, strict=True):
        assert score_headings(shared, test, bins=8) == score_headings(own, test, bins=8)
    hist = [m.probabilities(test.xyz, test.t_ns)[0] for m in readings]
    assert not np.array_equal(hist[1], hist[2])  # pooled static histograms, not the raw ones


class OneBin:
    name = "one bin"

    def probabilities(self, xyz: np.ndarray, t_ns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        hist = np.zeros((len(xyz), 8))
        hist[:, 4] = 3.0  # any scale: normalised before scoring
        return hist, np.ones(len(xyz), dtype=bool)


def test_every_histogram_is_floored_before_scoring() -> None:
    batch = corridor_flow(4)  # morning hours only: every heading is 0, bin 4
    right = score_headings(OneBin(), batch, bins=8)
    assert FLOOR == 0.01
    density = 8 / (2 * math.pi)
    assert right.nll_matched == pytest.approx(-math.log(1 / (1 + 7 * FLOOR) * density))
    flipped = DetectionBatch.from_arrays(batch.t_ns, batch.xyz, np.full(len(batch), math.pi / 2))
    wrong = score_headings(OneBin(), flipped, bins=8)  # bin 6: only the floor's share
    assert wrong.nll_matched == pytest.approx(-math.log(FLOOR / (1 + 7 * FLOOR) * density))


def test_aion_forecasts_a_direction_that_flips_at_noon_better_than_its_static_map() -> None:
    """A week of a corridor walked +x every morning and -x every afternoon; held out: the
    next day. The time-varying direction family knows which way people walk at each hour."""
    stream = corridor_flow(8 * 24, seed=7)
    day7 = stream.t_ns >= int(stream.t_ns.min()) + 7 * 24 * HOUR
    train, test = stream.select(~day7), stream.select(day7)
    mapper = Mapper(ModelConfig(window_s=600.0))
    mapper.set_fixed_sensor(int(train.t_ns.min()), int(test.t_ns.min()))
    mapper.add_detections(train.sorted_by_time())
    mapper.advance(int(test.t_ns.min()))
    aion = score_headings(AionHeadingModel(mapper.state, radius=1.0), test, bins=8)
    static = score_headings(
        AionHeadingModel(mapper.state, radius=1.0, static=True, name="static"), test, bins=8
    )
    assert aion.unmatched == static.unmatched == 0
    # the static map splits its mass between the two bins (each about half the detections);
    # scoring floors the six empty bins at FLOOR
    half = 0.5 / (1 + 6 * FLOOR)
    assert static.nll_matched == pytest.approx(-math.log(half * 8 / (2 * math.pi)), abs=0.01)
    assert aion.nll_matched < static.nll_matched - 0.1
