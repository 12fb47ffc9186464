"""The robot trajectory a build takes from TF (``--map-frame`` -> ``--base-frame``), and what
is said when there is none: why, and which frame TF moves in the map instead (a robot whose
base frame has another name, e.g. ``base_footprint``), since without a trajectory a robot's
log is read as a fixed sensor that saw every place in every window it recorded in.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.time_text import utc_text
from aion_cli.engine.types import Trajectory
from aion_cli.errors import TransformError
from aion_cli.log_times import own_recordings, stray_mask

if TYPE_CHECKING:
    from collections.abc import Sequence

    from aion_cli.formats.tf import TfBuffer

__all__ = ["moving_frames", "no_trajectory", "robot_trajectory", "wrong_base_warning"]


def robot_trajectory(
    tf: TfBuffer | None,
    map_frame: str,
    base_frame: str,
    warnings: list[str],
    recordings: Sequence[tuple[int, int]] = (),
    own: Trajectory | None = None,
) -> Trajectory | None:
    """The robot's ``map_frame -> base_frame`` poses (``--map-frame``, ``--base-frame``),
    without stray ones (the time-sanity rule of :func:`aion_cli.log_times.stray_mask` on the
    poses' own stamps: a pose a day away from the rest of the trajectory would make its far
    window an observed one). ``recordings``: the first and last message time of each input
    log that holds TF poses (``/tf``); a run of poses stamped inside one of them, where no
    other pose lies, is that log's own trajectory and stays
    (:func:`aion_cli.log_times.own_recordings`, as for log times): a short robot log a day
    away from a bigger one keeps its poses in one build of both as in a build of it alone
    (``--map``, a parallel build's shard of its own). Logs without ``/tf`` are left out: a
    stray stamp that falls in a fixed sensor's log is no pose of that log. ``own``: the poses
    of the logs' own TF trees (robots recording at once, :meth:`aion_cli.tf_trees.TfTrees.
    poses`), judged instead of ``tf``'s."""
    if tf is None:
        return None
    if own is not None:
        traj = own
    else:
        try:
            traj = tf.trajectory(map_frame, base_frame)
        except TransformError:
            return None
    if len(traj) == 0:
        return None
    t = np.asarray(traj.t_ns, dtype=np.int64)
    stray = own_recordings(t, stray_mask(t), recordings)
    if stray.any():
        warnings.append(
            f"{int(stray.sum()):,} robot pose(s) ignored: stamped more than a day away from "
            f"the rest of the trajectory (first: {utc_text(int(t[stray].min()))})"
        )
        keep = ~stray
        traj = Trajectory(t[keep], np.asarray(traj.xyz)[keep])
    return traj


def no_trajectory(tf: TfBuffer, map_frame: str, base_frame: str) -> str:
    """Why TF gave no robot trajectory: no ``map_frame -> base_frame`` chain, one of
    static transforms only (a sensor mounted in the map frame: no poses over time say
    when it observed, so the log is a fixed sensor), or one whose ``/tf`` links never
    overlap in time."""
    from aion_cli.formats.raw import normalize_frame

    if normalize_frame(base_frame) in tf.connected(map_frame):
        if tf.dynamic_links(map_frame, base_frame):
            return (
                f"TF joins {map_frame}->{base_frame}, but at no time does every transform of "
                "the chain have a pose (its /tf transforms do not overlap in time): no robot "
                "trajectory, so it is taken as a fixed sensor (see below)"
            )
        return (
            f"TF joins {map_frame}->{base_frame} by static transforms only (/tf_static): no "
            "poses over time say when the sensor observed, so it is taken as a fixed sensor "
            "(see below)"
        )
    return (
        f"TF has no {map_frame}->{base_frame} chain for the robot trajectory (frames: "
        f"{', '.join(sorted(tf.frames)[:12])}); see --map-frame / --base-frame"
    )


def moving_frames(tf: TfBuffer, map_frame: str) -> list[str]:
    """The frames joined to ``map_frame`` whose own parent link is a ``/tf`` transform (they
    move in the map: a robot's base, ``odom``), the deepest first (most ``/tf`` links from
    the map: the robot's base before ``odom``), then by name."""
    from aion_cli.formats.raw import normalize_frame
    from aion_cli.formats.tf_tree import parents

    target = normalize_frame(map_frame)
    up = parents(tf.edges)
    links = {f: tf.dynamic_links(target, f) for f in tf.connected(target)}
    moving = [  # a parent fewer /tf links from the map: the link to it is a /tf one
        f for f, n in links.items() if any(links.get(p, n) < n for p in up.get(f, []))
    ]
    return sorted(moving, key=lambda f: (-links[f], f))


def wrong_base_warning(tf: TfBuffer | None, map_frame: str, base_frame: str) -> str | None:
    """A warning when TF has no ``map_frame -> base_frame`` trajectory but moves other frames
    in ``map_frame``: the log is a robot's, which the build is about to read as a fixed sensor
    (every place observed in every window with a message), so name the frame to give as
    ``--base-frame``; None otherwise."""
    from aion_cli.formats.raw import normalize_frame

    target, base = normalize_frame(map_frame), normalize_frame(base_frame)
    if tf is None or target not in tf.frames or base in tf.connected(target):
        return None  # (a chain without poses: no_trajectory says why)
    moving = moving_frames(tf, target)
    if not moving:
        return None
    return (
        f"TF moves {', '.join(repr(f) for f in moving[:3])} in {target!r} but has no "
        f"{target}->{base} chain: this robot's log is read as a fixed sensor that saw every "
        f"place in every window with a message; give the robot's frame, e.g. --base-frame "
        f"{moving[0]}"
    )
