"""Ground truth against what the log itself implies, and determinism of logs and truth."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from aion_cli.sim.ground_truth import direction_bin
from aion_cli.sim.scenario import SceneResult, simulate
from tests.sim.conftest import FIXED, load_truth
from tests.sim.logged_detections import logged_detections


def test_direction_bin_convention() -> None:
    """bin(θ) = floor((θ+π)/(2π/B)) mod B: -π opens bin 0, +π wraps to 0, east is bin B/2."""
    theta = np.array(
        [-np.pi, -np.pi + 1e-9, -np.pi / 2, 0.0, np.pi / 2 - 1e-9, np.pi - 1e-9, np.pi]
    )
    np.testing.assert_array_equal(direction_bin(theta, 8), [0, 0, 2, 4, 5, 7, 0])
    np.testing.assert_array_equal(direction_bin(theta, 4), [0, 0, 1, 2, 2, 3, 0])


def test_truth_equals_detections_of_an_all_seeing_sensor(fixed_scene: SceneResult) -> None:
    """Fixed sensor, map frame, no noise: binning the log's detections gives flow_counts."""
    truth = load_truth(fixed_scene)
    t, xyz, vel, frames = logged_detections(fixed_scene)
    assert set(frames) == {"map"}
    assert len(t) == len(truth["agent_t_ns"]) > 100
    place = cKDTree(truth["place_xyz"]).query(xyz)[1]
    heading = np.arctan2(vel[:, 1], vel[:, 0])
    window_ns = int(fixed_scene.meta["window_s"] * 1e9)
    win = t // window_ns - truth["window_start_ns"][0] // window_ns
    counts = np.zeros_like(truth["flow_counts"])
    np.add.at(counts, (win, place, direction_bin(heading, fixed_scene.meta["bins"])), 1)
    np.testing.assert_array_equal(counts, truth["flow_counts"])
    np.testing.assert_array_equal(truth["seen_counts"], truth["flow_counts"])
    assert truth["observed"].all()
    # windows are aligned to the epoch and cover the log
    assert np.all(truth["window_start_ns"] % window_ns == 0)
    assert truth["window_start_ns"][0] <= t.min()
    assert t.max() < truth["window_start_ns"][-1] + window_ns
    # speeds: the recorded speed of every sample lies in the walking range
    assert truth["agent_speed"].min() >= 1.0 * 0.85
    assert truth["agent_speed"].max() <= 1.5 * 1.15


def test_patrol_truth_counts_everyone_the_robot_sees_a_part(patrol_scene: SceneResult) -> None:
    truth = load_truth(patrol_scene)
    flow, seen = truth["flow_counts"], truth["seen_counts"]
    assert flow.sum() == len(truth["agent_t_ns"])
    assert seen.sum() == truth["agent_seen"].sum() == patrol_scene.meta["detections"]
    assert np.all(seen <= flow)
    assert 0 < seen.sum() < flow.sum()
    # what the robot saw lies at places it covered in that window (coverage is judged from
    # the place nearest the robot, so a sighting at the edge of the range may fall outside)
    w = (truth["agent_t_ns"] // int(600e9)) - truth["window_start_ns"][0] // int(600e9)
    s = truth["agent_seen"]
    assert truth["observed"][w[s], truth["agent_place"][s]].mean() > 0.95
    assert 0.2 < truth["observed"].mean() < 0.9


def _bytes(path: Path) -> bytes:
    return path.read_bytes()


def test_same_seed_same_bytes_other_seed_other_bytes(tmp_path: Path) -> None:
    config = replace(FIXED, days=0.5 / 24, robot="patrol", frame=None, noise=0.05)
    a = simulate(config, tmp_path / "a.mcap")[0]
    b = simulate(config, tmp_path / "b.mcap")[0]
    c = simulate(replace(config, seed=config.seed + 1), tmp_path / "c.mcap")[0]
    assert _bytes(a.log) == _bytes(b.log)
    assert _bytes(a.truth_npz) == _bytes(b.truth_npz)
    assert a.truth_json.read_text().replace("a.mcap", "b.mcap") == b.truth_json.read_text()
    assert _bytes(a.log) != _bytes(c.log)
    ta, tc = load_truth(a), load_truth(c)
    assert not np.array_equal(ta["agent_xyz"][:50], tc["agent_xyz"][:50])


def test_scenes_are_independent_logs(tmp_path: Path) -> None:
    config = replace(FIXED, days=0.5 / 24, scenes=3)
    results = simulate(config, tmp_path / "paper")
    assert [r.log.name for r in results] == ["scene_00.mcap", "scene_01.mcap", "scene_02.mcap"]
    assert all(r.truth_npz.exists() and r.truth_json.exists() for r in results)
    walks = [load_truth(r)["agent_xyz"] for r in results]
    assert all(len(w) > 0 for w in walks)
    assert len({w.tobytes() for w in walks}) == 3


@pytest.mark.parametrize("fmt", ["bag", "rosbag2", "rosbag2-sqlite3", "mcap-ros1"])
def test_other_containers_are_deterministic_too(tmp_path: Path, fmt: str) -> None:
    config = replace(FIXED, days=0.2 / 24, robot="patrol", frame=None, format=fmt)
    (tmp_path / "a").mkdir()  # simulate makes no folder above its output
    (tmp_path / "b").mkdir()
    a = simulate(config, tmp_path / "a" / "log")[0]
    b = simulate(config, tmp_path / "b" / "log")[0]
    files_a = sorted(p for p in (tmp_path / "a").rglob("*") if p.is_file())
    files_b = sorted(p for p in (tmp_path / "b").rglob("*") if p.is_file())
    assert [p.relative_to(tmp_path / "a") for p in files_a] == [
        p.relative_to(tmp_path / "b") for p in files_b
    ]
    assert len(files_a) >= 3
    for fa, fb in zip(files_a, files_b, strict=True):
        assert fa.read_bytes() == fb.read_bytes(), fa.name
    assert a.meta["messages"] == b.meta["messages"]
