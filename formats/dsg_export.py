"""The 4D scene graph as a spark_dsg file (``aion export --format dsg``).

The map's scene graph — places with their edges, rooms, buildings — written with spark_dsg
as Hydra saves graphs (``.json``, or binary ``.sparkdsg``), each place and room carrying aion's
dynamics at the export's time in its node **metadata** under ``"aion"`` (the fields of
``aion predict --format json``: flow, flow_per_hour, flow_p10/p90, direction_deg, entropy,
concentration, mean_speed, histogram, family...), and the graph's own metadata saying what
the values are (map, time, zone, direction bins). A spark_dsg user reads them back with
``G.get_node(NodeSymbol("p", 12)).attributes.metadata.get()["aion"]``; aion reads the file
as any scene graph (``aion info``, ``build --graph``).

Places go to the PLACES layer (3) whatever layer the map's graph took them from (named in the
graph metadata, ``nav_layer``); a place of the map without an entry carries no ``"aion"``
record. Hash cells are not nodes of the graph and are left out.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.types import GraphSnapshot
from aion_cli.formats.outputs import OutputPathError, Staged, check_output

#: suffixes spark_dsg saves (it chooses the encoding from the name)
SUFFIXES = (".json", ".sparkdsg")
#: the graph metadata key naming the writer; an existing file holding it may be replaced
MARKER = "aion export"


@dataclass(frozen=True)
class DsgExportSummary:
    """What was written: the file and how many nodes carry dynamics."""

    path: Path
    places: int
    places_with_dynamics: int
    rooms: int
    buildings: int
    edges: int


#: how the graph metadata's marker reads in the bytes spark_dsg saves (JSON and binary alike)
_MARKER_FIELD = b'"written_by":"' + MARKER.encode() + b'"'
#: the start of a binary ``.sparkdsg`` file
_BINARY_HEAD = b"\xdd\x09\x00\x00\x00SPARK_DSG"


def _written_by_aion(path: Path) -> bool:
    """Whether ``path`` is a graph file an export wrote: a spark_dsg JSON whose graph
    metadata says ``"aion": {"written_by": "aion export"}``, or a binary ``.sparkdsg`` with
    that metadata. Any other file that merely holds the words "aion export" (a script or
    notes naming the command) is someone else's."""
    import json

    try:
        data = path.read_bytes()
    except OSError:
        return False
    if _MARKER_FIELD not in data:
        return False
    if data.startswith(_BINARY_HEAD):
        return True
    try:
        doc = json.loads(data)
    except (ValueError, RecursionError):
        return False
    meta = doc.get("metadata") if isinstance(doc, dict) else None
    aion = meta.get("aion") if isinstance(meta, dict) else None
    return isinstance(aion, dict) and aion.get("written_by") == MARKER


def check_dsg_target(path: Path) -> None:
    """Refuse the output before anything is computed: a folder, another suffix (``.JSON``
    too: spark_dsg saved nothing there and aion stopped with an internal error), a device, or
    an existing file that is not a graph file aion exported. The messages name the output,
    not the option that gave it: ``aion export -o`` and ``Map.export`` both come here."""
    if path.is_dir():
        raise OutputPathError(
            f"{path} is a folder: the scene-graph export (format dsg) writes one file",
            hint=f"name the file, e.g. {path / 'dsg.json'}",
        )
    if path.suffix.lower() not in SUFFIXES:
        raise OutputPathError(
            "the scene-graph export (format dsg) writes a .json or .sparkdsg file, got "
            f"{path.name!r}",
            hint="name the file, e.g. dsg.json",
        )
    if path.suffix not in SUFFIXES:  # spark_dsg saves (and loads) no other spelling
        raise OutputPathError(
            f"the scene-graph export writes a {path.suffix.lower()} file in lower case, got "
            f"{path.name!r}: spark_dsg reads no other spelling",
            hint=f"name it {path.with_suffix(path.suffix.lower()).name}",
        )
    check_output(
        path, overwrite=True, recognise=_written_by_aion, what="a scene-graph file", option=None
    )


def _check_saved(path: Path, out: Path, dsg: Any) -> None:
    """:class:`ExportWriteError` unless the file spark_dsg saved at ``path`` is whole:
    spark_dsg reports no write error (a full disk leaves a cut-off or empty file). A
    ``.json`` file must parse; a ``.sparkdsg`` file must end with the graph's binary form
    (``DynamicSceneGraph.to_binary``; the file adds a header in front)."""
    import json

    from aion_cli.formats.export import ExportWriteError

    try:
        data = path.read_bytes()
        if out.suffix.lower() == ".json":
            json.loads(data)
            whole = True
        else:
            body = dsg.to_binary(include_mesh=False)
            whole = len(data) > len(body) and data.endswith(body)
    except (OSError, ValueError) as exc:
        whole = False
        reason = getattr(exc, "strerror", None) or "the file came out incomplete"
    else:
        reason = "the file came out incomplete"
    if not whole:
        raise ExportWriteError(
            f"cannot write {out}: {reason}",
            hint="check free disk space on the output's file system",
        )


def _names(layer: Any) -> list[str]:
    """The name of each node of ``layer`` as the graph gave it ("kitchen"), "" where it gave
    none or only the node's id (:func:`aion_cli.room_names.name_of`)."""
    from aion_cli.room_names import name_of

    return [name_of(layer, k) or "" for k in range(len(layer))]


def write_dynamic_graph(
    graph: GraphSnapshot,
    records: Mapping[int, dict[str, Any]],
    info: dict[str, Any],
    out: Path,
) -> DsgExportSummary:
    """Write ``graph`` to ``out`` with ``records[node id]`` (places, rooms, buildings) as each
    node's ``"aion"`` metadata and ``info`` as the graph's; the file appears complete or not
    at all."""
    import spark_dsg

    check_dsg_target(out)
    dsg = spark_dsg.DynamicSceneGraph()

    def add(layer: Any, attrs: Any, node_id: int, xyz: Any) -> None:
        attrs.position = np.asarray(xyz, dtype=np.float64)
        record = records.get(node_id)
        if record is not None:
            attrs.metadata.set({"aion": record})
        dsg.add_node(layer, spark_dsg.NodeSymbol(node_id), attrs)

    places = graph.places
    for node_id, xyz in zip(places.ids.tolist(), places.xyz, strict=True):
        attrs = spark_dsg.PlaceNodeAttributes()
        attrs.real_place = True
        add(spark_dsg.DsgLayers.PLACES, attrs, node_id, xyz)
    for a, b in graph.edges.tolist():
        dsg.insert_edge(
            spark_dsg.NodeSymbol(int(places.ids[a])), spark_dsg.NodeSymbol(int(places.ids[b]))
        )
    for layer, kind, make in (
        (graph.rooms, spark_dsg.DsgLayers.ROOMS, spark_dsg.RoomNodeAttributes),
        (graph.buildings, spark_dsg.DsgLayers.BUILDINGS, spark_dsg.SemanticNodeAttributes),
    ):
        for node_id, xyz, name in zip(layer.ids.tolist(), layer.xyz, _names(layer), strict=True):
            attrs = make()
            attrs.name = name  # Hydra's room label ("kitchen"), read back by build --graph
            add(kind, attrs, node_id, xyz)
    for layer in (places, graph.rooms):  # each node to its parent one layer up
        for child, parent in zip(layer.ids.tolist(), layer.parent.tolist(), strict=True):
            if parent and dsg.has_node(spark_dsg.NodeSymbol(parent)):
                dsg.insert_edge(spark_dsg.NodeSymbol(child), spark_dsg.NodeSymbol(parent))
    dsg.metadata.set({"aion": {"written_by": MARKER, **info}})
    with Staged(out) as staged:
        dsg.save(str(staged.path), include_mesh=False)
        _check_saved(staged.path, out, dsg)
    with_dynamics = sum(1 for node_id in places.ids.tolist() if node_id in records)
    return DsgExportSummary(
        out, len(places), with_dynamics, len(graph.rooms), len(graph.buildings), len(graph.edges)
    )
