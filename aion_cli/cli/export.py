"""``aion export``: PLY/PCD scenes and CSV/JSON tables of a map at a time (or a time series)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from aion_cli.cli.common import (
    STEP_HELP,
    TIME_HELP,
    AionPath,
    announce_time,
    map_argument,
    note_empty,
    quiet_option,
    resolve_time,
    series_of,
    tz_option,
)
from aion_cli.cli.completion import complete_nodes
from aion_cli.cli.output import AionCommand
from aion_cli.number_text import counted

if TYPE_CHECKING:
    from aion_cli.exports import Exported

EPILOG = """\b
Examples:
  aion export office.aion --time "2026-11-23 08:30" -o out/
  aion export office.aion --time "2026-11-23 08:30" -o scene.ply
  aion export office.aion --historical -o out/ --format pcd
  aion export office.aion --from "2026-11-23 06:00" --to "2026-11-23 20:00" --step 1h -o series/
  aion export office.aion --time now --path-from p12 --path-to p87 -o out/
  aion export office.aion --time "2026-11-23 08:30" --format png -o map.png
  aion export office.aion --from "2026-11-23 06:00" --to "2026-11-23 20:00" --step 2h \\
      --format png -o day.png
  aion export office.aion --from "2026-11-23 06:00" --to "2026-11-23 20:00" --step 1h \\
      --format mcap -o day.mcap --path-from p12 --path-to p87
  aion export office.aion --time "2026-11-23 08:30" --format dsg -o office-4d.json

\b
Writes into the -o folder: the scene (nodes as spheres sized by flow and coloured by entropy,
blue low to red high, arrows along the dominant direction, flat squares for hash cells, edges as
lines, the scene graph's mesh, a planned path) as PLY or PCD (their headers' comments give
the time and hour_observed, as the JSON does), plus entries.csv and entries.json with the same
fields as `aion predict`. --from/--to/--step writes one
subfolder per time (named by the time in UTC, e.g. 20261123T060000Z) for animations, a series of
one time (--from T --to T) too; --to is included when it falls on a step, and a step of days
or weeks (1d, 1w) keeps the wall-clock time across a daylight-saving change.

\b
--format png writes one picture, -o naming the file: the map from above (place edges, rooms,
hash cells, arrows along the dominant direction with length proportional to flow, coloured
by direction entropy, blue low to red high); a series becomes small multiples, one panel per
time (at most 24); a map whose floors lie apart in height gets one panel per floor. A time
whose hour no log observed says "(extrapolated: an hour no log observed)" under its title, as
the table of `aion predict` does; in a series, its panel's title ends with "(extrapolated)".
A time over a week before or after the map's data (the default, now, often is) says how far
under its title ("47 weeks after the map's data (2026-01-05 to 2026-01-09)"); --historical
names the days it shows.

\b
--format mcap writes one MCAP file, -o naming it (.mcap), with a step per time logged at
that time, to scrub through in Foxglove (topic /aion/scene, foxglove.SceneUpdate: one entity
per entry named by its id, as `aion predict` prints it) or in RViz (/aion/markers,
visualization_msgs/MarkerArray; /tf_static declares the frame "map", or the --map-frame the
map was built in): the same spheres, arrows, cells, edges, mesh and path as the PLY scene,
sizes on one scale for the whole series.

\b
--format dsg writes the 4D scene graph as a spark_dsg file, -o naming it (.json or .sparkdsg):
the map's places, edges, rooms and buildings, each place and room with its dynamics at the
time (the fields of `aion predict`) in its node metadata under "aion".
"""


@click.command(
    "export",
    short_help="Write scenes (PLY/PCD/MCAP), pictures, the 4D scene graph, tables.",
    cls=AionCommand,
    epilog=EPILOG,
    advanced=("tz",),
    once={"time_text": "for several times, a series: --from T0 --to T1 --step 1h",
          "t_from": "a series has one start", "t_to": "a series has one end"},
)
@map_argument
@click.option(
    "-o",
    "--output",
    "out_dir",
    required=True,
    type=AionPath(path_type=Path),
    help="Folder to write into (made if missing, in an existing folder); for png, mcap and "
    "dsg the file, and a .ply / .pcd name writes the whole scene as that one file. With "
    "--format, a suffix naming another format is refused (--format png -o x.mcap).",
)
@click.option(
    "-t",
    "--time",
    "time_text",
    metavar="T",
    help="Prediction time [default: now, without --historical or --from/--to]. " + TIME_HELP,
)
@click.option("--historical", is_flag=True, help="Export what was observed instead.")
@click.option("--from", "t_from", metavar="T", help="Start of a time series.")
@click.option("--to", "t_to", metavar="T", help="End of a time series (inclusive).")
@click.option(
    "--step",
    metavar="DURATION",
    default=None,
    help=f"Time-series step: {STEP_HELP} [default: 1h; with --from and --to].",
)
@tz_option
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["ply", "pcd", "png", "mcap", "dsg"], case_sensitive=False),
    default=None,
    help="Point-cloud / scene format, png for a top-down picture, mcap for Foxglove/RViz, "
    "dsg for the 4D scene graph as a spark_dsg file (.json / .sparkdsg).  [default: from "
    "-o's suffix: .png, .mcap, .json or .sparkdsg; else ply]",
)
@click.option(
    "--path-from",
    metavar="A",
    help="Also plan and draw a path from A (place, room or building id, or x,y).",
    shell_complete=complete_nodes,
)
@click.option("--path-to", metavar="B", help="... to B.", shell_complete=complete_nodes)
@click.option(
    "--force",
    is_flag=True,
    help="Also replace aion's files in the -o folder that no export into it wrote (a scene "
    "'aion plan --export' saved there, an export's file changed since); never other files.",
)
@quiet_option
def command(
    map_path: Path,
    out_dir: Path,
    time_text: str | None,
    historical: bool,
    t_from: str | None,
    t_to: str | None,
    step: str | None,
    tz: str | None,
    fmt: str | None,
    path_from: str | None,
    path_to: str | None,
    force: bool,
) -> None:
    """Export MAP as 3D scenes (PLY/PCD, MCAP over time), pictures (PNG), the 4D scene graph
    (a spark_dsg file) and tables (CSV/JSON)."""
    from aion_cli.api_results import DISTANCE_PATH, flowless_places_note
    from aion_cli.cli.common import load
    from aion_cli.cli.console import console, note, progress, warn
    from aion_cli.cli.plan import snapped_text
    from aion_cli.errors import InputError
    from aion_cli.export_stale import stale_note
    from aion_cli.exports import (
        HISTORICAL_PATH,
        export_format,
        path_ends,
        scene_file,
        write_export,
    )
    from aion_cli.formats.dsg_export import not_stored_note
    from aion_cli.graph_export import cells_left_out

    modes = sum([time_text is not None, historical, t_from is not None or t_to is not None])
    if modes > 1:
        raise InputError(
            "choose one of --time, --historical or --from/--to",
            hint="--time T: the forecast at T; --historical: what was observed; --from/--to: "
            "a series",
        )
    if step is not None and t_from is None and t_to is None:
        raise InputError("--step needs --from and --to", hint="a series: --from T --to T --step 1h")
    if (t_from is None) != (t_to is None):
        raise InputError(
            "a time series needs both --from and --to",
            hint='e.g. --from "2026-11-23 06:00" --to "2026-11-23 20:00" --step 1h',
        )
    if (path_from is None) != (path_to is None):
        raise InputError(
            "a path needs both --path-from and --path-to", hint="e.g. --path-from p1 --path-to p12"
        )
    fmt = export_format(fmt, out_dir)
    loaded = load(map_path)
    times: list[int | None]
    zone = None
    if historical:
        times = [None]
    elif t_from is not None and t_to is not None:
        steps, zone = series_of(
            t_from, t_to, "1h" if step is None else step, tz, loaded, "frames"
        )
        times = list(steps)
    else:
        when, zone = resolve_time("now" if time_text is None else time_text, tz, loaded)
        times = [when]
    ends = None
    snapped: list[dict[str, Any]] = []  # ends given as points, rooms or buildings
    if path_from is not None and path_to is not None:
        ends = path_ends(loaded, path_from, path_to, snapped)  # bad ids fail before any write
    series = t_from is not None  # a series, even of one time (--from T --to T)
    if fmt == "dsg":
        if series:
            raise InputError(
                "--format dsg writes the graph at one time, not a series (--from/--to)",
                hint="use --time or --historical",
            )
        if ends is not None:
            raise InputError(
                "--format dsg holds no path: leave out --path-from/--path-to",
                hint="draw the path with --format ply, png or mcap, or 'aion plan --export'",
            )
    elif scene_file(fmt, out_dir) and series:
        raise InputError(
            f"a series writes one {fmt} scene per time into a folder, got a file: -o {out_dir}",
            hint="name a folder (e.g. -o series/), give --time for one scene, or "
            "--format png / mcap for one file",
        )
    with progress(quiet=len(times) == 1) as bar:
        task = bar.add_task("exporting", total=len(times), unit="times")
        written = write_export(
            loaded, map_path, out_dir, times, zone, fmt, ends, lambda: bar.advance(task),
            series=series, force=force,
        )  # fmt: skip
    if zone is not None and times[0] is not None:
        label = f"series of {len(times)} from" if series else "time"
        span = [int(t) for t in times if t is not None] if series else None
        announce_time(times[0], zone, label, loaded, series=span, text=t_from or time_text)
    else:  # --historical: no forecast's notes, but an empty map's
        note_empty(loaded)
    for snap in snapped:
        note(snapped_text(snap))
    if historical and ends is not None:
        note(HISTORICAL_PATH)
    elif ends is not None and (flowless := flowless_places_note(loaded.state, DISTANCE_PATH)):
        note(flowless)  # places without people: the path drawn is by distance
    console().print(_written(written, fmt, out_dir, len(times)), soft_wrap=True)
    if written.stale is not None and (said := stale_note(written.stale, out_dir)) is not None:
        note(said)
    if written.graph is not None:
        note(not_stored_note(loaded.graph.layer_name))
        left_out = cells_left_out(loaded)
        if left_out is not None:
            (warn if left_out[1] else note)(left_out[0])


def _written(written: Exported, fmt: str, out: Path, steps: int) -> str:
    """The closing line: what :func:`aion_cli.exports.write_export` wrote."""
    from aion_cli.cli.output import markup_safe
    from aion_cli.exports import scene_file

    if written.graph is not None:
        done = written.graph
        extra = f", {counted(done.agents, 'robot pose')}" if done.agents else ""
        if done.mesh_vertices:
            extra += f", a mesh of {done.mesh_vertices:,} vertices"
        return (
            f"wrote {markup_safe(out)}: {counted(done.places, 'place')} in layer "
            f"{done.place_layer} ({done.places_with_dynamics:,} with dynamics), "
            f"{counted(done.rooms, 'room')}, {counted(done.buildings, 'building')}, "
            f"{counted(done.edges, 'place edge')}{extra}"
        )
    if fmt == "png":
        return f"wrote {markup_safe(out)}"
    if fmt == "mcap":
        return f"wrote {markup_safe(out)} ({steps} step(s); open it in Foxglove)"
    if scene_file(fmt, out):
        return f"wrote {markup_safe(out)} (the whole scene in one {fmt} file)"
    return f"wrote {len(written.files)} file(s) to {markup_safe(out)}"
