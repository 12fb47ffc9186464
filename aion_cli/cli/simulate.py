"""``aion simulate``: realistic synthetic robot logs with ground truth (tests, demos, evals)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from aion_cli.cli.common import AionPath, quiet_option
from aion_cli.cli.graph_options import nav_layer_option
from aion_cli.cli.output import AionCommand

if TYPE_CHECKING:
    from datetime import date

    from aion_cli.sim.scenario import SceneResult

EPILOG = """\b
Examples:
  aion simulate -o office.mcap                          one day in the paper's office
  aion simulate -o week.mcap --days 7 --seed 3          a week: daily and weekly rhythm
  aion simulate -o paper/ --scenes 20 --agents 6        the paper's dataset shape
  aion simulate -o apt.bag --format bag \\
      --environment ../shared/data/dsg/apartment_dsg.json   people in a real scene graph
  aion simulate -o hydra.mcap --environment dsg.json --nav-layer PLACES
                                                        walk the 3D places, not the 2D ones
  aion simulate -o fixed.mcap --robot fixed --detection-type people
  aion build office.mcap -o office.aion                 then learn a map from it

\b
Each log gets <log>.truth.npz and <log>.truth.json beside it: the true flow per place,
window and direction bin (all people, seen or not), what the sensor covered, and the
scene-graph events (places added, moved by loop closures, merged, removed).
The same --seed gives byte-identical logs.
"""


def _hours(text: str) -> tuple[float, float]:
    from aion_cli.errors import InputError

    try:
        lo, hi = (float(v) for v in text.split("-", 1))
    except ValueError as exc:
        raise InputError(f"bad --patrol-hours {text!r}", hint="give START-END, e.g. 7-20") from exc
    if not (0 <= lo <= 24 and 0 <= hi <= 24):
        raise InputError(f"bad --patrol-hours {text!r}", hint="hours lie in 0..24")
    if lo == hi:
        raise InputError(
            f"--patrol-hours {text!r} is an empty span: no tour would start",
            hint="0-24 is all day; START after END wraps past midnight (22-6)",
        )
    return lo, hi


def _summary(results: list[SceneResult]) -> None:
    from aion_cli.cli.console import console, warn
    from aion_cli.cli.output import markup_safe as safe  # names from the scene-graph file

    first = results[0].meta if results else {}
    if first.get("nav_layer"):
        console().print(
            f"environment {safe(first['environment'])}: navigational layer "
            f"{safe(first['nav_layer'])}, {first['places']:,} walkable places",
            soft_wrap=True,
        )
    for note in first.get("environment_notes", []):
        console().print(f"[yellow]note:[/yellow] {safe(note)}", soft_wrap=True)
    for r in results:
        m = r.meta
        ev = _event_counts(r)
        console().print(
            f"wrote {safe(r.log)}: {m['detections']:,} detections in "
            f"{m['messages']['detections']:,} "
            f"messages, {m['messages']['scene_graph']:,} scene graphs, {m['messages']['tf']:,} "
            f"TF; {ev}; truth {safe(r.truth_npz)}",
            soft_wrap=True,
        )
        empty = _empty_scene(m)
        if empty is not None:
            warn(f"{r.log.name}: {empty}")


def _empty_scene(meta: dict[str, Any]) -> str | None:
    """Why a scene has no detection (None: it has some): nobody came during it (the office
    routine's hours), or people came and the robot saw none."""
    if meta.get("detections", 0):
        return None
    config = meta.get("config", {})
    scene = f"the scene runs {config.get('days', '?')} day(s) from {config.get('start', '?')}"
    if config.get("agents") == 0:
        return "nobody was detected: --agents 0 simulates no people (the robot and its graph only)"
    if not meta.get("true_samples", 0):
        rhythm = config.get("rhythm", {})
        arrive, leave = float(rhythm.get("arrive_h", 8.5)), float(rhythm.get("leave_h", 17.5))
        hours = (
            f"people keep office hours (arriving about {arrive:g} h, leaving about {leave:g} h "
            "local time, few at weekends)"
        )
        day, at = _start_of(str(config.get("start", "2026-01-05")))  # as the scene read it
        if day.weekday() >= 5:
            return (
                f"nobody was detected, and nobody came: {hours} and {scene}, a "
                f"{['Saturday', 'Sunday'][day.weekday() - 5]}; give a weekday --start "
                "or more --days"
            )
        if at is not None and arrive <= at < leave:  # in the hours: a scene too short to walk
            return (
                f"nobody was detected, and nobody walked: {hours}, most of them at their "
                f"desks, and {scene}; give more --days"
            )
        ask = "a --start within those hours" if at is not None else "--start with a time of day"
        example = min(math.ceil(arrive), 23)  # the first whole hour people are in
        return (
            f"nobody was detected, and nobody came: {hours} and {scene}; give {ask} "
            f"(e.g. {day.isoformat()}T{example:02d}:00) or more --days"
        )
    return (
        f"nobody was detected although people walked ({scene}): the robot saw none of them "
        "(see --robot, --patrol-hours, --tour-every and --sensor-range)"
    )


def _start_of(start: str) -> tuple[date, float | None]:
    """The local day of a scene's ``--start`` and its hour of the day (None: a date alone),
    read by :func:`aion_cli.sim.scenario.parse_start` as the scene was (any ISO form)."""
    from datetime import date

    from aion_cli.sim.scenario import parse_start

    day, seconds = parse_start(start)
    try:
        date.fromisoformat(start)
    except ValueError:
        return day, seconds / 3600.0
    return day, None


def _event_counts(r: SceneResult) -> str:
    import json

    meta = json.loads(r.truth_json.read_text())
    c = meta["event_counts"]
    from aion_cli.number_text import counted

    return (
        f"{counted(meta['loop_closures'], 'loop closure')} ({counted(c['move'], 'move')}, "
        f"{counted(c['merge'], 'merge')}, {counted(c['remove'], 'removal')})"
    )


@click.command(
    "simulate",
    cls=AionCommand,
    short_help="Synthetic logs of people, a robot and a scene graph.",
    epilog=EPILOG,
    advanced=(
        "nav_layer",
        "tz",
        "utc_offset",
        "rate",
        "noise",
        "sensor_range",
        "no_line_of_sight",
        "tour_every",
        "patrol_hours",
        "dsg_period",
        "dsg_idle_period",
        "tf_idle_period",
        "no_mesh",
        "window",
    ),
)
@click.option(
    "-o",
    "--output",
    required=True,
    type=AionPath(path_type=str),  # as typed: a trailing '/' names a folder (_output_path)
    help="Log to write (.mcap, .bag, rosbag2 folder); a folder with --scenes > 1.",
)
@click.option("--days", type=float, default=1.0, show_default=True, help="Simulated days.")
@click.option("--seed", type=int, default=0, show_default=True, help="Random seed.")
@click.option("--agents", type=int, default=6, show_default=True, help="People per scene.")
@click.option(
    "--scenes",
    type=int,
    default=1,
    show_default=True,
    help="Independent scenes, each its own log and ground truth.",
)
@click.option(
    "--environment",
    metavar="office|FILE",
    default="office",
    show_default=True,
    help="'office' (the paper's) or a spark_dsg scene graph file to walk in.",
)
@nav_layer_option
@click.option(
    "--robot",
    type=click.Choice(["patrol", "fixed"], case_sensitive=False),
    default="patrol",
    show_default=True,
    help="A patrolling robot, or a fixed sensor that sees all (it takes no patrol option).",
)
@click.option(
    "--frame",
    type=click.Choice(["base_link", "map"], case_sensitive=False),
    default=None,
    help="Frame of the detections [default: base_link; map for --robot fixed].",
)
@click.option(
    "--format",
    "--container",
    "fmt",
    default="mcap",
    show_default=True,
    type=click.Choice(
        ["mcap", "mcap-ros1", "bag", "rosbag2", "rosbag2-mcap", "rosbag2-sqlite3"],
        case_sensitive=False,  # as every --format
    ),
    # aion convert --container names the rosbag2 folder of MCAP storage rosbag2-mcap
    callback=lambda _ctx, _param, value: "rosbag2" if value == "rosbag2-mcap" else value,
    help="Log container (rosbag2, rosbag2-mcap: a rosbag2 folder of MCAP storage; "
    "--container as in aion convert).",
)
@click.option(
    "--detection-type",
    metavar="TYPE",
    default="tracked_persons",
    show_default=True,
    help="tracked_persons (spencer), pose_array, people (people_msgs).",
)
@click.option(
    "--start",
    metavar="DATE[THH:MM]",
    default="2026-01-05",
    show_default=True,
    help="Local date (and time) the scene starts; the default is a Monday midnight.",
)
@click.option(
    "--tz",
    metavar="ZONE",
    default=None,
    help="Local time zone of the scene: an IANA name (Europe/London: people keep their "
    "hours across daylight-saving changes), an offset (+09:00) or local (the machine's). "
    "Build with the same --tz "
    "[default: UTC, or --utc-offset].",
)
@click.option(
    "--utc-offset",
    type=float,
    default=0.0,
    show_default=True,
    help="Local time minus UTC, in hours (a fixed offset; --tz for a zone).",
)
@click.option(
    "--rate",
    type=float,
    default=2.0,
    show_default=True,
    help="Sensor rate in Hz (people are sampled at it).",
)
@click.option(
    "--noise",
    type=float,
    default=0.05,
    show_default=True,
    help="Detection position noise (std dev, m).",
)
@click.option("--sensor-range", type=float, default=8.0, show_default=True, help="Metres.")
@click.option("--no-line-of-sight", is_flag=True, help="Let the robot see through walls.")
@click.option(
    "--tour-every",
    type=float,
    default=30.0,
    show_default=True,
    help="Minutes between the starts of patrol tours.",
)
@click.option(
    "--patrol-hours",
    metavar="START-END",
    default="0-24",
    show_default=True,
    help="Local hours START-END in which tours start.",
)
@click.option(
    "--dsg-period",
    type=float,
    default=10.0,
    show_default=True,
    help="Seconds between scene graphs while the robot drives.",
)
@click.option(
    "--dsg-idle-period",
    type=float,
    default=600.0,
    show_default=True,
    help="Seconds between scene graphs while it is parked (or fixed).",
)
@click.option(
    "--tf-idle-period",
    type=float,
    default=10.0,
    show_default=True,
    help="Seconds between /tf (and empty detection) messages while nothing moves; a robot's "
    "at most 10 s (aion build takes a longer TF gap as a pose unknown).",
)
@click.option("--no-mesh", is_flag=True, help="Leave the mesh out of the scene graphs.")
@click.option(
    "--window",
    type=float,
    default=600.0,
    show_default=True,
    help="Ground-truth window length in seconds.",
)
@click.option("--force", is_flag=True, help="Overwrite existing outputs.")
@quiet_option
def simulate(
    output: str,
    days: float,
    seed: int,
    agents: int,
    scenes: int,
    environment: str,
    nav_layer: str | None,
    robot: str,
    frame: str | None,
    fmt: str,
    detection_type: str,
    start: str,
    tz: str | None,
    utc_offset: float,
    rate: float,
    noise: float,
    sensor_range: float,
    no_line_of_sight: bool,
    tour_every: float,
    patrol_hours: str,
    dsg_period: float,
    dsg_idle_period: float,
    tf_idle_period: float,
    no_mesh: bool,
    window: float,
    force: bool,
) -> None:
    """Simulate people in an office (or any scene graph) seen by a patrolling robot.

    Writes a log with Hydra scene graphs (hydra_msgs/DsgUpdate, growing as the robot explores,
    corrected at loop closures), people detections and TF, plus the ground truth beside it.
    """
    from aion_cli.cli.console import progress
    from aion_cli.sim.graphstream import StreamConfig
    from aion_cli.sim.robot import PatrolConfig
    from aion_cli.sim.scenario import ScenarioConfig
    from aion_cli.sim.scenario import simulate as run

    config = ScenarioConfig(
        environment=environment,
        nav_layer=nav_layer,
        days=days,
        seed=seed,
        agents=agents,
        scenes=scenes,
        robot=robot,
        frame=frame,
        format=fmt,
        detection_type=detection_type,
        start=start,
        utc_offset_h=utc_offset,
        timezone=None if tz is None else _zone_name(tz),
        rate_hz=rate,
        noise=noise,
        window_s=window,
        tf_idle_s=tf_idle_period,
        patrol=PatrolConfig(
            tour_every_s=tour_every * 60.0,
            hours=_hours(patrol_hours),
            sensor_range=sensor_range,
            line_of_sight=not no_line_of_sight,
        ),
        stream=StreamConfig(
            period_s=dsg_period, idle_period_s=dsg_idle_period, include_mesh=not no_mesh
        ),
    )
    with progress() as bar:
        task = bar.add_task("simulating", total=None)

        def report(stage: str, done: int, total: int) -> None:
            bar.update(task, description=stage, completed=done, total=total or None)

        results = run(config, _output_path(output, scenes, fmt), report, overwrite=force)
    _summary(results)
    _clock_change_note(start, config.timezone, config.utc_offset_h)


command = simulate

if __name__ == "__main__":  # samples/regenerate.sh runs this module directly
    import sys

    from aion_cli.cli.errors import report

    try:
        simulate(standalone_mode=False)
    except Exception as exc:
        sys.exit(report(exc, False))


def _output_path(text: str, scenes: int, fmt: str) -> Path:
    """``-o`` as a path. One scene in a log file (not a rosbag2 folder) named with a trailing
    ``/`` is refused: ``Path`` drops the separator, and ``-o runs/`` would quietly write
    ``runs.mcap`` beside the folder meant to hold it."""
    import os

    from aion_cli.errors import InputError

    if scenes == 1 and not fmt.startswith("rosbag2") and text.endswith(("/", os.sep)):
        raise InputError(
            f"-o {text!r} ends in '/', which names a folder, but one scene is one log file",
            hint=f"name the log (-o {text}office.mcap), or give --scenes N for a folder "
            "of scenes",
        )
    return Path(text)


def _zone_name(tz: str) -> str:
    """``--tz`` as the scene's zone name: ``local`` is the machine's zone by its name, as
    ``build --tz local`` stores it (the truth and the log then name a real zone). Read by
    the zone parser every command's --tz goes through, which refuses a bad zone alike."""
    from aion_cli.timeparse import resolve_zone

    zone = resolve_zone(tz)
    return zone.name if tz.strip().lower() == "local" else tz


def _clock_change_note(start: str, tz: str | None, utc_offset_h: float) -> None:
    """A note when ``--start`` is a wall-clock time of ``--tz`` that a clock change skips or
    repeats, saying which instant the scene started at (as ``predict --at`` does)."""
    if tz is None:  # a fixed offset has no clock change
        return
    from aion_cli.cli.console import note
    from aion_cli.sim.scenario import start_ns
    from aion_cli.timeparse import resolve_zone
    from aion_cli.wall_clock import clock_change_note

    changed = clock_change_note(start, resolve_zone(tz), start_ns(start, utc_offset_h, tz))
    if changed is not None:
        note(f"--start {changed}")
