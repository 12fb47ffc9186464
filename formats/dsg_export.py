"""The 4D scene graph as a spark_dsg file (``aion export --format dsg``).

The map's scene graph — places with their edges, rooms, buildings — written with spark_dsg
as Hydra saves graphs (``.json``, or binary ``.sparkdsg``), each place and room carrying aion's
dynamics at the export's time in its node **metadata** under ``"aion"`` (the fields of
``aion predict --format json``: flow, flow_per_hour, flow_p10/p90, direction_deg, entropy,
concentration, mean_speed, histogram, family...), and the graph's own metadata saying what
the values are (map, time, zone, direction bins). A spark_dsg user reads them back with
``G.get_node(NodeSymbol("p", 12)).attributes.metadata.get()["aion"]``; aion reads the file
as any scene graph (``aion info``, ``build --graph``).

The graph keeps what the map stores of its source graph (``formats/MAPFILE.md``): the places
go back to the layer they came from (:func:`place_layer`: PLACES ``3``, Hydra's 2D places
MESH_PLACES ``3[1]``, any other layer key as it was) under their own node ids, with their
edges, rooms and buildings; the robot poses of the agent layer (partition ``a`` of layer 2,
``a0``, ``a1``... in time order) and the mesh when the map holds them. What the map does not
store is not in the file (:data:`NOT_STORED`, said in a note): objects, the source's other
layers, frontiers, room and agent edges, edge weights, pose orientations and node attributes
beyond positions and names. A place of the map without an entry carries no ``"aion"``
record. Hash cells are not nodes of the graph and are left out.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.types import GraphSnapshot, Mesh
from aion_cli.formats.dsg_layers import NavLayer
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
    #: the places' layer key in spark_dsg's notation ("3", "3[1]")
    place_layer: str = "3"
    agents: int = 0
    mesh_vertices: int = 0


#: how the graph metadata's marker reads in the bytes spark_dsg saves (JSON and binary alike)
_MARKER_FIELD = b'"written_by":"' + MARKER.encode() + b'"'
#: what the source graph may hold that a map does not store, so an export cannot give back
NOT_STORED = (
    "objects, other layers, frontiers, room and robot-pose edges, edge weights, pose "
    "orientations or node attributes beyond positions and names"
)


def not_stored_note(layer_name: str) -> str:
    """The note of a scene-graph export: what of the source graph a map does not store, so
    the file cannot give it back; a graph aion derived (``layer_name`` "derived") had none."""
    if layer_name == "derived":
        return "the graph was derived from walking people: it holds places and their edges only"
    return f"a map does not store a scene graph's {NOT_STORED}: they are not in the file"


#: the robot's partition of the agent layer (kimera_pgmo's prefix of robot 0)
AGENT_PREFIX = "a"
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


def _check_saved(path: Path, out: Path, dsg: Any, with_mesh: bool) -> None:
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
            body = dsg.to_binary(include_mesh=with_mesh)
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


def place_layer(layer_name: str) -> NavLayer:
    """The source graph's layer of the map's places, from the name the map keeps
    (``GraphSnapshot.layer_name``, :attr:`NavLayer.snapshot_name`): ``places`` -> PLACES ``3``,
    ``mesh_places`` -> MESH_PLACES ``3[1]`` (spark_dsg 1.1's key: the map keeps the name, not
    whether an older graph had it at layer 20), ``layer_20`` / ``layer_3[2]`` -> that key; any
    other (``derived``: places aion derived, no source graph) -> PLACES ``3``."""
    from aion_cli.formats.dsg_layers import (
        DEFAULT_LAYER_NAMES,
        LEGACY_MESH_PLACES_LAYER,
        PLACES_LAYER,
        GraphLayerError,
        parse_nav_layer,
    )

    keys = {v: k for k, v in DEFAULT_LAYER_NAMES.items() if k != (LEGACY_MESH_PLACES_LAYER, 0)}
    text = layer_name.removeprefix("layer_")
    try:
        request = parse_nav_layer(text if text != layer_name else text.upper())
    except GraphLayerError:  # neither a key nor a name
        request = None
    if isinstance(request, tuple):
        return NavLayer(*request, name=DEFAULT_LAYER_NAMES.get(request, ""))
    if isinstance(request, str) and request in keys:
        return NavLayer(*keys[request], name=request)
    return NavLayer(PLACES_LAYER, 0, "PLACES")


def _new_graph(spark_dsg: Any, places: NavLayer, agents: bool) -> Any:
    """An empty spark_dsg graph with the default layers (OBJECTS / AGENTS 2, PLACES 3, ROOMS 4,
    BUILDINGS 5), the places' key and name, and the robot's agent partition when ``agents``."""
    key = spark_dsg.LayerKey
    names = {"OBJECTS": key(2), "AGENTS": key(2), "PLACES": key(3), "ROOMS": key(4)}
    names["BUILDINGS"] = key(5)
    if places.name:
        names[places.name] = key(places.layer, places.partition)
    keys = {(2, 0), (3, 0), (4, 0), (5, 0), (places.layer, places.partition)}
    if agents:
        keys.add((2, ord(AGENT_PREFIX)))
    return spark_dsg.DynamicSceneGraph([key(*k) for k in sorted(keys)], names)


def _spark_mesh(spark_dsg: Any, mesh: Mesh) -> Any:
    """The map's mesh as a spark_dsg ``Mesh``: 6 x v vertices (xyz, rgb in 0..1; black where the
    map keeps no colours) and 3 x f faces."""
    colored = len(mesh.colors) == len(mesh.vertices)
    out = spark_dsg.Mesh(colored, False, False, False)
    colors = mesh.colors if colored else np.zeros_like(mesh.vertices)
    out.set_vertices(np.ascontiguousarray(np.hstack([mesh.vertices, colors]).T, np.float64))
    out.set_faces(np.ascontiguousarray(np.asarray(mesh.faces, np.int32).T))
    return out


def _add_agents(spark_dsg: Any, dsg: Any, graph: GraphSnapshot) -> int:
    """The robot poses as agent nodes ``a0``, ``a1``... (time order, as Hydra numbers them)
    in partition ``a`` of layer 2, each with its position and stamp (whole microseconds, as
    spark_dsg holds them); the map keeps no orientation nor the links between poses, so each
    pose is written unrotated (the identity quaternion). spark_dsg leaves a new node's
    ``world_R_body`` uninitialised: memory of whatever was there, now and then NaN, which its
    JSON writer saves as ``null`` and its reader then refuses ("type must be number")."""
    from datetime import timedelta

    if graph.agents is None:
        return 0
    layer = int(dsg.get_layer_key("AGENTS").layer)
    t_us = (np.asarray(graph.agents.t_ns, np.int64) // 1000).tolist()
    for k, (us, xyz) in enumerate(zip(t_us, graph.agents.xyz, strict=True)):
        attrs = spark_dsg.AgentNodeAttributes()
        attrs.position = np.asarray(xyz, dtype=np.float64)
        attrs.timestamp = timedelta(microseconds=us)
        attrs.world_R_body = spark_dsg.Quaternion(1.0, 0.0, 0.0, 0.0)  # w, x, y, z
        attrs.external_key = 0  # uninitialised too
        dsg.add_node(layer, spark_dsg.NodeSymbol(AGENT_PREFIX, k), attrs, ord(AGENT_PREFIX))
    return len(t_us)


def write_dynamic_graph(
    graph: GraphSnapshot,
    records: Mapping[int, dict[str, Any]],
    info: dict[str, Any],
    out: Path,
) -> DsgExportSummary:
    """Write ``graph`` to ``out`` with ``records[node id]`` (places, rooms, buildings) as each
    node's ``"aion"`` metadata and ``info`` as the graph's; the places in the layer they came
    from, the robot poses and the mesh when the map holds them. The file appears complete or
    not at all."""
    import spark_dsg

    check_dsg_target(out)
    nav = place_layer(graph.layer_name)
    dsg = _new_graph(spark_dsg, nav, graph.agents is not None)

    def add(layer: Any, attrs: Any, node_id: int, xyz: Any) -> None:
        attrs.position = np.asarray(xyz, dtype=np.float64)
        record = records.get(node_id)
        if record is not None:
            attrs.metadata.set({"aion": record})
        dsg.add_node(layer, spark_dsg.NodeSymbol(node_id), attrs)

    places = graph.places
    place_key = spark_dsg.LayerKey(nav.layer, nav.partition)
    two_d = nav.name == "MESH_PLACES"  # Hydra's 2D places carry Place2dNodeAttributes
    for node_id, xyz in zip(places.ids.tolist(), places.xyz, strict=True):
        if two_d:
            attrs = spark_dsg.Place2dNodeAttributes()
            # left uninitialised by spark_dsg (memory of whatever was there, at times NaN,
            # saved as a JSON null its reader refuses); a map keeps no ellipse of a place
            attrs.ellipse_centroid = np.zeros(3)
            attrs.ellipse_matrix_compress = np.zeros((2, 2))
            attrs.ellipse_matrix_expand = np.zeros((2, 2))
        else:
            attrs = spark_dsg.PlaceNodeAttributes()
            attrs.real_place = True
        add(place_key, attrs, node_id, xyz)
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
    agents = _add_agents(spark_dsg, dsg, graph)
    if graph.mesh is not None:
        dsg.mesh = _spark_mesh(spark_dsg, graph.mesh)
    dsg.metadata.set({"aion": {"written_by": MARKER, **info}})
    with_mesh = graph.mesh is not None
    with Staged(out) as staged:
        dsg.save(str(staged.path), include_mesh=with_mesh)
        _check_saved(staged.path, out, dsg, with_mesh)
    with_dynamics = sum(1 for node_id in places.ids.tolist() if node_id in records)
    return DsgExportSummary(
        out, len(places), with_dynamics, len(graph.rooms), len(graph.buildings),
        len(graph.edges), nav.key, agents, 0 if graph.mesh is None else len(graph.mesh.vertices),
    )  # fmt: skip
