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
    UNIFORM_NLL,
    AionHeadingModel,
    GridHeadingModel,
    score_headings,
)
from tests.evaluation.test_grid import HOUR, corridor_flow


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
        AionHeadingModel(mapper.state, radius=1.0, order=0, name="static"), test, bins=8
    )
    assert static.nll_matched < UNIFORM_NLL - 1.0
    grid = GridMoD(GridSpec.covering(train.xyz[:, :2], 1.0), config)
    grid.fit(train)
    g = score_headings(GridHeadingModel(grid), test, bins=8)
    assert g.nll_matched < UNIFORM_NLL - 1.0
    assert 0.0 <= g.chi_square < 1.0
