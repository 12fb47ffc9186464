"""A :class:`GraphSnapshot` as plain arrays plus JSON metadata (and back), for the map state.

Arrays are prefixed ``graph_``; labels, times and names go to the meta dict so nothing needs
pickling. ``None`` (no graph yet) gives no arrays and ``meta = None``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from aion_cli.engine.types import GraphSnapshot, Layer, Mesh, Trajectory

_LAYERS = ("places", "rooms", "buildings")


def graph_to_arrays(graph: GraphSnapshot | None) -> tuple[dict[str, np.ndarray], Any]:
    """Arrays ``graph_*`` and a JSON-serialisable meta dict (None when there is no graph)."""
    if graph is None:
        return {}, None
    edges = np.asarray(graph.edges, np.int64).reshape(-1, 2)
    arrays: dict[str, np.ndarray] = {"graph_edges": edges}
    labels: dict[str, list[str]] = {}
    for name in _LAYERS:
        layer: Layer = getattr(graph, name)
        arrays[f"graph_{name}_ids"] = np.asarray(layer.ids, np.uint64)
        arrays[f"graph_{name}_xyz"] = np.asarray(layer.xyz, np.float64).reshape(-1, 3)
        arrays[f"graph_{name}_parent"] = np.asarray(layer.parent, np.uint64)
        labels[name] = list(layer.labels)
    if graph.mesh is not None:
        arrays["graph_mesh_vertices"] = graph.mesh.vertices
        arrays["graph_mesh_faces"] = graph.mesh.faces
        arrays["graph_mesh_colors"] = graph.mesh.colors
    if graph.agents is not None:
        arrays["graph_agents_t_ns"] = graph.agents.t_ns
        arrays["graph_agents_xyz"] = graph.agents.xyz
    meta = {
        "t_ns": int(graph.t_ns),
        "layer_name": graph.layer_name,
        "frame_id": graph.frame_id,
        "labels": labels,
        "has_mesh": graph.mesh is not None,
        "has_agents": graph.agents is not None,
    }
    return arrays, meta


def graph_from_arrays(arrays: dict[str, np.ndarray], meta: Any) -> GraphSnapshot | None:
    """Inverse of :func:`graph_to_arrays` (KeyError / ValueError on missing members)."""
    if meta is None:
        return None
    layers = {}
    for name in _LAYERS:
        labels = tuple(str(x) for x in meta["labels"].get(name, []))
        layers[name] = Layer(
            np.asarray(arrays[f"graph_{name}_ids"], np.uint64),
            np.asarray(arrays[f"graph_{name}_xyz"], np.float64).reshape(-1, 3),
            np.asarray(arrays[f"graph_{name}_parent"], np.uint64),
            labels,
        )
    mesh = None
    if meta["has_mesh"]:
        mesh = Mesh(
            np.asarray(arrays["graph_mesh_vertices"], np.float64).reshape(-1, 3),
            np.asarray(arrays["graph_mesh_faces"], np.int32).reshape(-1, 3),
            np.asarray(arrays["graph_mesh_colors"], np.float64).reshape(-1, 3),
        )
    agents = None
    if meta["has_agents"]:
        agents = Trajectory(
            np.asarray(arrays["graph_agents_t_ns"], np.int64),
            np.asarray(arrays["graph_agents_xyz"], np.float64).reshape(-1, 3),
        )
    return GraphSnapshot(
        t_ns=int(meta["t_ns"]),
        places=layers["places"],
        edges=np.asarray(arrays["graph_edges"], np.int64).reshape(-1, 2),
        rooms=layers["rooms"],
        buildings=layers["buildings"],
        mesh=mesh,
        agents=agents,
        layer_name=str(meta["layer_name"]),
        frame_id=str(meta["frame_id"]),
    )


def same_graph(a: GraphSnapshot | None, b: GraphSnapshot | None) -> bool:
    """Whether two graphs hold the same layers, edges, mesh and agents, whatever their times."""
    if a is None or b is None:
        return a is b
    xa, ma = graph_to_arrays(a)
    xb, mb = graph_to_arrays(b)
    if {**ma, "t_ns": 0} != {**mb, "t_ns": 0} or xa.keys() != xb.keys():
        return False
    return all(np.array_equal(xa[k], xb[k]) for k in xa)


def file_graph_time(
    graph: GraphSnapshot | None, before: GraphSnapshot | None
) -> GraphSnapshot | None:
    """``graph``, a ``--graph FILE`` added again at a later log's start, with the time of the
    same graph the map held ``before`` (one pass adds the file once, at its first log): the
    graph unchanged otherwise."""
    if graph is None or before is None or not same_graph(graph, before):
        return graph
    if int(before.t_ns) >= int(graph.t_ns):
        return graph
    from dataclasses import replace

    return replace(graph, t_ns=int(before.t_ns))
