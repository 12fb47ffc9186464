"""``aion info LOG``: the notes on what the log's TF says about frames -- detection frames it
does not join to ``map``, with the ``--map-frame`` to build in (the top of their tree).

Split from :mod:`aion_cli.cli.info`; the command there prints them. The report's
``frames_without_tf`` and ``tf_roots`` are :func:`aion_cli.log_report.add_frames`'; the
reading is :func:`aion_cli.frame_check.unconnected_frames`.
"""

from __future__ import annotations

from typing import Any


def print_frame_notes(report: dict[str, Any]) -> None:
    """A note per detection topic whose frames TF does not join to ``map``, with the
    ``--map-frame`` to build with: the top of the frame's TF tree when TF knows the frame
    (``map -> odom`` missing), else the frame itself when it is a fixed one."""
    from aion_cli.cli.console import console
    from aion_cli.cli.output import markup_safe as safe
    from aion_cli.frame_check import TF_SAMPLE

    has_tf = bool(report.get("will_use", {}).get("tf"))
    roots = report.get("tf_roots") or {}
    several = int(report.get("recordings") or 1) > 1  # logs given (a split bag is one)
    logs = "logs'" if several else "log's"
    for topic, frames in (report.get("frames_without_tf") or {}).items():
        named = ", ".join(f"'{f}'" for f in frames)
        apart = (
            f"which the {logs} TF (its first {TF_SAMPLE} messages per TF topic) does not "
            "connect to 'map'"
            if has_tf
            else f"and the {'logs have' if several else 'log has'} no TF to 'map'"
        )
        tops = list(dict.fromkeys(roots.get(f, f) for f in frames))
        top = tops[0]
        if len(tops) > 1:  # no TF joins them: the build stops on the second it meets
            each = ", ".join(f"--map-frame {safe(t)}" for t in tops)
            advice = f"build the logs of each frame into a map of its own ({each}) or give the TF"
        elif top != frames[0]:
            advice = (
                f"build with --map-frame {safe(top)} (the top of the TF tree {safe(frames[0])!r} "
                f"is in) or give the TF map->{safe(top)}"
            )
        else:
            advice = f"build with --map-frame {safe(top)} (if it is a fixed frame) or give the TF"
        console().print(
            f"[yellow]note:[/yellow] {safe(topic)} holds detections in "
            f"{'frames' if len(frames) > 1 else 'frame'} {safe(named)}, {apart}: {advice}",
            soft_wrap=True,
        )
