"""``aion build``: learn (or extend) a 4D scene-graph map from logs."""

from __future__ import annotations

from pathlib import Path
from types import TracebackType
from typing import Any

import click

from aion_cli.build_options import MAX_WORKERS
from aion_cli.cli.common import (
    AionPath,
    base_frame_option,
    detections_mapping_option,
    graph_topic_option,
    load_config,
    log_format_option,
    map_frame_option,
    quiet_option,
)
from aion_cli.cli.graph_options import graph_period_option, nav_layer_option
from aion_cli.cli.output import AionCommand, format_option, to_json
from aion_cli.merge_lineage import LINEAGES

EPILOG = """\b
Examples:
  aion build run.mcap                          writes run.aion next to the log
  aion build run1.mcap run2.bag -o office.aion  several logs, merged in time order
  aion build run3.mcap --map office.aion       continue a map with a new log
  aion build tracks.mcap --derive-graph        no scene graph: derive one from walking people
  aion build run.mcap --graph dsg.json         use a scene graph saved by Hydra
  aion build legs.bag --map-frame laser        a fixed sensor's frame as the map frame
  aion build run.bag --detections-mapping people.toml   people of another message type
  aion build run.mcap --nav-layer PLACES       3D places even where the graph has 2D ones
  aion build hydra.mcap --graph-period 0       every scene graph of a live Hydra stream
  aion build day*.mcap -o site.aion --workers 4   four processes at once
  aion build day*.mcap -o site.aion --scheduler tcp://10.0.0.5:8786   on a Dask cluster
  aion build mon.mcap --part -o mon.part.aion  a part for an exact aion merge later
  aion build legs.mcap --observed "2026-01-05..2026-01-12"   a tracker silent when
                                               nobody is there: those days were observed
  aion build --print-config > model.toml       dump every model parameter, edit, then
  aion build run.mcap --config model.toml      build with it

\b
Topics are found by message type. All topics with a people type are used, generic types
(PoseStamped, PoseArray, PoseWithCovarianceStamped, PointStamped, Marker, MarkerArray) only
when the topic name suggests people (person, people, human, pedestrian, agent, track, leg,
crowd); name the ones you want with --detections-topic (repeatable), e.g. when a tracker
publishes the same people twice. Other types: --detections-mapping FILE. Detections without
ids are linked into short tracks, so their headings come from motion. Without a robot trajectory (TF
map->base_link or the scene graph's agent layer) the log is treated as a fixed sensor over
the windows in which it recorded messages, and the spans --observed declares; the summary
says so. The time span comes from the
messages used; a message logged more than a day away from its topic's others (a run of at most
10 messages and 5 % of the topic), or outside 1900..2261, is dropped with a warning. Logs
must be added to a --map in time order; a log given twice is used once. Warnings are printed
also with -q and --format json (on stderr). An interrupted or failed build leaves an existing
map untouched. Several logs are built in parallel (--workers, default one process per core)
when they form groups that share no time window, and a long log is cut into time shards at
quiet moments (window starts with nobody seen in the 10 s before); the parts' maps are joined
into the map a sequential build makes: integers equal, float sums to rounding (a join adds a
part's sums at once, one process term by term: the last bits can differ, within 1e-12
relative). A part that could not be joined so is learnt in sequence, and the summary says so.

\b
JSON keys (--format json): map, map_bytes, continued, detections{read, used,
dropped{reason: n}} (of these logs), map_detections{read, used} (in the map written, a
continued map's included: what aion info MAP counts), detections_by_topic{topic: {read, used,
dropped{reason: n}}}, cells
(unbound hash cells), nodes, nodes_with_flow, bound_cells, windows (most windows any entry
observed, the open one included, a window partly recorded for its share, rounded; not the
windows with messages aion info counts), hours_observed (per kind of day), time_span{start_ns,
end_ns, seconds}, observation, graph{source, layer,
messages (applied), skipped (damaged), decoded, read_by_changes (of decoded: only the node
records changed since the last payload re-read), skipped_identical (applied without decoding:
the last payload again), skipped_period (left out by --graph-period), period_s, dsg_version,
topics}, detection_topics, detection_decoding{topic: {type, why,
decoder (fast|generic|mapping), messages, undecodable}}, log_times_dropped{topic:
{out_of_range, stray}}, tf_undecodable, headings{velocity, track, linked, pose_yaw, none},
mean_speed_m_s (of the detections with a speed),
inputs[{path, name, size, sha256}], workers[{shard, logs, from, to (a time shard's part),
worker, seconds, peak_rss_mb, detections_used}] (a parallel build's shards), notes, warnings.
"""


class _RichProgress:
    """Adapts a rich progress bar to :class:`aion_cli.build_report.ProgressSink`."""

    def __init__(self, quiet: bool) -> None:
        from aion_cli.cli.console import progress

        self._progress = progress(quiet)
        self._task: Any = None

    def __enter__(self) -> _RichProgress:
        self._progress.__enter__()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._progress.__exit__(exc_type, exc, tb)

    def start(self, description: str, total: int, unit: str = "msgs") -> None:
        if self._task is not None:
            self._progress.update(self._task, completed=self._progress.tasks[-1].total)
        self._task = self._progress.add_task(description, total=max(int(total), 1), unit=unit)

    def advance(self, n: int) -> None:
        if self._task is not None:
            self._progress.advance(self._task, n)

    def part(self, key: int, description: str, total: int, unit: str = "msgs") -> None:
        """A parallel build's worker started a phase: its own bar (replacing its last)."""
        bars = self.__dict__.setdefault("_parts", {})
        old = bars.get(key)
        if old is not None:
            self._progress.remove_task(old)
        bars[key] = self._progress.add_task(description, total=max(int(total), 1), unit=unit)

    def part_advance(self, key: int, n: int) -> None:
        task = self.__dict__.get("_parts", {}).get(key)
        if task is not None:
            self._progress.advance(task, n)


@click.command(
    "build",
    short_help="Learn (or extend) a map from logs.",
    cls=AionCommand,
    epilog=EPILOG,
    advanced=(
        "nav_layer",
        "graph_period_ns",
        "graph_topic",
        "map_frame",
        "base_frame",
        "dsg_version",
        "log_format",
        "batch_size",
        "timezone",
    ),
)
@click.argument("logs", nargs=-1, type=AionPath(path_type=Path))
@click.option(
    "-o",
    "--output",
    type=AionPath(path_type=Path, dir_okay=False),
    help="Map file to write [default: the first log's name with .aion, or --map].",
)
@click.option(
    "--map",
    "continue_from",
    type=AionPath(path_type=Path, dir_okay=False),
    help="Continue this existing map with the logs (equals building from all logs).",
)
@click.option(
    "--detections-topic",
    "detection_topics",
    multiple=True,
    metavar="TOPIC",
    help="People-detection topic to use (repeatable) [default: every people type, and "
    "generic types on topics whose name suggests people].",
)
@detections_mapping_option
@graph_topic_option
@click.option(
    "--graph",
    "graph_file",
    type=AionPath(path_type=Path, dir_okay=False),
    help="Scene graph saved by Hydra (dsg.json, .sparkdsg) instead of the log's.",
)
@click.option(
    "--lineage",
    type=click.Choice(LINEAGES, case_sensitive=False),
    default="auto",
    show_default=True,
    help="With --map: whether --graph FILE, else the logs' first scene graph, is of the map's "
    "scene-graph session (node ids go on by id) or of another (the map's places released to "
    "hash cells, then re-bound); auto refuses a graph whose place ids lie elsewhere.",
)
@nav_layer_option
@graph_period_option
@click.option(
    "--derive-graph",
    is_flag=True,
    help="Without any scene graph, derive places from where people walk.",
)
@map_frame_option(
    "Fixed frame of the map; detections are transformed into it with TF [default: the "
    "continued map's (--map), else map]."
)
@base_frame_option
@click.option(
    "--config",
    "config_file",
    type=AionPath(path_type=Path, dir_okay=False),
    help="TOML file of model parameters (see --print-config).",
)
@click.option(
    "--print-config",
    is_flag=True,
    help="Print the model parameters as TOML and exit (no log is read): the defaults, "
    "--config FILE's, or those of the map --map continues.",
)
@click.option(
    "--dsg-version",
    metavar="X.Y.Z",
    help="spark_dsg payload version of the scene graphs [default: detected].",
)
@log_format_option
@click.option(
    "--batch-size",
    default=4000,
    show_default=True,
    type=click.IntRange(min=1),
    help="Detection messages decoded per chunk. Another size may add the map's "
    "floating-point sums in another order, which changes them in their last bits (about "
    "1e-16 relative), never a prediction by more than 1e-9 (relative).",
)
@click.option(
    "--tz",
    "timezone",
    metavar="ZONE",
    help="Time zone of the place mapped (IANA name, UTC, an offset such as +09:00, or local: "
    "the machine's): the local clock of the map's days and daily profiles, and the default of "
    "predict / plan / export [default: UTC; a continued map keeps its own].",
)
@click.option(
    "--workers",
    metavar="N",
    default=0,
    type=click.IntRange(min=0, max=MAX_WORKERS),
    help="Processes building groups of logs that share no time, or time shards of a long "
    "log, at once, joined into the map the sequential build makes, float sums to rounding (0: "
    "one per core; 1: in this process) [default: 0].",
)
@click.option(
    "--scheduler",
    metavar="ADDRESS",
    help="Run the groups of logs on a Dask cluster (e.g. tcp://10.0.0.5:8786; every worker "
    "reads the logs by path). Needs pip install 'aion[dask]'.",
)
@click.option(
    "--part",
    is_flag=True,
    help="Write a part map for an exact `aion merge` later: its closed days are held "
    "unscored (it forecasts nothing on its own).",
)
@click.option(
    "--observed",
    "observed_text",
    metavar="START..END",
    multiple=True,
    help="Without a robot trajectory: a span the sensor was recording (repeatable), e.g. "
    '"2026-01-05 00:00..2026-01-12 00:00": its windows without a message count as observed, '
    "with nobody in them (a tracker that publishes only when it sees someone), to the "
    "span's end, the time between logs included (a new map: from the span's start; "
    "continued: from where the map's logs or spans stopped; --part: the logs' time, aion "
    "merge fills the rest). "
    "Times in --tz, else the continued map's zone, else the zone the logs declare, else UTC. "
    "Without it: the spans the logs record (aion convert --observed); given, it replaces them.",
)
@quiet_option
@format_option(choices=("table", "json"))
def command(
    logs: tuple[Path, ...],
    output: Path | None,
    continue_from: Path | None,
    detection_topics: tuple[str, ...],
    detections_mapping: Path | None,
    graph_topic: str | None,
    graph_file: Path | None,
    lineage: str,
    nav_layer: str | None,
    graph_period_ns: int | None,
    derive_graph: bool,
    map_frame: str | None,
    base_frame: str,
    config_file: Path | None,
    print_config: bool,
    dsg_version: str | None,
    log_format: str | None,
    batch_size: int,
    timezone: str | None,
    workers: int,
    scheduler: str | None,
    part: bool,
    observed_text: tuple[str, ...],
    fmt: str,
) -> None:
    """Learn a 4D scene-graph map from LOGS (MCAP, ROS 1 .bag, rosbag2 folders).

    Reads the people detections, the Hydra scene graphs and TF of the logs in one time-ordered
    stream, learns per place and hash cell how many people walk in which direction and how
    that changes over the day and week, and writes everything to a single map file.
    """
    from aion_cli.build_options import map_frame_of
    from aion_cli.engine.config import ModelConfig
    from aion_cli.errors import InputError
    from aion_cli.graph_schedule import DEFAULT_GRAPH_PERIOD_NS
    from aion_cli.pipeline import BuildOptions, build_map
    from aion_cli.timeparse import resolve_zone

    if print_config and fmt == "json":  # a script would get TOML, not JSON
        raise InputError("--print-config prints TOML, not JSON", hint="leave out --format json")
    config = load_config(config_file)
    if print_config:
        if config is None and continue_from is not None:  # what continuing it would use
            from aion_cli.formats.mapfile import read_manifest

            config = ModelConfig.from_stored(read_manifest(continue_from).get("config"))
        click.echo((config or ModelConfig()).to_toml(), nl=False)
        return
    if not logs:
        raise InputError("no log given", hint="aion build LOG... [-o MAP]; see aion build --help")
    from aion_cli.log_zone import build_zone, continued_zone

    zone_name = None if timezone is None else resolve_zone(timezone).name
    map_zone = continued_zone(continue_from)
    zone_name, zone_notes, zone_warnings = build_zone(zone_name, map_zone, logs)
    observed = observed_spans(observed_text, zone_name, continue_from)
    options = BuildOptions(
        logs=logs,
        output=output,
        config=config,
        log_format=log_format,
        detection_topics=detection_topics,
        graph_topic=graph_topic,
        map_frame=map_frame_of(map_frame, continue_from),
        base_frame=base_frame,
        graph_file=graph_file,
        nav_layer=nav_layer,
        derive_graph=derive_graph,
        continue_from=continue_from,
        lineage=lineage,
        dsg_version=dsg_version,
        batch_size=batch_size,
        timezone=zone_name,
        detections_mapping=detections_mapping,
        graph_period_ns=DEFAULT_GRAPH_PERIOD_NS if graph_period_ns is None else graph_period_ns,
        workers=workers,
        scheduler=scheduler,
        part=part,
        observed=observed,
        observed_typed=tuple(zip(observed_text, observed, strict=True)),
    )
    from aion_cli.cli.build_summary import clock_of

    with _RichProgress(fmt == "json") as progress:
        try:
            report = build_map(options, progress)
        except InputError as exc:  # its times on the map's clock, as the summary gives them
            exc.message = clock_of(zone_name or map_zone or "UTC")(exc.message)
            raise
    report.notes[:0] = [*zone_notes, *observed_notes(observed_text, observed, zone_name,
                                                     continue_from)]
    report.warnings[:0] = zone_warnings
    summary = report.to_dict()
    from aion_cli.cli.build_summary import print_summary, print_warnings

    if fmt == "json":
        click.echo(to_json(summary))
        print_warnings(summary, report.timezone)  # on stderr: stdout stays one JSON document
    else:  # with -q (quiet_option) only its warnings show
        print_summary(summary, report.timezone)


def observed_notes(
    texts: tuple[str, ...],
    spans: tuple[tuple[int, int], ...],
    timezone: str | None,
    continue_from: Path | None,
) -> list[str]:
    """The notes on the ``--observed`` spans (as :func:`observed_spans` read them) whose start
    a clock change of their zone skips or repeats (:func:`cli.common.span_start_notes`)."""
    if not texts:
        return []
    from aion_cli.cli.common import span_start_notes
    from aion_cli.log_zone import continued_zone
    from aion_cli.timeparse import resolve_zone

    zone_name = timezone if timezone is not None else continued_zone(continue_from)
    return span_start_notes(texts, spans, resolve_zone(zone_name or "UTC"), "--observed")


def observed_spans(
    texts: tuple[str, ...], timezone: str | None, continue_from: Path | None
) -> tuple[tuple[int, int], ...]:
    """``--observed`` spans in ns, read in ``timezone`` (``--tz``, or for ``aion build`` the
    zone the logs declare as :func:`aion_cli.log_zone.build_zone` gives it), else the zone of
    the map ``continue_from`` (the continued map; ``evaluate holdout``'s map), else UTC (a bad
    span fails before any log is read)."""
    if not texts:
        return ()
    from aion_cli.cli.common import parse_span
    from aion_cli.log_zone import continued_zone
    from aion_cli.timeparse import resolve_zone

    zone_name = timezone if timezone is not None else continued_zone(continue_from)
    zone = resolve_zone(zone_name or "UTC")
    return tuple(parse_span(text, zone, "--observed") for text in texts)
