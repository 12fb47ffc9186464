"""``aion info LOG``: what the log's TF says about frames -- detection frames it does not join
to ``map`` (and the top of their tree, the ``--map-frame`` to build in), transforms a build
ignores, a robot that moves without ``base_link`` -- into the report, and its notes.

Split from :mod:`aion_cli.cli.info`; the command there calls these. The reading is
:func:`aion_cli.frame_check.unconnected_frames`.
"""

from __future__ import annotations

from typing import Any


def add_frames(
    report: dict[str, Any], logset: Any, plan: Any, mappings: list[Any], robot_poses_elsewhere: bool
) -> None:
    """``frames_without_tf``, ``tf_roots`` and the TF warnings into ``report`` (and, for a fixed
    sensor, how many of the detection messages sampled held nobody; how a Marker topic is
    read, into ``plan``'s reasons: the topic's ``why``); the warning on
    a robot without ``base_link`` only when no scene graph gives robot poses
    (``robot_poses_elsewhere``: the build would observe with those)."""
    from aion_cli.frame_check import unconnected_frames

    frames = unconnected_frames(logset, plan, mappings)
    for topic, text in frames.read_as.items():  # how a Marker topic is read: in its `why`
        plan.reasons[topic] = f"{plan.reasons.get(topic, 'detections')}; {text}"
    report["frames_without_tf"] = frames.apart
    report["tf_roots"] = frames.roots
    report["warnings"].extend(frames.warnings)
    if report.get("fixed_sensor") is not None:  # a silent tracker publishes no empty message
        report["fixed_sensor"]["empty_in_first_messages"] = frames.empty_messages
    if frames.no_robot is not None and not robot_poses_elsewhere:
        report["warnings"].append(frames.no_robot)


def print_frame_notes(report: dict[str, Any]) -> None:
    """A note per detection topic whose frames TF does not join to ``map``, with the
    ``--map-frame`` to build with: the top of the frame's TF tree when TF knows the frame
    (``map -> odom`` missing), else the frame itself when it is a fixed one."""
    from aion_cli.cli.console import console
    from aion_cli.cli.output import markup_safe as safe
    from aion_cli.frame_check import TF_SAMPLE

    has_tf = bool(report.get("will_use", {}).get("tf"))
    roots = report.get("tf_roots") or {}
    for topic, frames in (report.get("frames_without_tf") or {}).items():
        named = ", ".join(f"'{f}'" for f in frames)
        apart = (
            f"which the log's TF (its first {TF_SAMPLE} messages per TF topic) does not connect "
            "to 'map'"
            if has_tf
            else "and the log has no TF to 'map'"
        )
        top = roots.get(frames[0], frames[0])
        advice = (
            f"build with --map-frame {safe(top)} (the top of the TF tree {safe(frames[0])!r} is "
            f"in) or give the TF map->{safe(top)}"
            if top != frames[0]
            else f"build with --map-frame {safe(top)} (if it is a fixed frame) or give the TF"
        )
        console().print(
            f"[yellow]note:[/yellow] {safe(topic)} holds detections in frame {safe(named)}, "
            f"{apart}: {advice}",
            soft_wrap=True,
        )
