"""``aion convert``: public pedestrian-track datasets (CSV) -> robot logs aion can build from."""

from __future__ import annotations

from pathlib import Path

import click

from aion_cli.cli.output import AionCommand

EPILOG = """\b
Examples:
  aion convert atc-20121024.csv --layout atc -o atc.mcap
  aion convert thor_run1.csv --layout thor -o thor.mcap --graph dsg.json
  aion convert tracks.csv -o tracks.mcap            canonical columns (the default)
  aion build atc.mcap --derive-graph                then learn a map from it

\b
Layouts: canonical (t_ns, track_id, x, y, z, heading_rad, speed_mps), atc (ATC shopping
centre), thor (THÖR), eth (ETH/UCY obsmat). The tracks become people-detection messages; a
dataset has no robot, so the build treats it as a fixed sensor over its time span.
"""


CONTAINERS = ("mcap", "mcap-ros1", "bag", "rosbag2-sqlite3", "rosbag2-mcap")


def _container_for(output: Path, container: str | None) -> str:
    """``--container``, else from the suffix: .bag -> ROS 1 bag, .mcap -> ROS 2 MCAP,
    no suffix -> a rosbag2 folder (sqlite3)."""
    if container is not None:
        return container
    suffix = output.suffix.lower()
    if suffix == ".bag":
        return "bag"
    if suffix == ".mcap":
        return "mcap"
    if suffix == "":
        return "rosbag2-sqlite3"
    from aion_cli.engine.errors import InputError

    raise InputError(
        f"cannot tell the log format from {output.name!r}",
        hint="name it .mcap or .bag, or give --container",
    )


@click.command(
    "convert",
    short_help="Turn pedestrian-track CSVs into logs.",
    cls=AionCommand,
    epilog=EPILOG,
    advanced=("container", "msgtype", "start_text"),
)
@click.argument("tracks", type=click.Path(path_type=Path))
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(path_type=Path),
    help="Log to write: .mcap, .bag, or a rosbag2 folder (no suffix).",
)
@click.option(
    "--layout",
    type=click.Choice(["canonical", "atc", "thor", "eth"]),
    default="canonical",
    show_default=True,
    help="Column layout of the CSV.",
)
@click.option(
    "--graph",
    "graph_file",
    type=click.Path(path_type=Path, dir_okay=False),
    help="Scene graph (dsg.json, .sparkdsg) to publish in the log as well.",
)
@click.option(
    "--container",
    type=click.Choice(CONTAINERS),
    help="Log container [default: from the output's suffix].",
)
@click.option(
    "--message-type",
    "msgtype",
    type=click.Choice(["spencer_tracking_msgs/msg/TrackedPersons", "geometry_msgs/msg/PoseArray"]),
    default="spencer_tracking_msgs/msg/TrackedPersons",
    show_default=True,
    help="Message type the detections are written as.",
)
@click.option(
    "--start",
    "start_text",
    metavar="T",
    help="Shift dataset times (ATC/THÖR/ETH seconds) to start at this time.",
)
@click.option("--force", is_flag=True, help="Overwrite the output if it exists.")
def command(
    tracks: Path,
    output: Path,
    layout: str,
    graph_file: Path | None,
    container: str | None,
    msgtype: str,
    start_text: str | None,
    force: bool,
) -> None:
    """Convert the pedestrian tracks in TRACKS (CSV) into a log with people detections."""
    from aion_cli.cli.console import console
    from aion_cli.engine.errors import InputError
    from formats.tracks import read_tracks, tracks_to_log

    if not tracks.is_file():
        raise InputError(f"tracks file not found: {tracks}", hint="check the path")
    kind = _container_for(output, container)
    if output.exists() and not force:
        raise InputError(f"{output} exists already", hint="choose another -o or add --force")
    start_ns = 0
    if start_text is not None:
        from aion_cli.cli.common import resolve_time

        start_ns, _ = resolve_time(start_text, None)
    batch = read_tracks(tracks, layout, start_ns=start_ns)
    if len(batch) == 0:
        raise InputError(f"no tracks in {tracks}", hint=f"is it really the {layout!r} layout?")
    summary = tracks_to_log(
        batch, output, graph_file=graph_file, container=kind, msgtype=msgtype, overwrite=force
    )
    n_tracks = len(set(batch.track_id.tolist()))
    span = (summary.end_ns - summary.start_ns) / 1e9
    console().print(
        f"wrote {summary.path}: {summary.detections:,} detections of {n_tracks:,} tracks in "
        f"{summary.detection_messages:,} messages over {span:,.0f} s"
        + (f", {summary.graph_messages} scene-graph messages" if summary.graph_messages else ""),
        soft_wrap=True,
    )
