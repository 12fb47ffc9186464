"""The closing table of ``aion build`` (on stderr: it is for people, not for scripts)."""

from __future__ import annotations

from typing import Any

from aion_cli.cli.console import console, print_table, warn_each
from aion_cli.cli.output import human_size, markup_safe
from aion_cli.number_text import WINDOWS_OBSERVED, counted, span_text

__all__ = ["clock_of", "print_summary", "print_warnings", "span_text"]


def print_summary(summary: dict[str, Any], zone: str = "UTC") -> None:
    """Render the build report dict (``BuildReport.to_dict``) as a two-column table, then its
    warnings and notes, their times on ``zone``'s clock (the map's: they are written in UTC).
    Every string that can come from a log or a path (map name, layer, observation, notes
    naming topics and frames) is shown as plain text: control characters made visible, rich
    markup not applied (:func:`aion_cli.cli.output.markup_safe`)."""
    from rich.table import Table

    det = summary["detections"]
    table = Table(
        title=f"map {markup_safe(summary['map'])}", show_header=False, title_justify="left"
    )
    table.add_column("what", style="bold", no_wrap=True)
    table.add_column("value", justify="right")
    new = " (new logs)" if summary.get("continued") else ""  # the rows below: the whole map
    table.add_row(f"detections read{new}", f"{det['read']:,}")
    table.add_row(f"detections used{new}", f"{det['used']:,}")
    for reason, count in det["dropped"].items():
        if count:
            table.add_row(f"  dropped: {markup_safe(reason)}", f"{count:,}")
    if new:  # as aion info MAP gives them
        total = summary["map_detections"]
        table.add_row("detections used in the map", f"{total['used']:,} of {total['read']:,}")
    headings = summary.get("headings") or {}
    if any(headings.values()):
        table.add_row("headings", heading_text(headings))
    graph = summary["graph"]
    layer = f", layer {graph['layer']}" if graph.get("layer") else ""
    table.add_row("graph", markup_safe(f"{graph['source']}{layer}"))
    add_map_rows(table, summary)
    table.add_row("time span", span_text(summary["time_span"]["seconds"]))
    table.add_row("observation", markup_safe(summary["observation"]))
    table.add_row("map size", human_size(summary["map_bytes"]))
    workers: dict[str, list[float]] = {}
    for shard in summary.get("workers", []):  # a parallel build: totals per worker
        total = workers.setdefault(str(shard["worker"]), [0, 0.0, 0.0, 0])
        total[0] += 1
        total[1] += float(shard["seconds"])
        total[2] = max(total[2], float(shard["peak_rss_mb"]))
        total[3] += int(shard["detections_used"])
    for k, (name, (shards, seconds, peak, used)) in enumerate(sorted(workers.items())):
        table.add_row(
            f"worker {k + 1}" if len(workers) > 1 else "worker",
            f"{counted(int(shards), 'shard')}, {int(used):,} det, "
            f"{seconds:.1f} s, {peak:.0f} MB  "
            f"[dim]({markup_safe(name)})[/dim]",
        )
    print_table(table, err=True)
    print_warnings(summary, zone)
    shown = clock_of(zone)
    for message in summary.get("notes", []):
        console().print(
            f"[yellow]note:[/yellow] {markup_safe(shown(message))}", soft_wrap=True
        )


def add_map_rows(table: Any, summary: dict[str, Any]) -> None:
    """The map's size rows of a closing table (``aion build``'s and ``aion merge``'s): nodes
    (with flow), hash cells, bound cells, windows observed and, when known, hours observed."""
    table.add_row("nodes", f"{summary['nodes']:,} ({summary['nodes_with_flow']:,} with flow)")
    table.add_row("hash cells", f"{summary['cells']:,}")
    table.add_row("bound cells", f"{summary['bound_cells']:,}")
    table.add_row(WINDOWS_OBSERVED, f"{summary['windows']:,}")
    if summary.get("hours_observed"):
        table.add_row("hours observed", markup_safe(summary["hours_observed"]))


def print_warnings(summary: dict[str, Any], zone: str = "UTC") -> None:
    """The report's warnings on stderr, one line each (also with ``-q`` and ``--format
    json``: a build that lost data must say so however it is run), their times on ``zone``'s
    clock, as ``aion info`` shows a log's (the JSON keeps them in UTC)."""
    shown = clock_of(zone)
    warn_each([shown(str(w)) for w in summary.get("warnings", [])])


def clock_of(zone: str) -> Any:
    """A message's UTC times on ``zone``'s clock (:func:`aion_cli.engine.time_text.on_clock`);
    unchanged in a zone that cannot be read (a damaged manifest's)."""
    from aion_cli.engine.time_text import on_clock
    from aion_cli.errors import AionError
    from aion_cli.timeparse import resolve_zone

    try:
        resolved = resolve_zone(zone)
    except AionError:
        return str
    return lambda text: on_clock(text, resolved)


def heading_text(headings: dict[str, int]) -> str:
    """Detections per heading source, in the report's order: ``velocity 0, track 0, linked
    290, pose yaw 0, none 34``."""
    return ", ".join(f"{name.replace('_', ' ')} {int(n):,}" for name, n in headings.items())
