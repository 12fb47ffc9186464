"""The closing table of ``aion build`` (on stderr: it is for people, not for scripts)."""

from __future__ import annotations

from typing import Any

from aion_cli.cli.console import console
from aion_cli.cli.output import human_size


def span_text(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    whole = round(seconds)
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}h{minutes:02d}m{secs:02d}s" if hours else f"{minutes}m{secs:02d}s"


def print_summary(summary: dict[str, Any]) -> None:
    """Render the build report dict (``BuildReport.to_dict``) as a two-column table."""
    from rich.markup import escape
    from rich.table import Table

    det = summary["detections"]
    table = Table(title=f"map {summary['map']}", show_header=False, title_justify="left")
    table.add_column("what", style="bold")
    table.add_column("value", justify="right")
    table.add_row("detections read", f"{det['read']:,}")
    table.add_row("detections used", f"{det['used']:,}")
    for reason, count in det["dropped"].items():
        if count:
            table.add_row(f"  dropped: {reason}", f"{count:,}")
    headings = summary.get("headings") or {}
    if any(headings.values()):
        table.add_row("headings", heading_text(headings))
    graph = summary["graph"]
    layer = f", layer {graph['layer']}" if graph.get("layer") else ""
    table.add_row("graph", f"{graph['source']}{layer}")
    table.add_row("nodes", f"{summary['nodes']:,} ({summary['nodes_with_flow']:,} with flow)")
    table.add_row("hash cells", f"{summary['cells']:,}")
    table.add_row("bound cells", f"{summary['bound_cells']:,}")
    table.add_row("windows observed", f"{summary['windows']:,}")
    table.add_row("time span", span_text(summary["time_span"]["seconds"]))
    table.add_row("observation", summary["observation"])
    table.add_row("map size", human_size(summary["map_bytes"]))
    out = console()
    out.print(table)
    for warning in summary.get("warnings", []):
        out.print(f"[yellow]warning:[/yellow] {escape(warning)}", soft_wrap=True)
    for note in summary.get("notes", []):
        out.print(f"[yellow]note:[/yellow] {note}", soft_wrap=True)


def heading_text(headings: dict[str, int]) -> str:
    """Detections per heading source, in the report's order: ``velocity 0, track 0, linked
    290, pose yaw 0, none 34``."""
    return ", ".join(f"{name.replace('_', ' ')} {int(n):,}" for name, n in headings.items())
