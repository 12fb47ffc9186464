"""``aion info``: what is in a log, and what aion will use from it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.common import AionPath, detections_mapping_option, log_format_option
from aion_cli.cli.graph_options import nav_layer_option
from aion_cli.cli.info_frames import print_frame_notes
from aion_cli.cli.info_log import describe, suggest
from aion_cli.cli.info_map import describe_map, print_map, verify_map
from aion_cli.cli.output import format_option, human_size, to_json

EPILOG = """\b
Examples:
  aion info run.mcap
  aion info run1.mcap run2.bag rosbag2_folder/      several logs, seen as one
  aion info office.aion                              a map: inputs, time span, counts, config
  aion info dsg.json                                 a scene graph: its layers, the places used
  aion info run.mcap --format json | jq '.topics[] | select(.role == "detections")'
  aion info run.bag --suggest-mapping /people > people.toml   a mapping to edit
  aion info run.bag --detections-mapping people.toml         what build takes with it
  aion info run.mcap --verify                        read every chunk: damage and what it loses

\b
Roles: scene_graph (hydra_msgs/DsgUpdate, used by build), detections (a supported people
type, used by build), tf / tf_static (frames and the robot trajectory), unsupported (ignored).
Generic types (PoseStamped, PoseArray, PoseWithCovarianceStamped, PointStamped, Marker,
MarkerArray) are used only from topics whose name suggests people; `why` says why each topic
is used or skipped. --suggest-mapping TOPIC prints a TOML mapping for --detections-mapping
(not for TF, a scene graph or raw sensor data: the error lists the topics that look like
detections).
JSON keys: formats, format, files[{path, format, size_bytes, messages, start_ns, end_ns,
compression}], size_bytes, compression (each file's: its chunks' none / bz2 / lz4 / zstd, from
the index or summary, and a rosbag2 bag's zstd (file) / zstd (message); [] unknown), start_ns,
end_ns, start, end (times null without messages; a stray log time the build drops left out: a
warning names it), span_s (first to last message, the time between logs included; duration_s
is the same), recorded_s (how long the logs
recorded: each log's span, one rosbag2 bag's files joined, overlaps once), recordings (logs with
messages), messages,
topics[{topic, type, count, role, encoding, rate_hz, used, why, readable}] (every topic, also
channels in encodings that are not ROS, such as JSON or protobuf: readable false, type their
schema's name, encoding the channel's; messages counts the readable ones), roles, dsg_versions,
will_use{detections, scene_graph, tf}, cannot_read, warnings,
fixed_sensor{windows_with_messages, span_windows, recorded_windows (the windows with messages,
each a log starts or ends inside counted for the part recorded, as build counts them),
recorded_s (the same in seconds), window_s, hours_with_messages, empty_in_first_messages (of
the first 20 per detection topic)} (only when the logs have no TF, and no scene graph or a
first one without robot poses in its agent layer: build observes the windows with messages),
frames_without_tf{topic: [frames of its first messages that the log's TF does not connect
to 'map']} (aion_cli.frame_check: a build would need --map-frame), tf_roots{frame: the frame
at the top of its TF tree, for those frames that TF knows (the --map-frame to build in when
map->odom is missing)},
observed_spans{log: [{start_ns, end_ns, start, end}]} (the spans aion convert --observed
recorded in a log, which aion build takes as --observed spans), declared_zones{log: zone} (the
time zone aion simulate or convert --tz wrote into a log, which aion build follows without
--tz), mapping_example (without a
detection topic: a topic --suggest-mapping writes a mapping for, or null), with --verify
verified{messages_read} (every message read as a build reads them; chunks that cannot be read
are warnings naming the messages lost).
For a map (.aion): map, format, version, creator, created (UTC; the table shows it, as every
time, in the map's timezone), inputs[{path, name, size, sha256}],
time_span, counts (all builds), entries and places_without_data (the graph's places that hold
no entry: predict lists them too, family none; null when unreadable), last_build,
graph_source, observation, families (how many entries each temporal model family forecasts,
flow and direction), timezone, config, map_frame,
nav_layer (the graph layer of its places: places, mesh_places, ...; null without a graph),
rooms[{id, name, places}], buildings[{id, name, rooms}], warnings (a state and graph that
cannot be read: why nav_layer, rooms and buildings are empty),
merged_from[{name, path, size, sha256}] and lineage (a merged map),
query_only{from{name, path, size, sha256}, left_out} (aion compact),
part{held_days} and observed_spans[[start_ns, end_ns]] (a part map; the spans of --observed),
and with --verify verified{members, bytes, consistent}; several
maps: a list of them.
For a scene graph (.json, .sparkdsg): graph, size_bytes, format, version, reader (spark_dsg or
lenient), nav_layer{name, key}, places, edges, frontiers_left_out, places_with_room, rooms,
buildings, agent_poses, mesh{vertices, faces}, layers[{key, name, nodes}], skipped, notes,
aion (what aion export --format dsg recorded in it, else null).
"""

MAP_SUFFIX = ".aion"


def _steps(report: dict[str, Any]) -> str:
    """The steps of a scene ``aion export --format mcap`` wrote: one ``/aion/scene`` message
    each, at the step's time."""
    from aion_cli.formats.scene_mcap import SCENE_TOPIC

    n = sum(t["count"] for t in report["topics"] if t["topic"] == SCENE_TOPIC)
    if n == 1:
        return f"one step, at {report['start']}"
    return f"{n:,} steps from {report['start']} to {report['end']}"


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


@click.command("info", short_help="What is in logs (maps, graphs), what aion uses.", epilog=EPILOG)
@click.argument("logs", nargs=-1, required=True, type=AionPath(path_type=Path))
@log_format_option
@detections_mapping_option
@click.option(
    "--suggest-mapping",
    "suggest_topic",
    metavar="TOPIC",
    help="Print a ready-to-edit TOML mapping for TOPIC, from the log's own definition of "
    "its type, and exit.",
)
@click.option(
    "--verify",
    is_flag=True,
    help="Maps: read every member and check its checksum and the state's consistency (info "
    "alone reads only the manifest and the graph). Logs: read every message as a build does, "
    "and say which chunks cannot be read and how many messages they hold (info alone reads "
    "the logs' summaries and the first messages).",
)
@click.option(
    "--tz",
    metavar="ZONE",
    help="Logs: the zone the table shows every time in (the first and last message, the "
    "observed spans, a fixed sensor's hours with messages; named once; the warnings' times "
    "with its offset) (IANA name, UTC, "
    "+01:00, local) [default: the zone the logs declare (aion convert or simulate --tz), "
    "else UTC, as aion build reads them without --tz]. JSON times stay UNIX ns and UTC.",
)
@nav_layer_option
@format_option(choices=("table", "json"))
def command(
    logs: tuple[Path, ...],
    log_format: str | None,
    fmt: str,
    nav_layer: str | None = None,
    detections_mapping: Path | None = None,
    suggest_topic: str | None = None,
    verify: bool = False,
    tz: str | None = None,
) -> None:
    """Show the format, duration and topics of LOGS and what aion will use from them.

    Given a map (.aion, or a map under any name) instead, show what it was built from and
    with; given a scene-graph file (.json, .sparkdsg), its layers and the navigational graph
    aion takes from it.
    """
    from aion_cli.errors import InputError

    if suggest_topic is not None and fmt == "json":  # a script would get TOML, not JSON
        raise InputError(
            "--suggest-mapping prints a TOML mapping, not JSON",
            hint="leave out --format json (aion info LOG --format json lists the topics)",
        )
    for path in logs:
        if not path.exists():
            raise InputError(f"not found: {path}", hint="check the path")
    given = {
        "--log-format": log_format is not None,
        "--detections-mapping": detections_mapping is not None,
        "--suggest-mapping": suggest_topic is not None,
        "--verify": verify,
        "--nav-layer": nav_layer is not None,
        "--tz": tz is not None,
    }
    from aion_cli.cli.info_graph import is_graph_file

    if logs and all(is_graph_file(p) for p in logs):
        _refuse_options(given, ("--nav-layer",), "a scene-graph file")
    if _show_graph_files(logs, nav_layer, fmt):
        return
    from aion_cli.formats.input_kind import input_kind

    for p in logs:  # a folder named as a map is no rosbag2 bag to describe (without its yaml)
        if p.is_dir() and p.suffix == MAP_SUFFIX and not (p / "metadata.yaml").is_file():
            from aion_cli.mapquery import check_map_input

            check_map_input(p)  # "is a folder, not a map file", and what a map file is
    # a map by its name or by its content (compact/build -o x.map writes a map of any name)
    maps = [p for p in logs if p.is_file() and (p.suffix == MAP_SUFFIX or input_kind(p) == "map")]
    if maps and len(maps) != len(logs):
        raise InputError(
            "give either logs or maps, not both",
            hint=_apart({"map": maps, "log": [p for p in logs if p not in maps]}),
        )
    if maps:
        _refuse_options(given, ("--verify",), "a map")
    if maps:
        reports = [describe_map(p) for p in maps]
        if verify:
            for path, report in zip(maps, reports, strict=True):
                report["verified"] = verify_map(path)
        if fmt == "json":
            click.echo(to_json(reports[0] if len(reports) == 1 else reports))
        else:
            for report in reports:
                print_map(report)
        return
    _refuse_options(  # aion build LOG --nav-layer takes a log's layer; info does not show it
        given, tuple(name for name in given if name != "--nav-layer"), "logs",
        "--nav-layer describes a scene-graph file (aion info GRAPH_FILE --nav-layer NAME) and "
        "chooses a log's layer in aion build LOG --nav-layer NAME",
    )
    if suggest_topic is not None:
        click.echo(suggest(list(logs), log_format, suggest_topic), nl=False)
        return
    from aion_cli.timeparse import resolve_zone

    zone = "UTC" if tz is None else resolve_zone(tz).name  # a bad zone: before any reading
    if tz is None:  # the zone aion build follows without --tz: the one the logs declare
        from aion_cli.log_zone import build_zone

        zone = build_zone(None, None, list(logs))[0] or "UTC"
    report = describe(list(logs), log_format, detections_mapping, zone, verify)
    if fmt == "json":
        click.echo(to_json(report))
    else:
        _print(report, zone)


def rate_text(hz: float) -> str:
    """A topic's rate for the table: two decimals, or two significant digits below 0.1 Hz, so
    a scene graph every ten minutes reads 0.0017, not 0.00 (a topic with messages)."""
    from aion_cli.cli.output import small_num

    return small_num(hz)


def _refuse_options(
    given: dict[str, bool], applies: tuple[str, ...], what: str, others: str | None = None
) -> None:
    """An :class:`InputError` naming the options given that do nothing for ``what`` (only
    ``applies`` do): an option silently ignored looks as if it had been taken. ``others``:
    what the other options are for (default: reading logs)."""
    from aion_cli.errors import InputError

    ignored = [name for name, on in given.items() if on and name not in applies]
    if ignored:
        if others is None:
            others = ("the others read logs" if what != "a scene-graph file" else
                      "--verify checks maps and logs, the others read logs")
        raise InputError(
            f"{', '.join(ignored)} {'does' if len(ignored) == 1 else 'do'} not apply to {what}",
            hint=f"for {what} only {', '.join(applies)} applies; {others}",
        )


def _apart(kinds: dict[str, list[Path]]) -> str:
    """The hint of a mix of kinds: which path is of which kind (the first of each; an empty
    kind: the rest), and one ``aion info`` of each kind's paths (printed through
    :func:`aion_cli.cli.errors.one_line`, which makes control characters visible)."""
    from aion_cli.errors import path_word

    named = [(kind, paths) for kind, paths in kinds.items() if paths]
    said = ", ".join(f"{paths[0]} {'is a ' + kind if kind else 'is not'}" for kind, paths in named)
    runs = "; ".join("aion info " + " ".join(map(path_word, paths))
                     for _, paths in named)
    return f"{said}: describe each kind apart ({runs})"


def _show_graph_files(paths: tuple[Path, ...], nav_layer: str | None, fmt: str) -> bool:
    """The GRAPH_FILE branch: describe scene-graph files (:mod:`aion_cli.cli.info_graph`);
    False when ``paths`` are no graph files."""
    from aion_cli.cli.info_graph import describe_graph, is_graph_file, print_graph
    from aion_cli.errors import InputError

    graphs = [p for p in paths if is_graph_file(p)]
    if not graphs:
        return False
    if len(graphs) != len(paths):
        raise InputError(
            "give either logs, maps or scene-graph files, not a mix",
            hint=_apart({"scene-graph file": graphs, "": [p for p in paths if p not in graphs]}),
        )
    reports = [describe_graph(p, nav_layer) for p in graphs]
    if fmt == "json":
        click.echo(to_json(reports[0] if len(reports) == 1 else reports))
    else:
        for report in reports:
            print_graph(report)
    return True


def _seconds_text(seconds: float) -> str:
    """A time for the header: seconds, a long one also in days or hours."""
    from aion_cli.cli.build_summary import span_text

    readable = ""
    if seconds >= 2 * 86400:
        readable = f" = {seconds / 86400:,.1f} days"
    elif seconds >= 3600:
        readable = f" = {span_text(seconds)}"
    return f"{seconds:,.1f} s{readable}"


def _print(report: dict[str, Any], zone: str = "UTC") -> None:
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
        see = "see the warnings" if report["warnings"] else "the others: see the topics"
        messages = f"{messages} readable of {held:,} ({see})"
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
        f"compression: {safe(', '.join(report['compression']) or '?')}  "
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
        rate = "-" if t["rate_hz"] is None else rate_text(t["rate_hz"])
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
            what = f"it is a scene aion exported, to open in Foxglove or RViz: {_steps(report)}"
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
    if not use["scene_graph"] and not scene:
        console().print(
            "[yellow]note:[/yellow] no scene graph: build with --graph FILE or --derive-graph",
            soft_wrap=True,
        )
    print_frame_notes(report)
    fixed = report.get("fixed_sensor")
    if fixed and fixed["span_windows"]:
        from aion_cli.fixed_sensor_text import share_text, time_text

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
            text += (
                f", {recorded:g} of {'it' if count == 1 else 'them'} recorded "
                f"({time_text(round(seconds * 1e9))}: a log that starts or ends inside a "
                "window observes only the part it recorded)"
            )
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
    for path, declared in (report.get("declared_zones") or {}).items():
        which = "its time zone (aion simulate or convert --tz), the one of the times here" \
            if declared == zone else \
            f"the time zone {safe(declared)} (aion simulate or convert --tz)"
        console().print(
            f"[yellow]note:[/yellow] {safe(Path(path).name)} declares {which}: `aion build` "
            "follows it unless --tz is given",
            soft_wrap=True,
        )
    from aion_cli.engine.time_text import on_clock
    from aion_cli.timeparse import resolve_zone

    shown = resolve_zone(zone)  # the warnings' times (written in UTC) on the table's clock
    warn_each([on_clock(str(w), shown) for w in report["warnings"]])
