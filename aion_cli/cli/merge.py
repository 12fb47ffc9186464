"""``aion merge``: one map from maps of disjoint time (``aion_cli.merging``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.common import AionPath, quiet_option
from aion_cli.cli.graph_options import nav_layer_option
from aion_cli.cli.output import AionCommand, format_option, map_output_option, to_json
from aion_cli.merge_lineage import LINEAGES

EPILOG = """\b
Examples:
  aion merge monday.aion tuesday.aion -o week.aion
  aion merge robot1.aion robot2.aion -o office.aion --graph dsg.json
  aion merge old.aion new.aion -o both.aion --lineage different
  aion merge part.aion -o map.aion          one part map (build --part): its days scored

\b
The maps must share their model parameters (the planner's plan_* may differ: the merged map
plans with the first map's, a note names the others) and time zone, and no log may be in two
of them, nor one recording in two log files (a log is never counted twice). They are merged
in time order: counts, speed sums and the temporal model add (the same as building from all
the logs at once for maps of one scene-graph session, but for the approximations the notes
name). Maps from different scene-graph sessions (node ids reused at unrelated positions;
--lineage auto finds them from the graphs) first release every place's state to the hash
cells at its position; the merged cells then bind to the target graph (--graph FILE, else
the newest map's), its places taken as stable at the merge time. Maps whose times overlap
(robots at once) keep the graph one build of their logs keeps: one session's graphs joined
(graph_source says which). A map most of whose detections lie away from the other maps'
(another place, another frame) is warned of. The output lists every input log and the maps
it was merged from; an existing map at -o is replaced atomically, anything else is refused.

\b
JSON keys (--format json): map, map_bytes, inputs[{path, name, size, sha256, start_ns,
end_ns, logs, detections}], lineage, parts (part maps joined), lineage_reason, graph_source,
released_nodes, rebound_cells, detections, logs, cells, nodes, nodes_with_flow, bound_cells,
windows, hours_observed, time_span{start_ns, end_ns, seconds}, notes, warnings (printed on
stderr also with -q and --format json, as aion build's).
"""


@click.command(
    "merge",
    short_help="Merge maps of disjoint time into one.",
    cls=AionCommand,
    epilog=EPILOG,
    advanced=("nav_layer",),
)
@click.argument("maps", nargs=-1, type=AionPath(path_type=Path))
@map_output_option()
@click.option(
    "--graph",
    "graph_file",
    type=AionPath(path_type=Path, dir_okay=False),
    help="Scene graph saved by Hydra (dsg.json, .sparkdsg) to bind the merged map to.",
)
@click.option(
    "--lineage",
    type=click.Choice(LINEAGES, case_sensitive=False),
    default="auto",
    show_default=True,
    help="Whether the maps come from one scene-graph session (node ids add by id) or from "
    "different ones (released to hash cells, then re-bound); auto decides from the graphs.",
)
@nav_layer_option
@quiet_option
@format_option(choices=("table", "json"))
def command(
    maps: tuple[Path, ...],
    output: Path,
    graph_file: Path | None,
    lineage: str,
    nav_layer: str | None,
    fmt: str,
) -> None:
    """Merge the map files MAPS (two or more, built from different logs) into one map; or
    turn one part map (aion build --part) into a map."""
    from aion_cli.cli.build import _RichProgress
    from aion_cli.errors import InputError
    from aion_cli.merging import merge_map_files

    if not maps:
        raise InputError(
            "a merge needs at least two maps (or one part map)",
            hint="aion merge A.aion B.aion ... -o OUT.aion",
        )
    with _RichProgress(fmt == "json") as progress:
        report = merge_map_files(list(maps), output, graph_file, lineage, progress, nav_layer)
    summary = report.to_dict()
    from aion_cli.cli.build_summary import print_warnings

    if fmt == "json":
        click.echo(to_json(summary))
    else:  # with -q (quiet_option) nothing shows
        print_summary(summary, report.timezone)
    print_warnings(summary, report.timezone)  # on stderr, also with -q and --format json


def print_summary(summary: dict[str, Any], zone: str = "UTC") -> None:
    """The closing table (on stderr, like ``aion build``'s) and the notes, their times on
    ``zone``'s clock (the merged map's); every name from a map or path is shown as plain
    text."""
    from rich.table import Table

    from aion_cli.cli.build_summary import add_map_rows, clock_of, span_text
    from aion_cli.cli.console import console, print_table
    from aion_cli.cli.output import human_size, markup_safe
    from aion_cli.engine.time_text import utc_text

    table = Table(
        title=f"map {markup_safe(summary['map'])}", show_header=False, title_justify="left"
    )
    table.add_column("what", style="bold", no_wrap=True)
    table.add_column("value", justify="right")
    from aion_cli.merge_names import shown_names

    for item, shown in zip(summary["inputs"], shown_names(summary["inputs"]), strict=True):
        table.add_row(
            f"input {markup_safe(shown)}",
            f"{item['detections']:,} detections, {item['logs']} log(s)",
        )
    table.add_row("lineage", markup_safe(summary["lineage"]))
    table.add_row("graph", markup_safe(summary["graph_source"]))
    table.add_row("logs", f"{summary['logs']:,}")
    table.add_row("detections", f"{summary['detections']:,}")
    add_map_rows(table, summary)
    span, shown = summary["time_span"], clock_of(zone)
    if span["start_ns"] is not None and span["end_ns"] is not None:
        table.add_row("first time", shown(utc_text(span["start_ns"])))
        table.add_row("last time", shown(utc_text(span["end_ns"])))
    table.add_row("time span", span_text(span["seconds"]))
    table.add_row("map size", human_size(summary["map_bytes"]))
    print_table(table, err=True)
    out = console()
    out.print(f"[dim]lineage: {markup_safe(summary['lineage_reason'])}[/dim]", soft_wrap=True)
    for message in summary["notes"]:
        out.print(f"[yellow]note:[/yellow] {markup_safe(shown(message))}", soft_wrap=True)
