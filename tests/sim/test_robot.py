"""The patrolling robot: what its sensor sees, how its odometry drifts, what loop closures fix."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.sim.geometry import segments_blocked
from aion_cli.sim.office import office_environment
from aion_cli.sim.robot import PatrolConfig, simulate_robot
from aion_cli.sim.scenario import build_scene
from tests.sim.conftest import PATROL


def test_sensor_sees_within_range_and_not_through_walls() -> None:
    env = office_environment(6)
    data = build_scene(PATROL, env, 0)
    robot = data.robot
    assert robot is not None
    s = data.samples
    seen = np.zeros(len(s), dtype=bool)
    seen[data.obs.sample] = True
    dist = np.linalg.norm(s.xyz[:, :2] - robot.pose[s.tick, :2], axis=1)
    blocked = segments_blocked(robot.pose[s.tick, :2], s.xyz[:, :2], env.walls)
    np.testing.assert_array_equal(seen, (dist <= 8.0) & ~blocked)
    assert seen.any()
    assert (~seen & (dist <= 8.0)).any()  # walls hide some people in range


def test_drift_grows_only_while_driving_and_loop_closures_zero_the_error() -> None:
    env = office_environment(6)
    cfg = PatrolConfig(tour_every_s=1800.0)
    robot = simulate_robot(env, cfg, np.random.default_rng(2), 0.5, 4 * 7200 + 1, 4 / 24)
    parked = ~robot.moving[1:] & ~robot.moving[:-1]
    step = np.abs(np.diff(robot.drift, axis=0))
    assert np.all(step[parked] == 0)
    assert np.abs(robot.drift).max() > 0.05
    lc = robot.loop_closures
    assert len(lc) >= 7
    np.testing.assert_allclose(robot.error(lc), 0, atol=1e-12)
    before = np.linalg.norm(robot.error(lc - 1)[:, :2], axis=1)
    assert before.max() > 0.05  # the closure really corrected something
    # the robot is back at its dock when a loop closes
    dock = env.xyz[env.roles.dock, :2]
    np.testing.assert_allclose(robot.pose[lc, :2], np.broadcast_to(dock, (len(lc), 2)))
    # tours start on the half hour grid, one minute past
    starts_s = robot.tour_starts * 0.5
    np.testing.assert_allclose(starts_s % 1800.0, 60.0)


@pytest.mark.parametrize(
    ("hours", "starts"),
    [
        ((8.5, 8.6), True),  # 08:30-08:36 holds the 08:31 start of the 30-min grid
        ((8.6, 8.9), False),  # 08:36-08:54: between 08:31 and 09:01
        ((24.0, 0.0), False),  # 24 is midnight: an empty span that wraps
        ((22.0, 6.0), True),
        ((0.0, 24.0), True),
    ],
)
def test_patrol_hours_that_no_tour_start_falls_in_are_refused(
    hours: tuple[float, float], starts: bool
) -> None:
    """--patrol-hours 24-0 or 8.6-8.9 with tours every 30 min (from 00:01: HH:01, HH:31)
    wrote a log whose robot never left its dock, without a word; they are refused now."""
    from aion_cli.errors import InputError
    from aion_cli.sim.robot import PatrolConfig, tours_can_start
    from aion_cli.sim.scenario import ScenarioConfig
    from aion_cli.sim.scenario_checks import validate_scenario

    patrol = PatrolConfig(tour_every_s=1800.0, hours=hours)
    assert tours_can_start(patrol) is starts
    config = ScenarioConfig(patrol=patrol)
    if starts:
        validate_scenario(config)
    else:
        with pytest.raises(InputError, match="no patrol tour would start"):
            validate_scenario(config)
