"""``aion plan``: a path that avoids crowded and opposing flows, beside the shortest one."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.common import (
    STEP_HELP,
    TIME_HELP,
    AionPath,
    announce_time,
    map_argument,
    map_zone,
    option_given,
    quiet_option,
    resolve_time,
    tz_option,
)
from aion_cli.cli.completion import complete_nodes
from aion_cli.cli.output import AionCommand, format_option, to_json
from aion_cli.note_words import EXTRAPOLATED

EPILOG = """\b
Examples:
  aion plan office.aion --from p12 --to p87 --time "tomorrow 12:00"
  aion plan office.aion --from 0,0 --to 12.5,3 --time "2026-11-23 08:30" --speed 1.2
  aion plan office.aion --from p12 --to p87 --format json
  aion plan office.aion --from p12 --to p87 --export path.ply   the scene with the path
  aion plan office.aion --from p12 --to p87 --png plan.png      both paths over the flows
  aion plan office.aion --from kitchen --to R4 --leave "08:00..10:00" --step 10m
                                          when to leave: the departure of least cost

\b
--from/--to take node ids ("p12") or coordinates "x,y[,z]" snapped to the nearest node
(horizontally for x,y: a spot on the floor plan).
The temporal cost of each node is predicted for the time the walker is expected to arrive
there (departure + distance / speed), read per model window: the forecast at the start of
the arrival's window (at the departure time within the departure's window). The
distance-only path is always shown beside it, with the temporal cost it would have (never
less than the temporal plan's: where it would be, it is the temporal plan too).
JSON keys: map, from, to, depart, depart_ns, zone, speed_mps,
temporal{path, length_m, duration_s, cost, arrival, arrival_ns}, distance_only{the same},
snapped[{option, room or building and name (a room or building asked for), reachable_only
(true where the place nearest its centre was not joined to the other end), point, node,
distance_m}] (a start or goal given as a point, room or building) (and export / png: the
files written; with --leave, departures[{depart, depart_ns, cost, length_m, duration_s,
distance_only_cost, best, hour_observed}]); hour_observed (a map that lists its observed
hours: whether any day observed the (best) departure's hour; where not, the costs come from
extrapolated flows).

\b
--png draws the map from above at the departure (place edges, rooms, arrows along the
dominant direction with length proportional to flow, coloured by direction entropy) with the
temporal path (green) over the distance-only path (orange, dashed), each with its length and
cost in the legend; a departure at an hour no log observed is titled as the table is, with
"(extrapolated: an hour no log observed)", and one over a week before or after the map's
data (the default, now, often is) says how far, as aion export --format png does.
"""


@click.command(
    "plan",
    short_help="A path that avoids busy, opposing flows.",
    cls=AionCommand,
    epilog=EPILOG,
    advanced=("tz",),
    once={"time_text": "for several departures, --leave START..END --step 10m",
          "leave": "--leave takes one span",
          "start": "a route has one start; plan again for another",
          "goal": "a route has one goal; plan again for another"},
)
@map_argument
@click.option(
    "--from",
    "start",
    required=True,
    metavar="A",
    help="Start: a place (p12), a room or building by id or name (R3, kitchen: its place "
    "nearest the centre) or a point x,y[,z].",
    shell_complete=complete_nodes,
)
@click.option(
    "--to",
    "goal",
    required=True,
    metavar="B",
    help="Goal: a place, a room or building by id or name, or a point x,y[,z].",
    shell_complete=complete_nodes,
)
@click.option(
    "-t",
    "--time",
    "time_text",
    metavar="T",
    default="now",
    show_default=True,
    help="Departure time. " + TIME_HELP,
)
@click.option(
    "--leave",
    metavar="START..END",
    help="Find the best departure between these times (instead of --time): plans every "
    "--step and keeps the one of least temporal cost (T..T: the one departure T).",
)
@click.option(
    "--step",
    metavar="DURATION",
    help=f"Departures every DURATION with --leave: {STEP_HELP} [default: 10m].",
)
@tz_option
@click.option(
    "--speed",
    type=click.FloatRange(min=0.01, max=20.0),
    help="Walking speed in m/s [default: the map's plan_speed].",
)
@click.option(
    "--export",
    "export_path",
    type=AionPath(path_type=Path, dir_okay=False),
    help="Also write the scene with the planned (temporal) path to this .ply file.",
)
@click.option(
    "--png",
    "png_path",
    metavar="FILE",
    type=AionPath(path_type=Path, dir_okay=False),
    help="Also draw both paths over the flow map at the departure into this .png file.",
)
@format_option(choices=("table", "json"))
@quiet_option
def command(
    map_path: Path,
    start: str,
    goal: str,
    time_text: str,
    leave: str | None,
    step: str | None,
    tz: str | None,
    speed: float | None,
    export_path: Path | None,
    png_path: Path | None,
    fmt: str,
) -> None:
    """Plan a path on the navigational graph of MAP from A to B, departing at a time."""
    from aion_cli.api import Plan
    from aion_cli.api_results import alike_note, departure_rows, flowless_places_note
    from aion_cli.cli.common import load, span_start_notes
    from aion_cli.cli.console import note, progress
    from aion_cli.cli.plan_departures import departure_times, print_departures
    from aion_cli.errors import InputError
    from aion_cli.mapquery import entry_positions, nav_graph
    from aion_cli.predictions import hour_flags
    from aion_cli.routes import plan_departures, plan_routes, resolve_ends

    time_given = option_given("time_text")
    if leave is not None and time_given:
        raise InputError(
            "choose one of --time or --leave",
            hint="--time T: leave at T; --leave START..END: compare departures in that span",
        )
    if step is not None and leave is None:
        raise InputError("--step needs --leave", hint='e.g. --leave "08:00..10:00" --step 10m')
    if png_path is not None:
        from aion_cli.pictures.render import check_png_target

        check_png_target(png_path, "--png")  # before any planning
    if export_path is not None:
        from aion_cli.exports import check_plan_export

        check_plan_export(export_path)  # so is the scene's
    loaded = load(map_path)
    zone = map_zone(tz, loaded)
    every = "10m" if step is None else step
    leaving = None if leave is None else departure_times(leave, every, zone)
    nav = nav_graph(loaded)
    a, b = resolve_ends(start, goal, nav, loaded.graph, entry_positions(loaded.state))
    if leaving is None:
        t_ns, _ = resolve_time(time_text, tz, loaded)
        routes = plan_routes(loaded, a.node_id, b.node_id, t_ns, speed, nav)
        departures = None
        (seen,) = hour_flags(loaded, [t_ns])
    else:
        with progress(quiet=len(leaving) == 1) as bar:
            task = bar.add_task("planning", total=len(leaving), unit="departures")
            observed = hour_flags(loaded, leaving)
            plans, best = plan_departures(
                loaded, a.node_id, b.node_id, leaving, speed, nav,
                lambda done: bar.update(task, completed=done), observed,
            )
        routes, t_ns, seen = plans[best], leaving[best], observed[best]
        departures = departure_rows(plans, best, zone, observed)
    snapped = [s for s in (a.snapped("--from"), b.snapped("--to")) if s is not None]
    report = {"map": str(map_path), **Plan.from_routes(routes, zone, snapped, seen).to_dict()}
    if departures is not None:
        report["departures"] = departures
    temporal = routes.temporal
    if export_path is not None:
        from aion_cli.exports import export_plan_scene

        export_plan_scene(loaded, t_ns, nav, temporal.rows, export_path, zone)
        report["export"] = str(export_path)
    if png_path is not None:
        from aion_cli.pictures.render import plan_png

        plan_png(loaded, routes, nav, zone, png_path, ends=_end_labels(report), observed=seen)
        report["png"] = str(png_path)
    announce_time(
        t_ns, zone, "departure" if departures is None else "best departure", loaded, leaving,
        "departures", text=time_text if departures is None and time_given else None,
    )
    if leave is not None and leaving:  # the start typed, read across a clock change
        for line in span_start_notes([leave], [(leaving[0], leaving[-1])], zone, "--leave"):
            note(line)
    flowless = flowless_places_note(loaded.state)
    if flowless is not None:  # the two plans alike, and why
        note(flowless)
    alike = None if departures is None else alike_note(departures)
    if alike is not None:  # "best" would read as quieter
        note(alike)
    if fmt == "json":
        click.echo(to_json(report))
    else:
        if departures is not None:
            print_departures(departures, zone)
        _print(report)


def snapped_text(snap: dict[str, Any]) -> str:
    """What a ``snapped`` record (a plan's end given as a point, room or building) stands
    for, as plan and ``export --path-from/--path-to`` say it."""
    within = next((k for k in ("room", "building") if k in snap), None)
    if within is not None:
        asked = snap[within] if "name" not in snap else f"{snap['name']} ({snap[within]})"
        among = (
            f" of those joined to the {'goal' if snap['option'].endswith('from') else 'start'}"
            if snap.get("reachable_only") else ""
        )
        return (
            f"{snap['option']} {asked}: its place nearest the {within}'s centre{among}, "
            f"{snap['node']} ({snap['distance_m']:.2f} m from it)"
        )
    from aion_cli.engine.node_ids import point_text

    return (
        f"{snap['option']} {point_text(snap['point'])} snapped to {snap['node']} "
        f"({snap['distance_m']:.2f} m away)"
    )


def _print(report: dict[str, Any]) -> None:
    from rich.table import Table
    from rich.text import Text

    from aion_cli.cli.console import console, note, print_table
    from aion_cli.cli.output import markup_safe, printable

    for snap in report["snapped"]:
        note(snapped_text(snap))
    ends = _end_labels(report)
    title = f"{ends[0]} -> {ends[1]}, departing {report['depart']}"
    if report.get("hour_observed") is False:  # stdout kept in a file keeps the word
        title += f" {EXTRAPOLATED}"
    table = Table(title=Text(printable(title)), min_width=len(title))  # the title kept whole
    table.add_column("plan", style="bold", no_wrap=True)
    table.add_column("length", justify="right", no_wrap=True)
    table.add_column("time", justify="right", no_wrap=True)
    table.add_column("cost", justify="right", no_wrap=True)
    table.add_column("path")  # wraps between nodes on a narrow terminal
    for name, key in (("temporal", "temporal"), ("distance only", "distance_only")):
        part = report[key]
        table.add_row(
            name,
            f"{part['length_m']:.1f} m",
            f"{part['duration_s']:.0f} s",
            f"{part['cost']:.1f}",
            Text(printable(" > ".join(part["path"]))),
        )
    print_table(table)
    for key in ("export", "png"):
        if key in report:
            console().print(f"wrote {markup_safe(report[key])}", soft_wrap=True)


def _end_labels(report: dict[str, Any]) -> tuple[str, str]:
    """The start and goal as the table and the picture name them: a room or building asked
    for by its name or id, with its place (``kitchen (p117)``), else the place id."""
    named = {
        snap["option"]: f"{snap.get('name') or snap.get('room') or snap.get('building')} "
        f"({snap['node']})"
        for snap in report["snapped"]
        if "room" in snap or "building" in snap
    }
    return named.get("--from", report["from"]), named.get("--to", report["to"])
