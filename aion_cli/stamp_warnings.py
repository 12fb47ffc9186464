"""Warnings on detections whose header stamps follow another clock than their messages' log
times: a day or more away (a simulation's clock from 0, a log recorded again later) or, for most
of a topic, a minute to a day away (another machine's clock or zone). A detection's time is
its stamp, but what was observed comes from the log times, so such detections fall outside the
windows the log recorded."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

FAR_STAMPS = "stamped more than a day away from their messages' log times"


def far_stamps_warning(topic: str, n: int, example: tuple[int, int]) -> str:
    """The warning for ``n`` detections of ``topic`` whose header stamps lie more than a day
    from their log times (``example``: the first one's stamp and log time)."""
    from aion_cli.engine.windows import iso

    return (
        f"{n:,} detection(s) on {topic} are {FAR_STAMPS} (the first stamped "
        f"{iso(example[0])}, logged {iso(example[1])}): stamps and log times follow different "
        "clocks (simulated time; a log recorded again later), and a detection's time is its "
        "stamp but what was observed comes from the log times; if the log times are right, "
        f'build with --detections-mapping giving stamp = "" for {topic} '
        f"(aion info LOG --suggest-mapping {topic} writes one)"
    )


OFF_STAMPS = "stamped more than a minute away from their messages' log times"


def off_stamps_warning(topic: str, n: int, stamped: int, example: tuple[int, int]) -> str:
    """The warning for ``n`` of the ``stamped`` detections of ``topic`` (more than half) whose
    header stamps lie a minute to a day from their log times (``example``: the first one's
    stamp and log time): the stamps' clock is off, and the detections land in other windows
    than the ones the log times say were observed."""
    from aion_cli.engine.windows import iso
    from aion_cli.number_text import span_text

    stamp, logged = example
    offset = ("+" if stamp >= logged else "-") + span_text(abs(stamp - logged) / 1e9)
    return (
        f"{n:,} of the {stamped:,} detection(s) on {topic} are {OFF_STAMPS} (the first "
        f"stamped {iso(stamp)}, logged {iso(logged)}: {offset}):"
        " a detection's time is its stamp but what was observed comes from the log times, so"
        " the detections fall into other windows than the log recorded (those before its"
        " windows are dropped, those after them make windows of their own and leave the"
        " log's own empty); is the tracker on another machine's clock or zone? If the log"
        f' times are right, build with --detections-mapping giving stamp = "" for {topic}'
        f" (aion info LOG --suggest-mapping {topic} writes one)"
    )


def stamp_warnings(topics: Mapping[str, Any]) -> list[str]:
    """The warnings for the per-topic counts ``topics`` (name -> ``TopicCounts``): any
    detection stamped a day away; more than half of a topic's stamped a minute away."""
    out = [
        far_stamps_warning(topic, t.stamps_far, t.far_example)
        for topic, t in sorted(topics.items())
        if t.stamps_far and t.far_example is not None
    ]
    out += [
        off_stamps_warning(topic, t.stamps_off, t.stamped, t.off_example)
        for topic, t in sorted(topics.items())
        if 2 * t.stamps_off > t.stamped and t.off_example is not None
    ]
    return out
