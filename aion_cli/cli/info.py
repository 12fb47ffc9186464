"""``aion info``: what is in a log, and what aion will use from it."""

from __future__ import annotations

from pathlib import Path

import click

from aion_cli.cli.common import AionPath, detections_mapping_option, log_format_option
from aion_cli.cli.graph_options import nav_layer_option
from aion_cli.cli.info_map import describe_map, print_map, verify_map
from aion_cli.cli.info_table import print_report
from aion_cli.cli.output import format_option, to_json
from aion_cli.log_report import describe, report_zone, suggest

EPILOG = """\b
Examples:
  aion info run.mcap
  aion info run1.mcap run2.bag rosbag2_folder/      several logs, seen as one
  aion info office.aion                              a map: inputs, time span, counts, config
  aion info dsg.json                                 a scene graph: its layers, the places used
  aion info run.mcap --format json | jq '.topics[] | select(.role == "detections" and .used)'
  aion info run.bag --suggest-mapping /people > people.toml   a mapping to edit
  aion info run.bag --detections-mapping people.toml         what build takes with it
  aion info run.mcap --verify                        read every chunk: damage and what it loses

\b
Roles (by type): scene_graph (hydra_msgs/DsgUpdate, used by build), detections (a type aion
reads people from), tf / tf_static (frames and the robot trajectory), unsupported (ignored).
Generic types (PoseStamped, PoseArray, PoseWithCovarianceStamped, PointStamped, Marker,
MarkerArray) are used only from topics whose name suggests people: a detections topic the
build skips (leg_tracker's /visualization_marker_array) has used false; `used` says whether
build takes each topic (will_use lists those taken), `why` why it is used or skipped.
--suggest-mapping TOPIC prints a TOML mapping for --detections-mapping (not for TF, a scene
graph or raw sensor data: the error lists the topics that look like detections).
JSON keys: formats, format, files[{path, format, size_bytes, messages, start_ns, end_ns,
compression}], size_bytes, compression (each file's: its chunks' none / bz2 / lz4 / zstd, from
the index or summary, none for a file without chunks, and a rosbag2 bag's zstd (file) / zstd
(message); [] unknown), start_ns,
end_ns, start, end (times null without messages; a stray log time the build drops left out: a
warning names it), span_s (first to last message, the time between logs included; duration_s
is the same), recorded_s (how long the logs
recorded: each log's span, one rosbag2 bag's files joined, overlaps once), recordings (logs with
messages), messages,
topics[{topic, type, count, role, encoding, rate_hz, used, why, readable}] (every topic, also
channels in encodings that are not ROS, such as JSON or protobuf: readable false, type their
schema's name, encoding the channel's; messages counts the readable ones),
roles{role: [topics of its types, used or not]}, dsg_versions,
will_use{detections, scene_graph, tf}, cannot_read, warnings,
fixed_sensor{windows_with_messages, span_windows, recorded_windows (the windows with messages,
each a log starts or ends inside counted for the part recorded, as build counts them),
recorded_s (the same in seconds: the build's count, each log's first and last
message placed to a 60th of a window; the logs' own time is the recorded_s above), window_s,
hours_with_messages, empty_in_first_messages (of the first 20 per detection topic)} (only
when the logs have no TF, and no scene graph or a first one without robot poses in its agent
layer: build observes the windows with messages),
frames_without_tf{topic: [frames of its first messages, in each log, that the log's TF does
not connect to 'map']} (aion_cli.frame_check: a build would need --map-frame),
tf_roots{frame: the frame at the top of its TF tree, for those frames that TF knows (the
--map-frame to build in when map->odom is missing)},
observed_spans{log: [{start_ns, end_ns, start, end}]} (the spans aion convert --observed
recorded in a log, which aion build takes as --observed spans), declared_zones{log: zone} (the
time zone aion simulate or convert --tz wrote into a log, which aion build follows without
--tz), mapping_example (without a
detection topic: a topic --suggest-mapping writes a mapping for, or null), with --verify
verified{messages_read} (every message read as a build reads them; chunks that cannot be read
are warnings naming the messages lost).
For a map (.aion): map, format, version, creator, created (UTC; the table shows it, as every
time, in the map's timezone), inputs[{path, name, size, sha256}],
time_span{start_ns, end_ns}, counts{read, used, dropped{reason: detections}, empty_messages
(detection messages that held none), cells, nodes, nodes_with_flow, bound_cells, windows
(observed); a fixed sensor's recording_windows (its logs' own time, in windows),
recording_reach and recording_first (the last and the first window its logs recorded, as
window numbers since 1970)} over all builds, entries and places_without_data (the graph's
places that hold no entry: predict lists them too, family none; null when unreadable),
last_build{read, used, dropped} (the latest build alone), graph_source, observation,
families{flow{family: entries}, direction{family: entries} (how many entries each temporal
model family forecasts), reconciled, scored_days, scored_windows, last_day_provisional,
observed_bins (the profile bins, hour of day x kind of day, in which anything was observed),
rules (the version of the rules that chose them), calendar{calendar (week or day_weekend: the
calendar the map's days ask for), gain (the week's day-ahead gain, nats), weekday_days}}
(formats/MAPFILE.md says more), timezone, config, map_frame,
nav_layer (the graph layer of its places: places, mesh_places, ...; null without a graph),
rooms[{id, name, places}], buildings[{id, name, rooms}], warnings (a state and graph that
cannot be read: why nav_layer, rooms and buildings are empty),
merged_from[{name, path, size, sha256}] and lineage (a merged map),
query_only{from{name, path, size, sha256}, left_out} (aion compact),
part{held_days} and observed_spans[[start_ns, end_ns]] (a part map; the spans of --observed),
and with --verify verified{members, bytes, consistent, sealed, derived_stale} (sealed: the map
carries the seal of its derived members; derived_stale: why they are not its own, which
queries then compute again, else null); several
maps: a list of them.
For a scene graph (.json, .sparkdsg): graph, size_bytes, format, version, reader (spark_dsg or
lenient), nav_layer{name, key}, places, edges, frontiers_left_out, places_with_room, rooms,
buildings, agent_poses, mesh{vertices, faces}, layers[{key, name, nodes}], skipped, notes,
aion (what aion export --format dsg recorded in it, else null).
"""

MAP_SUFFIX = ".aion"


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
    zone = report_zone(tz, list(logs))  # a bad zone: before any reading
    report = describe(list(logs), log_format, detections_mapping, zone, verify)
    if fmt == "json":
        click.echo(to_json(report))
    else:
        print_report(report, zone)


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
