"""The detections a simulated log holds, read back with the project's reader, for the tests
that compare them with the simulator's frames and ground truth."""

from __future__ import annotations

import numpy as np

from aion_cli.formats.logs import open_logs
from aion_cli.sim.scenario import SceneResult

#: the topic of the simulator's spencer TrackedPersons
DET = "/spencer/perception/tracked_persons"


def logged_detections(
    result: SceneResult,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """(t_ns, xyz, velocity, frame per message) of every TrackedPerson in the log."""
    t, xyz, vel, frames = [], [], [], []
    with open_logs([result.log]) as logs:
        for raw in logs.messages({DET}):
            msg = logs.decode(raw)
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            assert stamp == raw.log_time_ns
            frames.append(msg.header.frame_id)
            for tr in msg.tracks:
                p, v = tr.pose.pose.position, tr.twist.twist.linear
                t.append(stamp)
                xyz.append((p.x, p.y, p.z))
                vel.append((v.x, v.y, v.z))
    return np.array(t, dtype=np.int64), np.array(xyz), np.array(vel), frames
