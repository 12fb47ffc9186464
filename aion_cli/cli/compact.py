"""``aion compact``: a query-only copy of a map (``aion_cli.query_only``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.common import AionPath, quiet_option
from aion_cli.cli.output import AionCommand, format_option, map_output_option, to_json

EPILOG = """\b
Examples:
  aion compact office.aion -o office-robot.aion
  aion compact office.aion -o office-robot.aion --format json

\b
The copy answers predict, plan, export, report and the Python API exactly as the map does (the
same numbers, to the bit), but leaves out the per-entry Fourier sums that only learning uses:
it cannot be continued with aion build --map or merged (both refuse it and name the full map).
Keep the full map to add logs to; deploy the query-only one. Part maps (aion build --part) and
maps written before the FreMEn components were stored are refused. An existing map at -o is
replaced atomically, with a note saying so (as build and merge do); anything else there is
refused.

\b
JSON keys (--format json): map, source, source_bytes, map_bytes, ratio, entries,
bytes_per_entry, left_out, notes.
"""


@click.command(
    "compact",
    short_help="Write a smaller, query-only copy of a map.",
    cls=AionCommand,
    epilog=EPILOG,
)
@click.argument("map_path", metavar="MAP", type=AionPath(path_type=Path))
@map_output_option("Query-only map file")
@quiet_option
@format_option(choices=("table", "json"))
def command(map_path: Path, output: Path, fmt: str) -> None:
    """Write a copy of MAP for queries only: the same answers, without what learning needs."""
    from aion_cli.query_only import compact_map

    summary = compact_map(map_path, output).to_dict()
    if fmt == "json":
        click.echo(to_json(summary))
    else:
        _print(summary)


def _print(summary: dict[str, Any]) -> None:
    from aion_cli.cli.console import console
    from aion_cli.cli.output import human_size, markup_safe

    ratio = summary["ratio"]
    console().print(
        f"wrote {markup_safe(summary['map'])}: {human_size(summary['map_bytes'])} "
        f"({human_size(summary['source_bytes'])} for the full map"
        + (f", {ratio:.1f}x smaller" if ratio else "")
        + "); it answers queries, and cannot be continued or merged",
        soft_wrap=True,
    )
    for message in summary["notes"]:
        console().print(f"[yellow]note:[/yellow] {markup_safe(message)}", soft_wrap=True)
