"""People: daily and weekly rhythm, walking on the place graph of real scene graphs."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from aion_cli.sim.agents import agent_speeds, simulate_agents
from aion_cli.sim.environment import load_graph_environment
from aion_cli.sim.office import office_environment
from aion_cli.sim.scenario import build_scene, load_environment
from aion_cli.sim.schedule import plan_moves
from tests.shared_data import needs, real_path, require
from tests.sim.conftest import FIXED


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest of the 3D segments a[k]→b[k]."""
    best = np.full(len(points), np.inf)
    ab = b - a
    denom = np.maximum((ab * ab).sum(1), 1e-12)
    for s in range(0, len(points), 2000):
        p = points[s : s + 2000, None, :]
        u = np.clip(((p - a) * ab).sum(-1) / denom, 0, 1)
        d = np.linalg.norm(p - (a + u[..., None] * ab), axis=-1)
        best[s : s + 2000] = d.min(axis=1)
    return best


def test_week_rhythm_lunch_busier_than_night_weekend_quiet() -> None:
    env = office_environment(6)
    rng = np.random.default_rng(3)
    moves = plan_moves(rng, 6, 7, 0, env.roles, env.n_places)  # Monday .. Sunday
    samples = simulate_agents(env, moves, agent_speeds(rng, 6), rng, 0.5, 7 * 86400 * 2)
    t_s = samples.tick * 0.5
    day, hour = (t_s // 86400).astype(int), ((t_s % 86400) // 3600).astype(int)
    per_day_hour = np.zeros((7, 24), dtype=int)
    np.add.at(per_day_hour, (day, hour), 1)
    weekdays = per_day_hour[:5]
    assert np.all(weekdays[:, 12] > 0)
    assert np.all(weekdays[:, 12] > weekdays[:, 3])
    assert weekdays[:, 0:6].sum() == 0  # quiet nights
    assert weekdays[:, 8].sum() > weekdays[:, 20].sum()  # arrivals, nobody late
    weekend = per_day_hour[5:].sum(axis=1)
    assert np.all(weekend < 0.1 * weekdays.sum(axis=1).mean())
    # lunch traffic ends in the kitchen
    kitchen = env.xyz[env.roles.kitchen]
    near_kitchen = np.linalg.norm(samples.xyz - kitchen, axis=1) < 3.0
    assert near_kitchen[hour == 12].mean() > near_kitchen[hour == 10].mean()


def test_agents_walk_at_their_speed_with_heading_along_motion() -> None:
    env = office_environment(6)
    rng = np.random.default_rng(4)
    moves = plan_moves(rng, 6, 1, 0, env.roles, env.n_places)
    samples = simulate_agents(env, moves, agent_speeds(rng, 6), rng, 0.5, 86400 * 2)
    assert np.all((samples.speed >= 0.85) & (samples.speed <= 1.5 * 1.15))
    # consecutive samples of a trip: displacement ≈ speed · dt along the reported heading
    same = (samples.trip[1:] == samples.trip[:-1]) & (samples.tick[1:] == samples.tick[:-1] + 1)
    order = np.lexsort((samples.tick, samples.trip))
    xyz, trip, tick = samples.xyz[order], samples.trip[order], samples.tick[order]
    step = (trip[1:] == trip[:-1]) & (tick[1:] == tick[:-1] + 1)
    d = np.linalg.norm(np.diff(xyz, axis=0), axis=1)[step]
    assert np.all(d <= samples.speed[order][1:][step] * 0.5 + 1e-9)
    straight = d > samples.speed[order][1:][step] * 0.5 - 1e-9  # no corner in between
    move = np.diff(xyz, axis=0)[step][straight]
    ang = np.arctan2(move[:, 1], move[:, 0])
    diff = np.angle(np.exp(1j * (ang - samples.heading[order][:-1][step][straight])))
    assert np.abs(diff).max() < 1e-6
    assert same.any()


@pytest.mark.parametrize("name", ["apartment_dsg.json", "mp3d_x8F5xyUWy9e_dsg.json"])
def test_people_stay_on_the_place_graph_of_a_real_scene_graph(name: str) -> None:
    path = require(real_path("dsg", name), "the real scene graph")
    config = replace(
        FIXED, environment=str(path), noise=0.05, days=3 / 24, start="2026-01-05T11:30"
    )
    env = load_environment(config)
    data = build_scene(config, env, 0)
    assert len(data.samples) > 200
    a, b = env.xyz[env.edges[:, 0]], env.xyz[env.edges[:, 1]]
    on_graph = _segment_distance(data.samples.xyz, a, b)
    assert on_graph.max() < 1e-6
    published = _segment_distance(data.obs.xyz, a, b)
    assert published.max() < 0.05 * 6
    # the scene graph stream uses the file's own place ids
    alive = data.frames.ids[-1][data.frames.state[-1] == 1]
    assert set(alive.tolist()) <= set(env.place_ids.tolist())


@needs(real_path("dsg", "apartment_dsg.json"), "the apartment scene graph")
def test_real_graph_loader_keeps_the_largest_component() -> None:
    env = load_graph_environment(real_path("dsg", "apartment_dsg.json"), 6)
    from aion_cli.sim.environment import largest_component

    assert len(largest_component(env.n_places, env.edges)) == env.n_places
    assert {chr(int(i) >> 56) for i in env.place_ids} == {"p"}
    parents = env.place_room[env.place_room != 0]
    assert len(parents) > env.n_places // 2
    assert set(parents.tolist()) <= set(env.room_ids.tolist())
    assert len(env.roles.desks) == 6
    assert env.roles.patrol[0] == env.roles.patrol[-1] == env.roles.dock
