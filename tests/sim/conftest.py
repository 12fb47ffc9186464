"""Shared simulated scenes for the simulator tests, built once per session (short durations)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from aion_cli.sim.graphstream import StreamConfig
from aion_cli.sim.robot import PatrolConfig
from aion_cli.sim.scenario import ScenarioConfig, SceneResult, simulate
from tests.shared_data import SHARED_DATA

DSG_DIR = SHARED_DATA / "dsg"

# Three hours around lunch on a Monday, a tour every 20 minutes, and every loop closure both
# merges and removes a place, so the stream has all the situations to check.
PATROL = ScenarioConfig(
    days=3 / 24,
    seed=11,
    start="2026-01-05T11:00",
    patrol=PatrolConfig(tour_every_s=1200.0),
    stream=StreamConfig(merge_p=1.0, remove_p=1.0),
)
# A fixed sensor in the map frame without noise: detections are the truth.
FIXED = ScenarioConfig(
    days=1.5 / 24,
    seed=5,
    start="2026-01-05T12:00",
    robot="fixed",
    noise=0.0,
)


def load_truth(result: SceneResult) -> dict[str, Any]:
    with np.load(result.truth_npz, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


@pytest.fixture(scope="session")
def patrol_scene(tmp_path_factory: pytest.TempPathFactory) -> SceneResult:
    out = tmp_path_factory.mktemp("patrol") / "office.mcap"
    return simulate(PATROL, out)[0]


@pytest.fixture(scope="session")
def patrol_map_scene(tmp_path_factory: pytest.TempPathFactory) -> SceneResult:
    """The patrol scene again, detections published in the map frame instead."""
    out = tmp_path_factory.mktemp("patrol_map") / "office.mcap"
    return simulate(replace(PATROL, frame="map"), out)[0]


@pytest.fixture(scope="session")
def fixed_scene(tmp_path_factory: pytest.TempPathFactory) -> SceneResult:
    out = tmp_path_factory.mktemp("fixed") / "fixed.mcap"
    return simulate(FIXED, out)[0]
