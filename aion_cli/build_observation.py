"""The observation of a build: which windows (and which places in them) its map observed,
said in the report: the robot trajectory TF gives (``--map-frame`` -> ``--base-frame``), else
the scene graphs' agent layer, else a fixed sensor over the windows the logs recorded in
(:mod:`aion_cli.fixed_sensor`); beside a robot's, the logs it does not observe are fixed
sensors over their own windows.

Why apart from :mod:`aion_cli.tf_feed`, which reads TF into a buffer before the stream: what
the buffer's trajectory means for the map (and for a time shard of a parallel build, what one
pass's whole trajectory decides for the part) is a question of observation, not of reading.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.types import I64, Trajectory
from aion_cli.engine.windows import window_ns
from aion_cli.fixed_sensor import fixed_sensor_windows, unposed_log_windows
from aion_cli.fixed_sensor_text import time_text
from aion_cli.tf_trajectory import no_trajectory, robot_trajectory, wrong_base_warning

if TYPE_CHECKING:
    from aion_cli.build_report import BuildReport
    from aion_cli.engine.mapper import Mapper
    from aion_cli.formats.tf import TfBuffer
    from aion_cli.log_times import TimeCheck

__all__ = ["NO_TRAJECTORY_NOTE", "SILENT_NOTE", "observe", "silent_note"]


def observe(
    mapper: Mapper,
    tf: TfBuffer | None,
    frames: tuple[str, str],
    graph_agents: Callable[[tuple[int, int] | None], bool],
    logset: Any,
    times: TimeCheck,
    report: BuildReport,
    declared: tuple[tuple[int, int], ...] = (),
    detection_windows: I64 | None = None,
    fill: tuple[int | None, int | None] = (None, None),
    marks: I64 | None = None,
    whole: TimeCheck | None = None,
    opens_map: bool = False,
    begun: bool = False,
    tf_logs: tuple[tuple[int, int], ...] = (),
    own_poses: Trajectory | None = None,
) -> None:
    """The observation of a build, said in ``report.observation``: the robot trajectory
    ``frames`` (``--map-frame``, ``--base-frame``) from TF, added to ``mapper``; else the scene
    graphs' agent layer when the first graph has one (``graph_agents``; its poses are fed
    per snapshot); else a fixed sensor over the windows it recorded in and the ``declared``
    spans (:func:`fixed_sensor_windows`; with a robot's observation they are ignored, with
    a warning: its poses say what it saw; ``fill`` widens the time they may fill:
    :func:`~aion_cli.observed_spans.declared_windows`; ``marks``: the times of the messages
    that only mark the spans the logs record, :func:`aion_cli.log_observed.marker_times`).
    ``detection_windows``: the windows holding a message of a detection topic; the robot's
    windows without one are counted in a note (:func:`silent_note`). Beside a robot
    trajectory, logs of other times that hold none of its poses are fixed sensors over their
    own windows (:func:`unposed_log_windows`), as a build of them alone (a continuation, a
    parallel shard) observes them. ``whole``: a time shard's ``times`` without its limits;
    whether the robot observes a group of logs is judged by all its poses, not the part's.
    ``opens_map``: the shard's logs start a new map (no map or logs before them); ``begun``:
    a shard after others (or onto a map): where its map starts (:func:`_one_pass_start`).
    ``tf_logs``: the first and last message time of each log holding ``/tf`` messages; a
    run of poses that is all of one such log's is never a stray (:func:`robot_trajectory`).
    ``own_poses``: the robot poses of the logs' own TF trees, where robots recording at once
    each have one (:meth:`aion_cli.tf_trees.TfTrees.poses`), taken instead of ``tf``'s."""
    map_frame, base_frame = frames
    traj = robot_trajectory(tf, map_frame, base_frame, report.warnings, tf_logs, own_poses)
    why_none = None if tf is None or traj is not None else no_trajectory(tf, map_frame, base_frame)
    if why_none is not None:
        report.notes.append(why_none)
    if traj is not None:
        delta = window_ns(mapper.state.config.window_s)
        # every pose's window, also a time shard's outside its part (one pass judges a group
        # of logs by all of them: fixed_sensor.unposed_log_windows)
        every = np.unique(np.asarray(traj.t_ns, dtype=np.int64) // delta)
        part = times.inside_limits(traj.t_ns)  # a time shard observes with its own poses
        if not part.all():
            traj = Trajectory(np.asarray(traj.t_ns)[part], np.asarray(traj.xyz)[part])
        mapper.add_trajectory(traj)
        report.observation = f"tf {map_frame}->{base_frame}"
        _ignored(declared, report.observation, report.warnings)
        poses = np.unique(np.asarray(traj.t_ns, dtype=np.int64) // delta)

        def posed(lo: int, hi: int) -> bool:
            at = int(np.searchsorted(every, lo))
            return at < every.size and int(every[at]) <= hi

        unposed, unposed_from = unposed_log_windows(
            mapper, logset, times, posed, report.notes, report, whole
        )
        if unposed is not None:
            report.observation += " + " + unposed
        first = int(every[0]) if unposed_from is None else min(int(every[0]), unposed_from)
        _one_pass_start(mapper, times, first * delta, opens_map, begun)
        if detection_windows is not None:
            silent = np.setdiff1d(poses, detection_windows, assume_unique=True)
            report.silent_windows = (int(silent.size), delta)
            if silent.size:
                report.notes.append(silent_note(int(silent.size), delta))
    elif graph_agents(None):
        report.observation = "scene-graph agent layer"  # fed per snapshot
        _ignored(declared, report.observation, report.warnings)
        delta = window_ns(mapper.state.config.window_s)
        unposed, _ = unposed_log_windows(  # (no pose is added before the stream)
            mapper,
            logset,
            times,
            lambda lo, hi: graph_agents((lo * delta, (hi + 1) * delta)),
            report.notes,
            report,
            whole,
        )
        if unposed is not None:
            report.observation += " + " + unposed
    else:
        wrong_base = wrong_base_warning(tf, map_frame, base_frame)
        if wrong_base is not None:  # says what the note said, and names the frame to give
            report.warnings.append(wrong_base)
            if why_none in report.notes:
                report.notes.remove(why_none)
        report.observation = fixed_sensor_windows(
            mapper, logset, times, report.notes, report, declared, fill, marks
        )
        report.notes.append(
            f"{NO_TRAJECTORY_NOTE}{map_frame}->{base_frame} or scene-graph agents): the log "
            "is treated as a fixed sensor that saw everything in the windows in which it "
            "recorded any message, within the time of the topics aion uses"
        )


def _one_pass_start(
    mapper: Mapper, times: TimeCheck, first_ns: int, opens_map: bool, begun: bool
) -> None:
    """Where a shard's map starts, as one pass's does, after its robot poses were added.

    One pass adds every robot pose (and the windows of the logs beside the robot's that it
    reads as fixed sensors) before the stream, so a new map starts at the first of them
    (``first_ns``) and drops the detections before it as ``before_window`` (a tracker
    recording before the localisation started). A time shard of a new map's first logs
    (``opens_map``) starting at or before that time starts there too: holding none of those
    poses it would start at its own first detection and keep them.

    A shard whose map one pass had begun before (``begun``: a group of logs after others, or
    onto a map; or such a time shard starting after ``first_ns``) starts at its first
    message when that comes before its first pose: one pass streams the detections before
    that pose into its open map, where the shard, its own poses added first, would start at
    the first of them and drop those detections."""
    part = times.limits
    if opens_map and part is not None and first_ns >= part[0]:
        mapper.start_at(first_ns)
    elif (begun or (opens_map and part is not None)) and times.start_ns is not None:
        mapper.start_at(times.start_ns)


NO_TRAJECTORY_NOTE = "no robot trajectory (TF "
"""The start of the note of a log without a robot trajectory (its frames follow)."""


SILENT_NOTE = "robot trajectory: "


def silent_note(n: int, delta: int) -> str:
    """The note on ``n`` windows the robot's poses observe in which no detection topic
    recorded a message (a parallel build adds its shards' up into one)."""
    return (
        f"{SILENT_NOTE}{n:,} window(s) ({time_text(n * delta)}) with robot poses hold "
        "no message of the detection topic(s): they count as observed and empty (nobody "
        "there); a tracker that publishes only when it sees someone leaves them so, but one "
        "that was down then (crashed, not started) did not observe them: leave that time "
        "out of the logs"
    )


def _ignored(declared: tuple[tuple[int, int], ...], observation: str, warnings: list[str]) -> None:
    if declared:
        warnings.append(
            f"--observed ignored: the logs have a robot trajectory ({observation}), whose "
            "poses say which places the sensor saw in each window"
        )
