"""The scene-graph export: the map's graph with each place's, room's and building's dynamics
in its node metadata, as a spark_dsg file (``aion export --format dsg``, ``Map.export``).

:func:`export_dsg` gathers the predict records of the graph's nodes and hands them to
:mod:`formats.dsg_export`; :func:`cells_left_out` says what such a file cannot hold (the
detections on hash cells no place holds). It is apart from :mod:`aion_cli.exports`, which
stages scene files and frames into folders, because a spark_dsg file shares none of that:
:func:`aion_cli.exports.write_export` calls :func:`export_dsg` and nothing else here
(no click or rich here).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from aion_cli.engine.time_text import Zone


def export_dsg(
    loaded: Any, map_path: Path | str, out: Path, t_ns: int | None, zone: Zone | None
) -> Any:
    """The map's scene graph with each place's and room's dynamics at ``t_ns`` (None: as
    observed) in its node metadata, as the spark_dsg file ``out`` (``export --format dsg``,
    :mod:`formats.dsg_export`); returns its ``DsgExportSummary``."""
    from aion_cli.engine.node_ids import parse_node_id
    from aion_cli.entry_selection import select
    from aion_cli.errors import InputError
    from aion_cli.formats.dsg_export import check_dsg_target, write_dynamic_graph
    from aion_cli.formats.outputs import safe_text
    from aion_cli.predictions import document, entry_table, hour_flags, rows_from_table

    check_dsg_target(out)  # before anything is computed
    graph = loaded.graph
    if graph is None:
        raise InputError(
            "the map has no scene graph to write",
            hint="build it with a scene graph (from the log or --graph FILE) or --derive-graph",
        )
    table = entry_table(loaded, t_ns)
    places = select(table, "places")
    node_ids = table.node_id[places].tolist()
    records = {
        int(n): _node_record(row)
        for n, row in zip(node_ids, rows_from_table(table, places), strict=True)
    }
    if len(graph.rooms) or len(graph.buildings):
        from aion_cli.room_names import names_by_id

        names = names_by_id(graph)
        for layer in ("rooms", "buildings"):
            try:
                grouped = entry_table(loaded, t_ns, layer)
            except InputError:  # the graph has none that hold places
                continue
            for row in rows_from_table(grouped, None, names):  # with names, as predict's
                records[parse_node_id(str(row["id"]))] = _node_record(row)
    (seen,) = hour_flags(loaded, [t_ns])
    info = document(map_path, loaded.config.bins, [], t_ns, zone, seen)
    info.pop("entries")
    info["map"] = safe_text(Path(os.fsdecode(map_path)).name)
    info["nav_layer"] = graph.layer_name
    return write_dynamic_graph(graph, records, info, out)


def cells_left_out(
    loaded: Any, shown_by: str = "--format ply or png"
) -> tuple[str, bool] | None:
    """What a scene-graph export (``--format dsg``) leaves out: the detections on unbound
    hash cells, which a spark_dsg graph has no node for (a log in another frame than the
    graph, a fixed sensor built with ``--graph`` of another site: every detection there, and
    the file's places all read zero). ``(message, most)``: ``most`` when they are at least
    half the map's detections; None when no cell holds any. ``shown_by``: what draws them
    (the API names its own calls)."""
    from aion_cli.mapquery import detections_by_kind, entries_with_detections

    on_cells, on_nodes = detections_by_kind(loaded.state)
    if on_cells <= 0:
        return None
    entries = loaded.state.entries
    cells = entries_with_detections(entries, entries.cell_rows())
    total = on_cells + on_nodes
    share = 100.0 * on_cells / total
    # never "0%" of some detections, nor "100%" of not all of them
    said = "under 1" if share < 1.0 else "over 99" if 99.0 < share < 100.0 else f"{share:.0f}"
    return (
        f"{said}% of the map's detections ({on_cells:,.0f} of {total:,.0f}) lie on "
        f"{cells:,} hash cell(s) that no place of the scene graph holds (away from them, or "
        "before they were stable), and a spark_dsg graph has no node for a cell: the file "
        f"leaves them out ({shown_by} shows them)",
        on_cells >= on_nodes,
    )


def _node_record(row: dict[str, Any]) -> dict[str, Any]:
    """A predict record without what the node itself holds (its position)."""
    return {k: v for k, v in row.items() if k not in ("x", "y", "z")}
