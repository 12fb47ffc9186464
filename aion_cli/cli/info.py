"""``aion info``: what is in a log, and what aion will use from it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aion_cli.cli.output import format_option, human_size, to_json

EPILOG = """\b
Examples:
  aion info run.mcap
  aion info run1.mcap run2.bag rosbag2_folder/      several logs, seen as one
  aion info office.aion                              a map: inputs, time span, counts, config
  aion info run.mcap --format json | jq '.topics[] | select(.role == "detections")'

\b
Roles: scene_graph (hydra_msgs/DsgUpdate, used by build), detections (a supported people
type, used by build), tf / tf_static (frames and the robot trajectory), unsupported (ignored).
JSON keys: formats, format, files[{path, format, size_bytes, messages, start_ns, end_ns}],
size_bytes, start_ns, end_ns, start, end, duration_s, messages, topics[{topic, type, count,
role, encoding, rate_hz, used}], roles, dsg_versions, will_use{detections, scene_graph, tf},
cannot_read, warnings. For a map (.aion): format, version, creator, created, inputs,
time_span, counts (all builds), last_build, graph_source, observation, families (how many
entries each temporal model family forecasts, flow and direction), timezone, config.
"""

MAP_SUFFIX = ".aion"


def describe_map(path: Path) -> dict[str, Any]:
    """The manifest of a map file (cheap: no array is read), without the internal tables."""
    from formats.mapfile import read_manifest

    manifest = read_manifest(path)
    return {"map": str(path)} | {k: v for k, v in manifest.items() if k not in ("members", "state")}


def describe(paths: list[Path], log_format: str | None) -> dict[str, Any]:
    """The info report of ``paths`` as a plain dict (also the JSON document):
    ``formats.summary`` plus what ``aion build`` will use and the scene-graph payload version."""
    from aion_cli.topics import select_topics
    from formats.logs import open_logs
    from formats.summary import summarize

    with open_logs(paths, log_format) as logset:
        summary = summarize(logset)
        plan = select_topics(logset.topics)
        for info in plan.graph:
            summary.dsg_versions[info.topic] = _dsg_versions(logset, info.topic)
        report = summary.to_dict()
    used = plan.names("detections") | plan.names("graph") | plan.names("tf")
    for topic in report["topics"]:
        topic["used"] = topic["topic"] in used
    report["format"] = ", ".join(report["formats"]) or None
    report["will_use"] = {
        "detections": sorted(plan.names("detections")),
        "scene_graph": sorted(plan.names("graph")),
        "tf": sorted(plan.names("tf")),
    }
    report["cannot_read"] = [f"{t.topic} ({t.msgtype})" for t in plan.ignored]
    return report


def _dsg_versions(logset: Any, topic: str) -> list[str]:
    """spark_dsg payload version of the topic's first scene graph (decoding one message)."""
    import numpy as np

    from aion_cli.engine.errors import InputError
    from formats.dsg import decode_dsg

    first = next(iter(logset.messages({topic})), None)
    if first is None:
        return []
    try:
        payload = np.asarray(logset.decode(first).layer_contents, dtype=np.uint8)
        return [decode_dsg(payload, first.log_time_ns).version]
    except InputError as exc:
        return [f"unreadable: {exc.message}"]


@click.command("info", short_help="What is in logs (or a map), what aion uses.", epilog=EPILOG)
@click.argument("logs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option(
    "--log-format",
    type=click.Choice(["mcap", "bag", "rosbag2"]),
    help="Container format [default: guessed from the path].",
)
@format_option(choices=("table", "json"))
def command(logs: tuple[Path, ...], log_format: str | None, fmt: str) -> None:
    """Show the format, duration and topics of LOGS and what aion will use from them.

    Given a map (.aion) instead, show what it was built from and with.
    """
    from aion_cli.engine.errors import InputError

    for path in logs:
        if not path.exists():
            raise InputError(f"not found: {path}", hint="check the path")
    maps = [p for p in logs if p.suffix == MAP_SUFFIX and p.is_file()]
    if maps and len(maps) != len(logs):
        raise InputError("give either logs or maps, not both")
    if maps:
        reports = [describe_map(p) for p in maps]
        if fmt == "json":
            click.echo(to_json(reports[0] if len(reports) == 1 else reports))
        else:
            for report in reports:
                _print_map(report)
        return
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
        f"size: {human_size(report['size_bytes'])}  "
        f"duration: {report['duration_s']:,.1f} s ({report['start']} .. {report['end']})  "
        f"messages: {report['messages']:,}",
        soft_wrap=True,
    )
    table = Table(show_lines=False, header_style="bold")
    for name, justify in (
        ("topic", "left"),
        ("type", "left"),
        ("count", "right"),
        ("Hz", "right"),
        ("aion uses it as", "left"),
    ):
        table.add_column(name, justify=justify)  # type: ignore[arg-type]
    for t in report["topics"]:
        role = t["role"] if t["used"] else "[dim]- (not a type aion reads)[/dim]"
        if t["topic"] in report["dsg_versions"]:
            role += f" (spark_dsg {', '.join(report['dsg_versions'][t['topic']])})"
        rate = "-" if t["rate_hz"] is None else f"{t['rate_hz']:.2f}"
        table.add_row(t["topic"], t["type"], f"{t['count']:,}", rate, role)
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


def _print_map(report: dict[str, Any]) -> None:
    from rich.table import Table

    from aion_cli.cli.build_summary import span_text
    from aion_cli.cli.console import data_console
    from aion_cli.engine.config import ModelConfig

    span = report.get("time_span", {})
    start, end = span.get("start_ns"), span.get("end_ns")
    seconds = None if start is None or end is None else (end - start) / 1e9
    counts = report.get("counts", {})
    table = Table(title=f"map {report['map']}", show_header=False, title_justify="left")
    table.add_column("what", style="bold")
    table.add_column("value")
    table.add_row("format", f"{report.get('format')} {report.get('version')}")
    table.add_row("created", f"{report.get('created')} by {report.get('creator')}")
    table.add_row("time span", span_text(seconds))
    table.add_row("detections used", f"{counts.get('used', 0):,} of {counts.get('read', 0):,}")
    table.add_row("nodes / cells", f"{counts.get('nodes', 0):,} / {counts.get('cells', 0):,}")
    table.add_row("graph", str(report.get("graph_source")))
    table.add_row("observation", str(report.get("observation")))
    families = report.get("families") or {}
    for kind in ("flow", "direction"):
        tally = families.get(kind) or {}
        if tally:
            text = ", ".join(f"{name} {count:,}" for name, count in sorted(tally.items()))
            table.add_row(f"{kind} models", text)
    if families:
        table.add_row(
            "reconciled", "yes: totals follow the map's own forecast" if families.get("reconciled")
            else "no"
        )
    defaults = ModelConfig().to_dict()
    changed = {k: v for k, v in report.get("config", {}).items() if defaults.get(k) != v}
    table.add_row("config", ", ".join(f"{k}={v}" for k, v in changed.items()) or "defaults")
    for entry in report.get("inputs", []):
        table.add_row(
            "input", f"{entry['name']}  {human_size(entry['size'])}  sha256 {entry['sha256'][:12]}"
        )
    data_console().print(table)
