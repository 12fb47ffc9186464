"""``aion info``'s table of a log report: the header, the topics and what aion uses each
for, and the notes under it (no detection topic, no scene graph, a fixed sensor's windows,
observed spans, declared zones, warnings).

Split from :mod:`aion_cli.cli.info`; the command there describes the logs and calls
:func:`print_report`."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aion_cli.cli.info_frames import print_frame_notes
from aion_cli.cli.output import human_size
from aion_cli.number_text import significant


def _steps(report: dict[str, Any], zone: str) -> str:
    """The steps of a scene ``aion export --format mcap`` wrote: one ``/aion/scene`` message
    each, at the step's time, on the clock of ``zone`` as the header gives the times (which
    names the zone)."""
    from aion_cli.cli.info_map import clock_in
    from aion_cli.formats.scene_mcap import SCENE_TOPIC

    n = sum(t["count"] for t in report["topics"] if t["topic"] == SCENE_TOPIC)
    start, end = (clock_in(report[key], zone) for key in ("start_ns", "end_ns"))
    if n == 1:
        return f"one step, at {start}"
    return f"{n:,} steps from {start} to {end}"


def _unused_pointer(report: dict[str, Any]) -> str:
    """What info's note on a log without a usable detection topic points to: the generic
    topics skipped for their names, a topic `--suggest-mapping` writes a mapping for
    (``mapping_example``), or that no type of the log holds a position."""
    from aion_cli.errors import NO_DEFINITION_HINT
    from aion_cli.topic_mappable import NO_DEFINITION_REASON

    generic = any(t.get("why", "").endswith("--detections-topic)") for t in report["topics"])
    undefined = any(t.get("why", "").endswith(NO_DEFINITION_REASON) for t in report["topics"])
    example = report.get("mapping_example")
    parts = ["name a generic one with --detections-topic"] if generic else []
    if example is not None:
        parts.append(f"map another type: aion info LOG --suggest-mapping {example}")
    elif undefined:
        parts.append(f"no --detections-mapping can read a type the log does not define: "
                     f"{NO_DEFINITION_HINT}")  # fmt: skip
    elif not generic:
        parts.append("none of its types has a field a --detections-mapping could read as a "
                     "position")  # fmt: skip
    return ", or ".join(parts)


FASTEST_HZ = 100_000.0
"""Above this rate (messages under 10 µs apart on average: no sensor's stream, but stamps a
test or a converter wrote nanoseconds apart) the table gives a topic's ``count`` over the
time it spans (``804 in 2 µs``), not ``402402402.40`` Hz; JSON keeps ``rate_hz``."""


def rate_text(hz: float, count: int | None = None) -> str:
    """A topic's rate for the table: two decimals, or two significant digits below 0.1 Hz, so
    a scene graph every ten minutes reads 0.0017, not 0.00 (a topic with messages); above
    :data:`FASTEST_HZ`, with its ``count``, the count over its span (``count / hz``)."""
    from aion_cli.cli.output import small_num

    if count is not None and hz > FASTEST_HZ:
        return f"{count:,} in {_short_time(count / hz)}"
    return small_num(hz)


def _short_time(seconds: float) -> str:
    """A time under a few seconds to two significant digits in ns, µs, ms or s."""
    for unit, scale in (("ns", 1e-9), ("µs", 1e-6), ("ms", 1e-3)):
        if seconds < 1000 * scale:
            return f"{significant(seconds / scale, 2)} {unit}"
    return f"{significant(seconds, 2)} s"


def _seconds_text(seconds: float) -> str:
    """A time for the header: seconds, a long one also in days or hours, one under a second
    to two significant digits (a 0.48 s bag read "0.5 s", one of 0.03 s "0.0 s")."""
    from aion_cli.cli.build_summary import span_text

    if 0 < seconds < 1:
        return f"{significant(seconds, 2)} s"
    readable = ""
    if seconds >= 2 * 86400:
        readable = f" = {seconds / 86400:,.1f} days"
    elif seconds >= 3600:
        readable = f" = {span_text(seconds)}"
    return f"{seconds:,.1f} s{readable}"


def _recorded_text(fixed: dict[str, Any], count: int, report: dict[str, Any]) -> str:
    """What a fixed-sensor log's windows recorded, when it started or ended inside one: the
    share ``build`` counts (``recorded_windows``, its first and last message placed to
    steps of a 60th of a window) and, when the logs hold less than that, their own time
    (the report's ``recorded_s``): a 0.48 s bag was said to have recorded 10 s, the step the
    build counts it as."""
    from aion_cli.fixed_sensor import EDGE_STEPS
    from aion_cli.fixed_sensor_text import time_text

    counted = float(fixed["recorded_s"])
    text = (
        f", {fixed['recorded_windows']:g} of {'it' if count == 1 else 'them'} counted as "
        f"recorded ({time_text(round(counted * 1e9))}"
    )
    own_s = report.get("recorded_s")
    if isinstance(own_s, int | float) and own_s < counted:
        own = f"{significant(own_s, 2)} s" if own_s < 1 else time_text(round(own_s * 1e9))
        several = int(report.get("recordings") or 1) > 1
        text += f"; the log{'s hold' if several else ' holds'} {own}"
    step = time_text(round(float(fixed["window_s"]) / EDGE_STEPS * 1e9))
    return text + (
        f": build places a log's first and last message to steps of {step}, and a log that "
        "starts or ends inside a window observes only the part it recorded)"
    )


def _unread_text(report: dict[str, Any]) -> str:
    """Where the messages a ROS reader cannot decode are: the warnings that name them, else
    their topics (an MCAP scene aion exported: ``1 on /aion/scene (protobuf)``, for Foxglove,
    whose warning is left out), else the topics table."""
    from aion_cli.listing import first_few

    if report["warnings"]:
        return "see the warnings"
    others = [
        f"{t['count']:,} on {t['topic']} ({t['encoding']})"
        for t in report["topics"]
        if not t.get("readable", True)
    ]
    if not others:
        return "the others: see the topics"
    return f"the rest: {first_few(others, 3)}, which aion's ROS readers do not decode"


def print_report(report: dict[str, Any], zone: str = "UTC") -> None:
    """The table of a log report, every time of the logs on the clock of ``zone`` (the one
    a build follows: :func:`aion_cli.log_zone.build_zone`, or ``--tz``), which the header
    names once (or, for logs without messages, the first note with a time), the warnings'
    times with its offset (:func:`aion_cli.engine.time_text.on_clock`). Every string
    that comes from the log (topic and type names, reasons naming topics, versions,
    warnings) or from the command line (file names) goes through :func:`markup_safe`: a
    topic named ``/x<ESC>[2J`` shows as ``/x\x1b[2J`` instead of clearing the screen, and
    ``[bold]`` in a name is shown, not applied."""
    from rich.table import Table

    from aion_cli.cli.console import console, data_console, print_table, warn_each
    from aion_cli.cli.output import markup_safe as safe

    out = data_console()
    names = safe(", ".join(dict.fromkeys(  # a rosbag2 folder's name for its mcap storage files
        Path(f["path"]).parent.name if f["format"] == "rosbag2-mcap" else Path(f["path"]).name
        for f in report["files"]
    )))
    held = sum(int(f["messages"]) for f in report["files"])
    messages = f"{report['messages']:,}"
    if held > report["messages"]:  # the rest on topics no ROS reader can decode (warnings)
        messages = f"{messages} readable of {held:,} ({_unread_text(report)})"
    read = report.get("verified", {}).get("messages_read")
    if read is not None:
        gone = report["messages"] - read
        lost = f", {gone:,} lost: see the warnings" if gone > 0 else ""
        messages = f"{messages} ({read:,} read{lost})"
    from aion_cli.cli.info_map import clock_in

    said = held > 0 and report.get("start_ns") is not None  # the header names the zone
    if said:
        ends = f"{clock_in(report['start_ns'], zone)} .. {clock_in(report['end_ns'], zone)}"
        span = f"{_seconds_text(report['span_s'])} ({ends} {safe(zone)})"
        times = f"duration: {span}"
    else:  # an empty recording (info opens it; build refuses it)
        times = "duration: none (no messages)"
    if said and report["recordings"] > 1 and report["recorded_s"] < report["span_s"]:
        # several logs with time between them: what they recorded is not their span
        times = (
            f"recorded: {_seconds_text(report['recorded_s'])} in {report['recordings']} logs  "
            f"span: {span}"
        )
    out.print(
        f"[bold]{names}[/bold]  format: {safe(report['format'] or '?')}  "
        f"size: {human_size(report['size_bytes'])}  "
        f"compression: {safe(', '.join(report['compression']) or 'unknown')}  "
        f"{times}  "
        f"messages: {messages}",
        soft_wrap=True,
    )
    table = Table(show_lines=False, header_style="bold")
    for name, justify in (
        ("topic", "left"),
        ("type", "left"),
        ("count", "right"),
        ("Hz", "right"),
        ("aion uses it as", "left"),
    ):
        # names and numbers whole (a narrow terminal wraps what aion does with a topic)
        table.add_column(name, justify=justify, no_wrap=name != "aion uses it as")  # type: ignore[arg-type]
    for t in report["topics"]:
        why = t.get("why", "")
        if t["used"]:
            role = safe(t["role"] + (f" ({why})" if why and why != t["role"] else ""))
        else:
            role = f"[dim]- {safe(why or 'not a type aion reads')}[/dim]"
        if t["topic"] in report["dsg_versions"]:
            role += f" (spark_dsg {safe(', '.join(report['dsg_versions'][t['topic']]))})"
        rate = "-" if t["rate_hz"] is None else rate_text(t["rate_hz"], t["count"])
        table.add_row(safe(t["topic"]), safe(t["type"]), f"{t['count']:,}", rate, role)
    print_table(table)
    use = report["will_use"]
    from aion_cli.formats.scene_mcap import is_scene_mcap

    # a scene aion exported is no log to build a map from: no note on building it with a graph
    scene = bool(report["files"]) and all(is_scene_mcap(Path(f["path"])) for f in report["files"])
    if not use["detections"]:
        from aion_cli.topics import RAW_SENSOR_REASON

        ros = [t for t in report["topics"] if t["readable"]]  # the others are not read at all
        raw = ros and all(t.get("why", "").endswith(RAW_SENSOR_REASON) for t in ros)
        from aion_cli.formats.detections.registry import unreadable_kind

        if raw:
            from aion_cli.formats.detections.registry import RAW_SENSOR_HINT

            what = f"it holds only raw sensor data: {RAW_SENSOR_HINT}"
        elif scene:  # not a log
            steps = _steps(report, zone)
            what = f"it is a scene aion exported, to open in Foxglove or RViz: {steps}"
        elif not ros:  # no messages, or channels in other encodings only
            what = "it has no ROS topic"
            if report["warnings"]:
                what += " aion can read: see the warnings"
        elif all(unreadable_kind(t["type"]) is not None for t in ros):
            what = (
                "none of its topics holds positions of people: logging, parameters, service "
                "calls or plain values"
            )
        else:
            what = _unused_pointer(report)
        console().print(
            "[yellow]note:[/yellow] no people-detection topic of a supported type: "
            f"`aion build` cannot learn flows from this log ({safe(what)})",
            soft_wrap=True,
        )
    if not use["scene_graph"] and not scene and use["detections"]:
        # without people to learn from, a graph would not let the build run (it refuses)
        console().print(
            "[yellow]note:[/yellow] no scene graph: build with --graph FILE or --derive-graph",
            soft_wrap=True,
        )
    print_frame_notes(report)
    fixed = report.get("fixed_sensor")
    if fixed and fixed["span_windows"]:
        from aion_cli.fixed_sensor_text import share_text

        share = fixed["windows_with_messages"] / fixed["span_windows"]
        why = (
            "no TF, and the scene graph's agent layer holds no robot poses"
            if use["scene_graph"]
            else "no TF, no scene graph"
        )
        count = fixed["windows_with_messages"]
        text = (
            f"no robot trajectory ({why}): `aion build` takes the log as a fixed "
            f"sensor over the {count:,} window{'' if count == 1 else 's'} of "
            f"{fixed['window_s'] / 60:g} min with messages"
        )
        recorded, seconds = fixed.get("recorded_windows"), fixed.get("recorded_s")
        if isinstance(recorded, int | float) and isinstance(seconds, int | float) \
                and recorded < count:
            # a log that starts or ends inside a window recorded only that part of it
            text += _recorded_text(fixed, count, report)
        if fixed["span_windows"] > 1:  # a span inside one window is that window, all of it
            text += f", {share_text(share)} of its span"
        empty = int(fixed.get("empty_in_first_messages") or 0)
        if share < 0.5 and empty:  # a tracker that publishes empty messages is not silent
            text += (
                f"; the others were not recorded: its first detection messages include "
                f"{empty:,} with nobody in {'it' if empty == 1 else 'them'}, so the tracker is "
                "not silent when nobody is there"
            )
        elif share < 0.5 and not report.get("observed_spans"):  # else: the note below
            text += (
                "; the others are unknown, not empty: if the tracker is silent when nobody "
                "is there, build with --observed START..END"
            )
        console().print(f"[yellow]note:[/yellow] {text}", soft_wrap=True)
        if fixed.get("hours_with_messages"):
            hours = str(fixed["hours_with_messages"]).removesuffix(f" ({zone})")  # said above
            console().print(f"[yellow]note:[/yellow] hours with messages: {safe(hours)}",
                            soft_wrap=True)
    for path, spans in (report.get("observed_spans") or {}).items():
        listed = ", ".join(
            f"{clock_in(s['start_ns'], zone)} .. {clock_in(s['end_ns'], zone)}" for s in spans
        ) + ("" if said else f" {zone}")
        said = True
        console().print(
            f"[yellow]note:[/yellow] {safe(Path(path).name)} records the spans the sensor was "
            f"observing (aion convert --observed): {listed}; `aion build` takes them as "
            "--observed spans (a window only the log's empty marker messages hold counts for "
            "the share they cover) unless --observed is given",
            soft_wrap=True,
        )
    by_zone: dict[str, list[str]] = {}  # one note per zone, not one per log that declares it
    for path, declared in (report.get("declared_zones") or {}).items():
        by_zone.setdefault(declared, []).append(safe(Path(path).name))
    for declared, logs in by_zone.items():
        many = len(logs) > 1
        who = logs[0] if not many else ", ".join(logs[: min(3, len(logs) - 1)]) + (
            f" and {logs[-1]}" if len(logs) <= 4 else f" and {len(logs) - 3:,} other logs"
        )
        which = f"{'their' if many else 'its'} time zone (aion simulate or convert --tz), the " \
            "one of the times here" if declared == zone else \
            f"the time zone {safe(declared)} (aion simulate or convert --tz)"
        console().print(
            f"[yellow]note:[/yellow] {who} declare{'' if many else 's'} {which}: `aion build` "
            "follows it unless --tz is given",
            soft_wrap=True,
        )
    from aion_cli.engine.time_text import on_clock
    from aion_cli.timeparse import resolve_zone

    shown = resolve_zone(zone)  # the warnings' times (written in UTC) on the table's clock
    warn_each([on_clock(str(w), shown) for w in report["warnings"]])
