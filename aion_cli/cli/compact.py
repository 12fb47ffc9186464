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
places_without_data (places of the graph that hold no entry; predict lists them with family
"none"), bytes_per_entry, left_out, notes.
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
    """The closing table (on stderr, as ``build`` and ``merge`` close theirs): the copy, the
    full map it was made from, both sizes, the entries it answers for and what it leaves
    out; then the notes. Names from paths are shown as plain text."""
    from rich.table import Table

    from aion_cli.cli.console import console, print_table
    from aion_cli.cli.output import human_size, markup_safe
    from aion_cli.mapquery import entries_text

    table = Table(
        title=f"query-only map {markup_safe(summary['map'])}",
        show_header=False,
        title_justify="left",
    )
    table.add_column("what", style="bold", no_wrap=True)
    table.add_column("value", justify="right")
    table.add_row("made from", markup_safe(summary["source"]))
    table.add_row("full map size", human_size(summary["source_bytes"]))
    ratio = summary["ratio"]
    table.add_row(
        "query-only size",
        human_size(summary["map_bytes"]) + (f" ({ratio:.1f}x smaller)" if ratio else ""),
    )
    per = summary["bytes_per_entry"]
    table.add_row("entries", entries_text(summary["entries"], summary["places_without_data"]))
    if per:
        table.add_row("size per entry", human_size(int(per)))
    left_out = summary["left_out"]
    table.add_row(
        "left out (for learning)",
        ", ".join(map(markup_safe, left_out)) if left_out else "nothing",
    )
    print_table(table, err=True)
    out = console()
    out.print(
        "[dim]it answers every query as the full map does, and cannot be continued "
        "(build --map) or merged: keep the full map to add logs to[/dim]",
        soft_wrap=True,
    )
    for message in summary["notes"]:
        out.print(f"[yellow]note:[/yellow] {markup_safe(message)}", soft_wrap=True)
