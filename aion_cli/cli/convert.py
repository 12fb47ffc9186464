"""``aion convert``: public pedestrian-track datasets (CSV) -> robot logs aion can build from."""

from __future__ import annotations

from pathlib import Path

import click

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


@click.command("convert", epilog=EPILOG)
@click.argument("tracks", type=click.Path(path_type=Path, dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(path_type=Path),
              help="Log to write (.mcap, .bag, or a rosbag2 folder).")
@click.option("--layout", type=click.Choice(["canonical", "atc", "thor", "eth"]),
              default="canonical", show_default=True, help="Column layout of the CSV.")
@click.option("--graph", "graph_file", type=click.Path(path_type=Path, dir_okay=False),
              help="Scene graph (dsg.json, .sparkdsg) to publish in the log as well.")
@click.option("--force", is_flag=True, help="Overwrite the output if it exists.")
def command(
    tracks: Path, output: Path, layout: str, graph_file: Path | None, force: bool
) -> None:
    """Convert the pedestrian tracks in TRACKS (CSV) into a log with people detections."""
    from aion_cli.cli.console import console
    from aion_cli.engine.errors import InputError
    from formats.tracks import read_tracks, tracks_to_log

    if not tracks.is_file():
        raise InputError(f"tracks file not found: {tracks}", hint="check the path")
    if output.exists() and not force:
        raise InputError(f"{output} exists already", hint="choose another -o or add --force")
    batch = read_tracks(tracks, layout)
    if len(batch) == 0:
        raise InputError(f"no tracks in {tracks}", hint=f"is it really the {layout!r} layout?")
    tracks_to_log(batch, output, graph_file=graph_file, overwrite=force)
    n_tracks = len({int(t) for t in batch.track_id.tolist()})
    span = (int(batch.t_ns.max()) - int(batch.t_ns.min())) / 1e9
    console().print(
        f"wrote {output}: {len(batch):,} detections of {n_tracks:,} tracks over {span:,.0f} s",
        soft_wrap=True,
    )
