"""``aion info GRAPH_FILE``: what is in a saved scene graph, and what aion takes from it.

The file is read by the loader every command uses (:func:`formats.dsg.load_graph`), so the layer
and counts shown are the ones ``aion build --graph`` and ``aion simulate --environment`` get.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aion_cli.cli.output import human_size

#: Suffixes of spark_dsg graph files (``aion info`` tells them from logs and maps by these).
GRAPH_SUFFIXES = (".json", ".sparkdsg", ".bson")


def is_graph_file(path: Path) -> bool:
    """A spark_dsg graph file by its name (a rosbag2 folder is never one)."""
    return path.suffix.lower() in GRAPH_SUFFIXES and path.is_file()


def describe_graph(path: Path, nav_layer: str | None = None) -> dict[str, Any]:
    """The info report of one graph file as a plain dict (also the JSON document)."""
    from aion_cli.formats.dsg import graph_layers, load_graph

    loaded = load_graph(path, 0, nav_layer)
    snap, nav, file = loaded.snapshot, loaded.nav, loaded.file
    mesh = snap.mesh
    return {
        "graph": str(path),
        "size_bytes": path.stat().st_size,
        "format": file.format,
        "version": file.version,
        "reader": file.reader,
        "nav_layer": {"name": nav.layer.name or None, "key": nav.layer.key},
        "places": len(snap.places),
        "edges": len(snap.edges),
        "frontiers_left_out": nav.frontiers,
        "places_with_room": int((snap.places.parent != 0).sum()),
        "rooms": len(snap.rooms),
        "buildings": len(snap.buildings),
        "agent_poses": 0 if snap.agents is None else len(snap.agents),
        "mesh": None
        if mesh is None
        else {"vertices": len(mesh.vertices), "faces": len(mesh.faces)},
        "layers": [
            {"key": key, "name": name or None, "nodes": n}
            for key, name, n in graph_layers(file.graph)
        ],
        "skipped": dict(file.skipped),
        "notes": loaded.notes(),
        "aion": _aion_dynamics(file.graph),
    }


def _aion_dynamics(graph: Any) -> dict[str, Any] | None:
    """What ``aion export --format dsg`` recorded in the graph's metadata (the map, the time,
    whether predicted or observed), or None for a graph that carries no aion dynamics."""
    try:
        record = graph.metadata.get().get("aion")
    except Exception:  # no metadata interface, or metadata spark_dsg cannot give back
        return None
    return record if isinstance(record, dict) else None


def print_graph(report: dict[str, Any]) -> None:
    """The report as a two-column table (stdout) and its notes (stderr). Every string from
    the file or its path (layer names, format, the dynamics' map, spark_dsg's messages) is
    plain text: control characters made visible, rich markup shown, not applied."""
    from rich.table import Table

    from aion_cli.cli.console import console, print_table
    from aion_cli.cli.output import markup_safe as safe

    nav = report["nav_layer"]
    layer = safe(f"{nav['name']} ({nav['key']})" if nav["name"] else nav["key"])
    table = Table(
        title=f"scene graph {safe(report['graph'])}", show_header=False, title_justify="left"
    )
    table.add_column("what", style="bold", no_wrap=True)
    table.add_column("value")
    reader = "; read leniently" if report["reader"] == "lenient" else ""
    table.add_row(
        "format", f"{safe(report['format'])}{reader}, {human_size(report['size_bytes'])}"
    )
    table.add_row("navigational layer", layer)
    frontiers = report["frontiers_left_out"]
    table.add_row(
        "places",
        f"{report['places']:,}" + (f" ({frontiers:,} frontiers left out)" if frontiers else ""),
    )
    table.add_row("place edges", f"{report['edges']:,}")
    table.add_row("rooms", f"{report['rooms']:,} ({report['places_with_room']:,} places in a room)")
    table.add_row("buildings", f"{report['buildings']:,}")
    table.add_row("agent poses", f"{report['agent_poses']:,}{_robots_text(report['layers'])}")
    dynamics = report.get("aion")
    if dynamics is not None:
        when = (
            f"predicted at {dynamics['time']} ({dynamics.get('zone') or '-'})"
            if dynamics.get("time")
            else "as observed"
        )
        table.add_row(
            "aion dynamics",
            f"flows {safe(when)} from {safe(dynamics.get('map', '?'))}, in each place's and "
            "room's metadata",
        )
    mesh = report["mesh"]
    table.add_row(
        "mesh",
        "none" if mesh is None else f"{mesh['vertices']:,} vertices, {mesh['faces']:,} faces",
    )
    table.add_row(
        "layers",
        ", ".join(
            safe(f"{row['key']}{' ' + row['name'] if row['name'] else ''}: {row['nodes']:,}")
            for row in report["layers"]
        ),
    )
    print_table(table)
    for note in report["notes"]:
        console().print(f"[yellow]note:[/yellow] {safe(note)}", soft_wrap=True)
    if report["places"] == 0:
        console().print(
            f"[yellow]warning:[/yellow] the navigational layer {layer} has no places: "
            "choose another with --nav-layer",
            soft_wrap=True,
        )


def _robots_text(layers: list[dict[str, Any]]) -> str:
    """`` (robot a, 2[97]; not used: 2[98] 5)`` when the graph holds several robots' agent
    partitions (Hydra-Multi): aion takes the first robot's poses (the lowest partition, as
    :func:`formats.dsg_scan.navigation` does), and the count alone read as every robot's;
    "" for one robot or none."""
    import re

    robots = []
    for row in layers:
        m = re.fullmatch(r"(\d+)\[(\d+)\]", str(row["key"]))
        if row["name"] == "AGENTS" and m and int(m[2]) != 0 and row["nodes"]:
            robots.append((int(m[2]), row["key"], row["nodes"]))
    if len(robots) < 2:
        return ""
    robots.sort()
    part, key, _ = robots[0]
    who = f"robot {chr(part)}, {key}" if chr(part).isalpha() and part < 128 else key
    others = ", ".join(f"{k} {n:,}" for _, k, n in robots[1:])
    return f" ({who}; not used: {others})"
