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
Those sums hold the days of history closed for scoring (a build keeps the last day open), so
the copy's saving grows with them: about nothing for a map of one day or a single hour, 1.4-1.7x
for 3 to 5 days, about 4x for two weeks (the ratio --format json gives).
Keep the full map to add logs to; deploy the query-only one. Part maps (aion build --part) and
maps written before the FreMEn components were stored are refused. An existing map at -o is
replaced atomically, with a note saying so (as build and merge do); anything else there is
refused.

\b
JSON keys (--format json): map, source, source_bytes, map_bytes, ratio, entries,
places_without_data (places of the graph that hold no entry; predict lists them with family
"none"), bytes_per_entry, left_out, notes.
"""


#: a ratio below this is said as "about the same size", not "1.0x smaller"
SMALLER = 1.05


@click.command(
    "compact",
    short_help="Write a query-only copy of a map (smaller the more days it holds).",
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
    shrank = bool(ratio) and ratio >= SMALLER
    table.add_row(
        "query-only size",
        human_size(summary["map_bytes"])
        + (f" ({ratio:.1f}x smaller)" if shrank else " (about the same size)" if ratio else ""),
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
    if ratio and not shrank:
        saved = max(0, summary["source_bytes"] - summary["map_bytes"])
        out.print(
            f"[yellow]note:[/yellow] the copy is about the full map's size: the Fourier sums it "
            f"leaves out held {human_size(saved)}. They hold the days of history closed for "
            "scoring (a build keeps the last day open), so a map of a day or less shrinks "
            "by almost nothing, one of a few days by 1.4-1.7x, and one of weeks several times",
            soft_wrap=True,
        )
    for message in summary["notes"]:
        out.print(f"[yellow]note:[/yellow] {markup_safe(message)}", soft_wrap=True)
