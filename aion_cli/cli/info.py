"""``aion info``: what is in a log, and what aion will use from it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.output import format_option, to_json

EPILOG = """\b
Examples:
  aion info run.mcap
  aion info run1.mcap run2.bag rosbag2_folder/      several logs, seen as one
  aion info run.mcap --format json | jq '.topics[] | select(.role == "detections")'

\b
Roles: scene_graph (hydra_msgs/DsgUpdate, used by build), detections (a supported people
type, used by build), tf / tf_static (frames and the robot trajectory), unsupported (ignored).
JSON keys: files, format, start_ns, end_ns, duration_s, messages, topics[{topic, type, count,
role, encoding, used}], will_use{detections, scene_graph, tf}, cannot_read, warnings.
"""


def describe(paths: list[Path], log_format: str | None) -> dict[str, Any]:
    """The info report of ``paths`` as a plain dict (also the JSON document)."""
    from aion_cli.pipeline import select_topics
    from formats.logs import open_logs

    with open_logs(paths, log_format) as logset:
        plan = select_topics(logset.topics)
        roles = {t.topic: "detections" for t in plan.detections}
        roles.update({t.topic: "scene_graph" for t in plan.graph})
        for t in plan.tf:
            roles[t.topic] = "tf_static" if t.topic.endswith("_static") else "tf"
        topics = [
            {
                "topic": t.topic,
                "type": t.msgtype,
                "count": int(t.count),
                "encoding": t.encoding,
                "role": roles.get(t.topic, "unsupported"),
                "used": t.topic in roles,
            }
            for t in logset.topics
        ]
        files = [
            {"path": str(f.path), "format": getattr(f, "format", None)}
            for f in getattr(logset, "files", [])
        ]
        formats = sorted({str(f["format"]) for f in files if f["format"]})
        start, end = int(logset.start_ns), int(logset.end_ns)
        return {
            "files": files,
            "format": ", ".join(formats) if formats else None,
            "start_ns": start,
            "end_ns": end,
            "duration_s": max(end - start, 0) / 1e9,
            "messages": sum(t["count"] for t in topics),
            "topics": topics,
            "will_use": {
                "detections": sorted(plan.names("detections")),
                "scene_graph": sorted(plan.names("graph")),
                "tf": sorted(plan.names("tf")),
            },
            "cannot_read": [f"{t.topic} ({t.msgtype})" for t in plan.ignored],
            "warnings": list(logset.warnings),
        }


@click.command("info", epilog=EPILOG)
@click.argument("logs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option(
    "--log-format",
    type=click.Choice(["mcap", "bag", "rosbag2"]),
    help="Container format [default: guessed from the path].",
)
@format_option(choices=("table", "json"))
def command(logs: tuple[Path, ...], log_format: str | None, fmt: str) -> None:
    """Show the format, duration and topics of LOGS and what aion will use from them."""
    from aion_cli.engine.errors import InputError

    for path in logs:
        if not path.exists():
            raise InputError(f"log not found: {path}", hint="check the path")
    report = describe(list(logs), log_format)
    if fmt == "json":
        click.echo(to_json(report))
    else:
        _print(report)


def _print(report: dict[str, Any]) -> None:
    from rich.table import Table

    from aion_cli.cli.console import console, data_console

    out = data_console()
    names = ", ".join(Path(f["path"]).name for f in report["files"])
    out.print(
        f"[bold]{names}[/bold]  format: {report['format'] or '?'}  "
        f"duration: {report['duration_s']:.1f} s  messages: {report['messages']:,}"
    )
    table = Table(show_lines=False, header_style="bold")
    for name, justify in (
        ("topic", "left"),
        ("type", "left"),
        ("count", "right"),
        ("aion uses it as", "left"),
    ):
        table.add_column(name, justify=justify)  # type: ignore[arg-type]
    for t in report["topics"]:
        role = t["role"] if t["used"] else "[dim]- (not a type aion reads)[/dim]"
        table.add_row(t["topic"], t["type"], f"{t['count']:,}", role)
    out.print(table)
    use = report["will_use"]
    if not use["detections"]:
        console().print(
            "[yellow]note:[/yellow] no people-detection topic of a supported type: "
            "`aion build` cannot learn flows from this log"
        )
    if not use["scene_graph"]:
        console().print(
            "[yellow]note:[/yellow] no scene graph: build with --graph FILE or --derive-graph"
        )
    for warning in report["warnings"]:
        console().print(f"[yellow]warning:[/yellow] {warning}", soft_wrap=True)
