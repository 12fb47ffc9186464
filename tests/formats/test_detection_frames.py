"""Detections moved into the map frame by TF: positions, velocities and pose headings of a
sensor that is yawed, upside down or tilted, checked against hand-computed answers."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from aion_cli.detection_feed import DetectionCounts, DetectionFeeder
from aion_cli.formats.raw import RawMessage
from aion_cli.formats.tf import TfBuffer
from tests.formats.ros_messages import header, pose, raw

S = 1_000_000_000
T0 = 1_700_000_000 * S


def yaw_q(a: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(a / 2), math.cos(a / 2))


def sensor(q: tuple[float, float, float, float], at: tuple[float, float, float]) -> TfBuffer:
    """TF with ``map -> laser`` fixed at ``at``, rotated by ``q``, sampled at 10 Hz for 10 s."""
    tf = TfBuffer()
    t = np.arange(T0, T0 + 10 * S, S // 10)
    tf.add_transforms("map", "laser", t, np.tile(at, (len(t), 1)), np.tile(q, (len(t), 1)))
    return tf


def people(t_ns: int, poses: list[tuple[float, float, float, float]]) -> RawMessage:
    """A PoseArray in ``laser``: people at (x, y, z) facing yaw (rad, about the laser's z)."""
    msg = {
        "header": header(t_ns // S, t_ns % S, "laser"),
        "poses": [pose(x, y, z, yaw_q(a)) for x, y, z, a in poses],
    }
    return raw("geometry_msgs/msg/PoseArray", msg, 2, log_time_ns=t_ns, topic="/people")


def headings(tf: TfBuffer, poses: list[tuple[float, float, float, float]]) -> Any:
    feeder = DetectionFeeder(tf, "map", DetectionCounts(), linker=None)
    return feeder.decode([people(T0 + S, poses)])


def test_an_upside_down_sensor_mirrors_pose_headings() -> None:
    # Rolled by pi about x: (x, y, z) -> (x, -y, -z), so a heading a becomes -a.
    tf = sensor((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    b = headings(tf, [(1.0, 1.0, 0.2, 0.5), (2.0, 0.0, 0.0, -2.0)])
    np.testing.assert_allclose(b.xyz, [[1.0, -1.0, 0.8], [2.0, 0.0, 1.0]], atol=1e-12)
    np.testing.assert_allclose(b.heading, [-0.5, 2.0], atol=1e-12)


def test_a_pitched_sensor_projects_pose_headings_onto_the_floor() -> None:
    # Pitched by 60 deg about y: the direction (cos a, sin a, 0) becomes
    # (cos 60 cos a, sin a, -sin 60 cos a), whose heading on the floor is atan2(sin a, cos a / 2).
    p = math.radians(60)
    tf = sensor((0.0, math.sin(p / 2), 0.0, math.cos(p / 2)), (0.0, 0.0, 1.5))
    b = headings(tf, [(1.0, 0.0, 0.0, math.pi / 4), (1.0, 1.0, 0.0, math.pi / 2)])
    np.testing.assert_allclose(b.heading, [math.atan(2.0), math.pi / 2], atol=1e-12)


def test_a_level_sensor_adds_its_yaw_to_pose_headings() -> None:
    tf = sensor(yaw_q(math.pi / 2), (1.0, 2.0, 0.0))
    b = headings(tf, [(1.0, 0.0, 0.0, 3.0), (0.0, 1.0, 0.0, 0.25)])
    np.testing.assert_allclose(b.xyz[:, :2], [[1.0, 3.0], [0.0, 2.0]], atol=1e-12)
    np.testing.assert_allclose(b.heading, [3.0 + math.pi / 2 - 2 * math.pi, 0.25 + math.pi / 2])


@pytest.mark.parametrize("roll", [0.0, math.pi])
def test_velocities_are_rotated_not_moved(roll: float) -> None:
    # The laser at (5, 5) yawed 90 deg (and rolled upside down about its own x, which leaves
    # its +x where it was): a person walking +x in the laser walks +y in the map.
    q_yaw = yaw_q(math.pi / 2)
    q_roll = (math.sin(roll / 2), 0.0, 0.0, math.cos(roll / 2))
    x1, y1, z1, w1 = q_yaw
    x2, y2, z2, w2 = q_roll  # q_yaw * q_roll: roll first, then yaw
    q = (
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
    )
    tf = sensor(q, (5.0, 5.0, 0.0))
    msg = {
        "header": header(T0 // S + 1, 0, "laser"),
        "tracks": [
            {
                "track_id": 7,
                "is_matched": True,
                "pose": {"pose": pose(1.0, 0.0, 0.0, (0.0, 0.0, 0.0, 1.0))},
                "twist": {"twist": {"linear": {"x": 1.5, "y": 0.0, "z": 0.0}}},
            }
        ],
    }
    m = raw("spencer_tracking_msgs/msg/TrackedPersons", msg, 2, log_time_ns=T0 + S, topic="/t")
    b = DetectionFeeder(tf, "map", DetectionCounts(), linker=None).decode([m])
    np.testing.assert_allclose(b.xyz[0, :2], [5.0, 6.0], atol=1e-12)  # +x of the laser is +y
    assert b.heading[0] == pytest.approx(math.pi / 2)
    assert b.speed[0] == pytest.approx(1.5)
