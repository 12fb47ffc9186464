"""``aion report``: one self-contained HTML page about a map (:mod:`aion_cli.report`)."""

from __future__ import annotations

from pathlib import Path

import click

from aion_cli.cli.common import TIME_HELP, AionPath, map_argument, quiet_option, tz_option
from aion_cli.cli.output import AionCommand

EPILOG = """\b
Examples:
  aion report office.aion -o report/                  then open report/index.html
  aion report office.aion -o report/ --tz Europe/Berlin
  aion report office.aion -o report/ --time "2026-01-12 08:40"   busiest places at a time

\b
Writes into the -o folder: index.html (one page, inline CSS, no script, no external address:
send the folder to a colleague) and the PNG pictures it shows: map.png (the map from above, as
aion export --format png draws it), observed.png (when the map was observed),
activity_day_weekday.png, activity_day_weekend.png and activity_week.png (predicted flow
per room over a day every 15 minutes and over a week every hour: the first week after the
observations, or the week of --time), roses.png (direction roses of the busiest places).
The page holds what the map holds (counts, inputs, families, as aion info shows them) and
the busiest places as aion predict --top lists them (as observed, or at --time). Files
already in the folder that the report does not write are kept.
"""


@click.command(
    "report",
    short_help="Write an HTML page about a map (with pictures).",
    cls=AionCommand,
    epilog=EPILOG,
    advanced=("tz",),
)
@map_argument
@click.option(
    "-o",
    "--output",
    "out_dir",
    required=True,
    type=AionPath(path_type=Path),
    help="Folder to write into (made if missing, in an existing folder).",
)
@click.option(
    "-t",
    "--time",
    "time_text",
    metavar="T",
    help="Rank the busiest places by the prediction at T [default: as observed]. " + TIME_HELP,
)
@tz_option
@quiet_option
def command(
    map_path: Path, out_dir: Path, time_text: str | None, tz: str | None
) -> None:
    """Write a report of MAP into a folder: an HTML page and the pictures it shows."""
    from aion_cli.cli.common import announce_time, load, resolve_time
    from aion_cli.cli.console import console, progress
    from aion_cli.cli.output import markup_safe
    from aion_cli.exports import check_out_dir
    from aion_cli.manifest import Manifest
    from aion_cli.report.writer import PAGE, STEPS, write_report
    from aion_cli.timeparse import resolve_zone

    check_out_dir(out_dir)  # a bad -o fails before the map is read
    loaded = load(map_path)
    t_ns = None
    if time_text is not None:
        t_ns, zone = resolve_time(time_text, tz, loaded)
    else:
        zone = resolve_zone(tz if tz is not None else Manifest.from_dict(loaded.manifest).timezone)
    with progress() as bar:
        task = bar.add_task("report", total=STEPS, unit="steps")

        def advance(what: str) -> None:
            bar.update(task, advance=1, description=markup_safe(what))

        written = write_report(loaded, map_path, out_dir, zone, t_ns, advance)
    if t_ns is not None:
        announce_time(t_ns, zone, loaded=loaded, text=time_text)
    console().print(
        f"wrote {len(written)} file(s) to {markup_safe(out_dir)}: open "
        f"{markup_safe(out_dir / PAGE)}",
        soft_wrap=True,
    )
