"""Write one simulated scene as a ROS log: scene graphs, detections and TF in log-time order.

The three streams are merged by tick (TF before scene graph before detections at equal stamps, so
a reader always has the transform when a detection arrives). Log time equals header stamp. TF is
published at every tick the robot moves or a detection message is published, at loop closures
(and the tick before, so the ``map→odom`` jump is sharp) and as a heartbeat while parked; a fixed
sensor publishes no TF at all (its detections are in ``map``). The tracker publishes a message at
every tick with detections and, like a live tracker, an empty one every ``tf_idle_s`` seconds
otherwise, so the topic exists even in a log in which nobody walks.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aion_cli.engine.types import I64
from aion_cli.sim.environment import Environment
from aion_cli.sim.graphstream import GraphFrames, PayloadBuilder
from aion_cli.sim.messages import (
    DETECTION_TOPICS,
    DSG_UPDATE,
    TF_MESSAGE,
    detection_message,
    dsg_message,
)
from aion_cli.sim.robot import RobotTrack
from aion_cli.sim.sensing import Observations
from aion_cli.sim.tfcodec import TfEncoder

Progress = Callable[[int, int], None]

DSG_TOPIC_ROS2 = "/hydra/backend/dsg"
DSG_TOPIC_ROS1 = "/hydra_ros_node/backend/dsg"
TF_TOPIC = "/tf"
TF, DSG, DET = 0, 1, 2


@dataclass(frozen=True)
class LogCounts:
    """Messages written per stream, and the topics used."""

    tf: int
    dsg: int
    detections: int
    detection_rows: int
    topics: dict[str, str]


def tf_ticks(robot: RobotTrack, obs_ticks: I64, idle_ticks: int) -> I64:
    """Ticks at which /tf is published (see the module docstring)."""
    n = len(robot.pose)
    lc = robot.loop_closures
    parts = [
        np.flatnonzero(robot.moving),
        obs_ticks,
        lc,
        lc[lc > 0] - 1,
        np.arange(0, n, max(idle_ticks, 1)),
        np.array([n - 1]),
    ]
    return np.unique(np.concatenate(parts)).astype(np.int64)


def dsg_topic(container: str) -> str:
    """Hydra's backend topic name in ROS 1 or ROS 2 naming."""
    return DSG_TOPIC_ROS1 if container in ("bag", "mcap-ros1") else DSG_TOPIC_ROS2


def write_scene_log(
    path: Path,
    container: str,
    env: Environment,
    frames: GraphFrames,
    obs: Observations,
    robot: RobotTrack | None,
    msgtype: str,
    t0_ns: int,
    dt_ns: int,
    n_ticks: int,
    tf_idle_s: float,
    include_mesh: bool,
    noise: float,
    progress: Progress | None = None,
    overwrite: bool = False,
    timezone: str | None = None,
) -> LogCounts:
    """Write the merged streams to ``path`` with :class:`formats.writers.LogWriter`: beside
    the target, renamed into place when complete (``overwrite`` replaces only a log of the
    same kind aion wrote; an error or Ctrl-C mid-scene leaves the previous log intact).
    ``timezone``: the zone the scene's hours follow, stored in the log (an MCAP file's
    metadata, a rosbag2 folder's custom_data, a ROS 1 bag's latched topic:
    :mod:`formats.log_zone`) for ``aion build`` to take without ``--tz``."""
    from aion_cli.formats.writers import LogWriter, check_stamps

    check_stamps(t0_ns + max(n_ticks - 1, 0) * dt_ns, container, "the simulated days")
    idle_ticks = max(round(tf_idle_s * 1e9 / dt_ns), 1)
    det_ticks = np.union1d(obs.tick, np.arange(0, n_ticks, idle_ticks)).astype(np.int64)
    det_start = np.searchsorted(obs.tick, det_ticks, side="left")
    det_end = np.searchsorted(obs.tick, det_ticks, side="right")
    tf_t = np.zeros(0, dtype=np.int64) if robot is None else tf_ticks(robot, det_ticks, idle_ticks)
    tick = np.concatenate([tf_t, frames.tick, det_ticks])
    kind = np.concatenate(
        [np.full(len(tf_t), TF), np.full(len(frames), DSG), np.full(len(det_ticks), DET)]
    )
    index = np.concatenate(
        [np.arange(len(tf_t)), np.arange(len(frames)), np.arange(len(det_ticks))]
    )
    order = np.lexsort((kind, tick))
    map_odom = np.zeros((len(tf_t), 3)) if robot is None else robot.correction(tf_t)
    odom_base = np.zeros((len(tf_t), 3)) if robot is None else robot.odom_pose(tf_t)
    det_topic = DETECTION_TOPICS[msgtype]
    graph_topic = dsg_topic(container)
    total = len(order)
    builder = PayloadBuilder(env, frames, include_mesh)
    with LogWriter(path, container, overwrite=overwrite, lock=False) as log:  # run_scene's
        if timezone is not None:
            from aion_cli.formats.log_zone import KEY, RECORD

            log.add_metadata(RECORD, {KEY: timezone})
        tf_bytes = TfEncoder(log).encode(t0_ns + tf_t * dt_ns, map_odom, odom_base)
        for n, o in enumerate(order):
            k, i = int(tick[o]), int(index[o])
            t_ns = t0_ns + k * dt_ns
            if kind[o] == TF:
                log.write_raw(TF_TOPIC, TF_MESSAGE, tf_bytes[i].tobytes(), t_ns)
            elif kind[o] == DSG:
                payload = builder.payload(i)
                log.write(graph_topic, DSG_UPDATE, dsg_message(t_ns, payload, i), t_ns)
            else:
                rows = slice(int(det_start[i]), int(det_end[i]))
                msg = detection_message(
                    msgtype,
                    t_ns,
                    obs.frame,
                    obs.xyz[rows],
                    obs.velocity[rows],
                    obs.track_id[rows],
                    obs.age_ns[rows],
                    int(det_start[i]),
                    noise,
                )
                log.write(det_topic, msgtype, msg, t_ns)
            if progress is not None and (n % 2000 == 0 or n == total - 1):
                progress(n + 1, total)
    topics = {det_topic: msgtype, graph_topic: DSG_UPDATE}
    if robot is not None:
        topics[TF_TOPIC] = TF_MESSAGE
    return LogCounts(
        tf=len(tf_t),
        dsg=len(frames),
        detections=len(det_ticks),
        detection_rows=len(obs),
        topics=topics,
    )
