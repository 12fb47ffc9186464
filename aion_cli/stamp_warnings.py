"""Warnings on detections whose header stamps follow another clock than their messages' log times:
a day or more away (a simulation's clock from 0, a log recorded again later) or, for more than
1 % of a topic, a minute to a day away (another machine's clock or zone, or one that stepped
mid-log). A detection's time is its stamp, but what was observed comes from the log times, so
such detections fall outside the windows the log recorded. And the warning for a map whose time
is a simulation's, from 1970 (:func:`sim_time_warning`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

FAR_STAMPS = "stamped more than a day away from their messages' log times"


def far_stamps_warning(topic: str, n: int, example: tuple[int, int]) -> str:
    """The warning for ``n`` detections of ``topic`` whose header stamps lie more than a day
    from their log times (``example``: the first one's stamp and log time)."""
    from aion_cli.engine.time_text import utc_text

    return (
        f"{n:,} detection(s) on {topic} are {FAR_STAMPS} (the first stamped "
        f"{utc_text(example[0])}, logged {utc_text(example[1])}): stamps and log times follow "
        "different clocks (simulated time; a log recorded again later), and a detection's time is "
        f"its stamp but what was observed comes from the log times; {_log_times_hint(topic)}"
    )


def _log_times_hint(topic: str, opening: str = "if") -> str:
    """The way out when a topic's log times are right and its stamps are not (``opening``:
    "If" to start a sentence)."""
    return (
        f'{opening} the log times are right, build with --detections-mapping giving stamp = "" '
        f"for {topic} (aion info LOG --suggest-mapping {topic} writes one)"
    )


OFF_STAMPS = "stamped more than a minute away from their messages' log times"

#: share of a topic's detections stamped a minute to a day off their log times above which the
#: build warns: a tracker's clock stepped mid-log (half of them off) or runs on another clock
#: (all off); one glitch among thousands is not warned of
OFF_STAMPS_SHARE = 0.01


def off_stamps_warning(topic: str, n: int, stamped: int, example: tuple[int, int]) -> str:
    """The warning for ``n`` of the ``stamped`` detections of ``topic`` (more than
    :data:`OFF_STAMPS_SHARE` of them) whose header stamps lie a minute to a day from their log
    times (``example``: the first one's stamp and log time): the stamps' clock is off, and the
    detections land in other windows than the ones the log times say were observed."""
    from aion_cli.engine.time_text import utc_text
    from aion_cli.number_text import span_text

    stamp, logged = example
    offset = ("+" if stamp >= logged else "-") + span_text(abs(stamp - logged) / 1e9)
    return (
        f"{n:,} of the {stamped:,} detection(s) on {topic} are {OFF_STAMPS} (the first "
        f"stamped {utc_text(stamp)}, logged {utc_text(logged)}: {offset}):"
        " a detection's time is its stamp but what was observed comes from the log times, so"
        " the detections fall into other windows than the log recorded (those before its"
        " windows are dropped, those after them make windows of their own and leave the"
        " log's own empty); is the tracker on another machine's clock or zone? "
        + _log_times_hint(topic, "If")
    )


def stamp_warnings(topics: Mapping[str, Any]) -> list[str]:
    """The warnings for the per-topic counts ``topics`` (name -> ``TopicCounts``): any
    detection stamped a day away; more than :data:`OFF_STAMPS_SHARE` of a topic's stamped a
    minute away."""
    out = [
        far_stamps_warning(topic, t.stamps_far, t.far_example)
        for topic, t in sorted(topics.items())
        if t.stamps_far and t.far_example is not None
    ]
    out += [
        off_stamps_warning(topic, t.stamps_off, t.stamped, t.off_example)
        for topic, t in sorted(topics.items())
        if t.stamps_off > OFF_STAMPS_SHARE * t.stamped and t.off_example is not None
    ]
    return out


SIM_TIME_BEFORE_NS = 946_684_800 * 1_000_000_000
"""2000-01-01 00:00 UTC: a map whose data starts before it was recorded on a simulation's
clock from 0 (Gazebo with use_sim_time), not the world's (no ROS log is older)."""

SIM_TIME = "a simulation's clock from 0 (use_sim_time)?"


def sim_time_warning(
    start_ns: int | None, what: str = "the map's data", query: bool = True
) -> str | None:
    """The warning for a map whose data (``what``: a log's messages) starts at ``start_ns``
    before :data:`SIM_TIME_BEFORE_NS`; None for a later (or no) start. ``query``: it says at
    which times to query the map; False for logs a map is judged on (``aion evaluate
    holdout``'s test logs), which it says are judged at that clock's hours."""
    if start_ns is None or start_ns >= SIM_TIME_BEFORE_NS:
        return None
    from datetime import UTC, datetime, timedelta

    from aion_cli.engine.time_text import utc_text

    when = datetime(1970, 1, 1, tzinfo=UTC) + timedelta(microseconds=start_ns // 1000)
    head = (
        f"{what} starts at {utc_text(start_ns)} (a {when:%A}), {SIM_TIME} Its hours of "
        "the day and weekdays are that clock's, not the world's"
    )
    if not query:
        return (
            f"{head}, and the map's forecast is judged at them: record the logs with the wall "
            "clock"
        )
    return (
        f"{head}, and a forecast for now lies decades after its data: query it at times of its "
        f'own (aion predict MAP --time "{when:%Y-%m-%d} 08:00"), or record the logs with the '
        "wall clock"
    )
