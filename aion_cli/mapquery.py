"""Reading a map back and the queries predict / plan / export share (no click).

:func:`load_map` gives the model state, its navigational graph (None for a map of hash cells
only) and the manifest (:func:`load_map_head` the manifest, graph and config alone);
:func:`nav_graph` and :func:`node_cost_fn` feed ``engine.planning``; :func:`export_map` hands
an entry table to ``formats.export``.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.types import I64, GraphSnapshot
from aion_cli.errors import InputError, MapFileError

if TYPE_CHECKING:
    from aion_cli.engine.entries import HeldCounts
    from aion_cli.engine.state import MapState


@dataclass
class LoadedMap:
    """A map read back: its state, navigational graph (None: hash cells only) and manifest."""

    state: MapState
    graph: GraphSnapshot | None
    manifest: dict[str, Any]

    @property
    def config(self) -> ModelConfig:
        return self.state.config

    def __iter__(self) -> Iterator[Any]:
        """``state, graph, manifest = load_map(path)`` (the contract's tuple form)."""
        return iter((self.state, self.graph, self.manifest))


def load_map(
    path: Path | str, writable: bool = False, forecast_only: bool = False
) -> LoadedMap:
    """Read ``path`` (checksums and version checked) into a :class:`LoadedMap`.

    ``forecast_only`` (queries: ``predict``, ``plan``, ``export``, ``report``): the per-entry
    Fourier sums are not read when the map stores the FreMEn components its forecasts use
    (``engine.temporal.components``); predictions are the same, the state cannot be saved.

    ``writable``: the state will be continued and saved (``aion build --map``); otherwise
    queries may fold the map's pending day into its accumulators in place, and the state
    keeps its arrays as read (no room reserved for new entries: no copy of the
    accumulators). Members are read and verified as the state asks for them
    (``formats.mapfile.open_map``): each is checksummed once, and the arrays read become the
    state's own (no second copy; a query's arrays view the file's pages in place, copied on
    write).

    A query-only map (``aion compact``: no Fourier sums) is always read as ``forecast_only``,
    and refused as ``writable`` (:class:`~aion_cli.errors.MapFileError` naming the full map it
    was made from).

    Derived members (FreMEn components, provisional scores, pooling priors) are used only
    when the map's seal says they are its own (``aion_cli.derived_seal``); otherwise the
    state computes them from its accumulators, and a query-only map is refused."""
    from aion_cli.derived_seal import derived_use
    from aion_cli.engine.state import MapState
    from aion_cli.formats.mapfile import check_writable_version, open_map
    from aion_cli.query_only import query_only_of, refuse_learning

    path = Path(path)  # a str from a script reads as its path
    check_map_input(path)
    with open_map(path, in_place=not writable) as members, invalid_state_named(path):
        manifest = members.manifest
        meta = _state_meta(path, manifest)
        query_only = query_only_of(manifest)
        if writable:
            check_writable_version(manifest.get("version"))
            refuse_learning(path, query_only, "continued or merged")
        use = derived_use(path, manifest, query_only is not None)
        # a query-only map (aion compact) has no Fourier sums: it is read as queries read maps
        forecast_only = forecast_only or query_only is not None
        state = MapState.from_arrays(
            members, meta, writable=writable, copy=False, forecast_only=forecast_only,
            stored_forecasts=use.forecasts, stored_priors=use.priors,
        )
    return LoadedMap(state, latest_graph(state), manifest)


@dataclass(frozen=True)
class MapHead:
    """What a map file says of itself without its model state: the manifest, the latest
    graph (None: hash cells only), the model parameters, the open window, the detections it
    used and whether it is a part map (``aion build --part``: days held for a merge)."""

    manifest: dict[str, Any]
    graph: GraphSnapshot | None
    config: ModelConfig
    open_window: int | None
    accepted: int
    part: bool


def load_map_head(path: Path | str) -> MapHead:
    """Read ``path``'s manifest and graph members only (checksummed as read; the entries and
    accumulators, most of a map, stay unread): what ``aion merge`` plans with before it reads
    each map's state in turn."""
    from aion_cli.engine.graph_arrays import graph_from_arrays
    from aion_cli.engine.state_checks import parse_state_meta
    from aion_cli.errors import MapCorruptError
    from aion_cli.formats.mapfile import open_map

    path = Path(path)
    check_map_input(path)
    with open_map(path) as members, invalid_state_named(path):
        manifest = members.manifest
        meta = _state_meta(path, manifest)
        head = parse_state_meta(meta)
        try:  # the graph's reader only looks members up by name: any mapping will do
            graph = graph_from_arrays(cast(dict[str, np.ndarray], members), head.graph)
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise MapCorruptError(f"map state metadata is incomplete or invalid: {exc}") from exc
    if graph is not None and len(graph.places) == 0:
        graph = None  # as latest_graph
    part = meta.get("deferred") is not None
    return MapHead(manifest, graph, head.config, head.open_window, head.accepted, part)


@contextmanager
def invalid_state_named(path: Path) -> Iterator[None]:
    """A map whose members pass their checksums but do not make a valid state (a value,
    dtype or shape the state's readers refuse: ``MapState.from_arrays``) reported with the
    map's path and the hint ``check_loaded``'s refusals give (theirs named the path too since
    stop 70: a position beyond the spatial hash's range named no map), as the file checks
    report a damaged member: the engine's :class:`~aion_cli.errors.MapCorruptError` names the member
    alone and has no hint (the command line printed ``error: map member forecast_priors
    holds [...]`` and nothing more, not saying which map of a merge)."""
    from aion_cli.errors import MAP_REBUILD_HINT, MapCorruptError

    try:
        yield
    except MapCorruptError as exc:
        if str(path) not in exc.message:  # which map of a merge or a --map
            exc.message = f"map {path} is invalid: {exc.message}"
            exc.args = (exc.message, *exc.args[1:])
        if exc.hint is None:
            exc.hint = MAP_REBUILD_HINT
        raise


def check_map_input(path: Path) -> None:
    """:class:`MapFileError` unless ``path`` names an existing file (a map to read; the
    output side is ``formats.mapfile.check_map_output``)."""
    if not path.exists():
        raise MapFileError(f"map file not found: {path}", hint="build one with `aion build LOG`")
    if path.is_dir():
        maps = sorted(str(p) for p in path.glob("*.aion") if p.is_file())[:3]
        raise MapFileError(
            f"{path} is a folder, not a map file",
            hint=f"give a map in it: {', '.join(maps)}"
            if maps
            else "give a map file (maps end in .aion; aion build LOG -o MAP writes one)",
        )


def _state_meta(path: Path, manifest: dict[str, Any]) -> dict[str, Any]:
    meta = manifest.get("state")
    if not isinstance(meta, dict):
        raise MapFileError(f"{path} has no model state", hint="rebuild it with `aion build`")
    return meta


def latest_graph(state: MapState) -> GraphSnapshot | None:
    """The map's latest scene graph, None when it has no places (a map of hash cells)."""
    graph = state.graph
    if graph is None or len(graph.places) == 0:
        return None
    return graph


def entry_positions(state: MapState) -> np.ndarray:
    """The positions (f64[n,3]) of the map's entries, places and hash cells: what the map
    spans beside its scene graph (a graph of one place among cells 40 m apart spans 0 m)."""
    entries = state.entries
    return entries.xyz[entries.live_rows()]


def state_counts(state: MapState) -> dict[str, int]:
    """Unbound cells, graph nodes (and those holding flow), bound cells and windows observed
    (the most any entry has seen, the open window included as the flows count it, each window
    for the share of it watched or recorded: rounded to whole windows) of a state, for
    summaries; never 0 when any share of a window was: a 4-minute log observed 0.4 of one
    window, which read "windows observed 0" beside the detections it used; 4.5 reads 5, a half
    up, not 4 as ``round`` has it)."""
    from aion_cli.number_text import half_up

    entries = state.entries
    live = entries.live_rows()
    observed = state.windows_observed(live, open_window=True)
    most = float(observed.max()) if len(observed) else 0.0
    return {
        "cells": len(entries.cell_rows()),
        "nodes": 0 if state.graph is None else len(state.graph.places),
        "nodes_with_flow": entries_with_detections(entries, entries.node_rows()),
        "bound_cells": len(state.redirects),
        "windows": max(1, half_up(most)) if most > 0 else 0,
    }


def entries_with_detections(entries: HeldCounts, rows: I64) -> int:
    """How many of ``rows`` hold a detection (a node's entry may hold only the windows in
    which the robot saw nobody there); ``entries``: a store or any entries with its counts."""
    from aion_cli.engine.entries import held_detections

    return int(np.count_nonzero(held_detections(entries, rows) > 0))


def detections_by_kind(state: MapState) -> tuple[float, float]:
    """(detections on unbound hash cells, detections on graph nodes) of a state."""
    from aion_cli.engine.entries import held_detections

    entries = state.entries
    on_cells = held_detections(entries, entries.cell_rows()).sum()
    on_nodes = held_detections(entries, entries.node_rows()).sum()
    return float(on_cells), float(on_nodes)


def nav_graph(loaded: LoadedMap) -> Any:
    """The planning graph of a map (``engine.nav_graph.NavGraph``)."""
    from aion_cli.engine.nav_graph import NavGraph

    if loaded.graph is None:
        raise InputError(
            "the map has no navigational graph to plan on",
            hint="build it with a scene graph (from the log or --graph FILE) or --derive-graph",
        )
    return NavGraph.from_snapshot(loaded.graph, loaded.config.plan_connect_radius)


def node_rows(table: Any, node_ids: np.ndarray) -> np.ndarray:
    """Row of each node id in an entry table (-1 where the node has no entry)."""
    rows = np.flatnonzero(np.asarray(table.kind) == 1)
    ids = np.asarray(table.node_id, dtype=np.uint64)[rows]
    order = np.argsort(ids)
    ids, rows = ids[order], rows[order]
    wanted = np.asarray(node_ids, dtype=np.uint64)
    if len(ids) == 0:
        return np.full(len(wanted), -1, np.int64)
    pos = np.minimum(np.searchsorted(ids, wanted), len(ids) - 1)
    return np.where(ids[pos] == wanted, rows[pos], -1).astype(np.int64)


def planning_config(loaded: LoadedMap) -> ModelConfig:
    """The map's config for planning: with ``plan_flow_auto``, ``plan_flow_scale`` becomes the
    90th percentile of the observed flow per window of the places that saw anyone, so "busy"
    means busy for this map whatever the tracker's rate or the robot's coverage."""
    config = loaded.config
    if not config.plan_flow_auto:
        return config
    from aion_cli.engine.entries import NODE
    from aion_cli.engine.query import historical_table

    table = historical_table(loaded.state)
    flow = table.descriptors.flow_per_window[table.kind == NODE]
    flow = flow[np.isfinite(flow) & (flow > 0)]
    if len(flow) == 0:
        return config
    return config.replace(plan_flow_scale=float(np.percentile(flow, 90.0)))


def node_cost_fn(loaded: LoadedMap, node_ids: np.ndarray) -> Any:
    """``node_cost(t_s)`` for ``engine.planning.plan``: predicted descriptors of the nodes at
    model time ``t_s`` (nodes without an entry have no flow)."""
    from aion_cli.engine.planning import NodeCosts
    from aion_cli.engine.query import predict_table
    from aion_cli.engine.windows import EPOCH_NS

    def cost(t_s: float) -> NodeCosts:
        table = predict_table(loaded.state, EPOCH_NS + round(t_s * 1e9))
        rows = node_rows(table, node_ids)
        have = rows >= 0
        d = table.descriptors
        costs = NodeCosts.zeros(len(node_ids))
        for name in ("entropy", "flow_per_window", "mean_angle", "concentration"):
            getattr(costs, name)[have] = np.asarray(getattr(d, name))[rows[have]]
        flow = costs.flow_per_window
        flow[~np.isfinite(flow)] = 0.0
        return costs

    return cost


def export_map(
    loaded: LoadedMap,
    table: Any,
    out_dir: Path,
    fmt: str = "ply",
    path_xyz: np.ndarray | None = None,
    prefix: str = "",
    flow_scale: float | None = None,
    about: Sequence[str] = (),
) -> list[Path]:
    """Write the scene of an entry table (nodes, cells, edges, mesh, a path) with
    ``formats.export.export_scene``; returns the files written. The arrays are gathered by
    ``aion_cli.scene.scene_of_table``, as for the other pictures of a map. ``flow_scale``: the
    flow drawn at full size (a series' one scale); None: this scene's own. ``about``: the
    files' header comments (``predictions.scene_about``)."""
    from aion_cli.formats.export import export_scene
    from aion_cli.scene import scene_of_table

    scene = scene_of_table(loaded, table)
    return export_scene(
        out_dir,
        scene.nodes_xyz,
        scene.node_flow,
        scene.node_entropy,
        scene.node_angle,
        cells_xyz=scene.cells_xyz,
        cells_flow=scene.cells_flow,
        cells_entropy=scene.cells_entropy,
        edges_xyz_pairs=scene.edges_xyz if len(scene.edges_xyz) else None,
        mesh=scene.mesh,
        path_xyz=path_xyz,
        fmt="pcd" if fmt == "pcd" else "ply",
        cell_size=scene.cell_size,
        prefix=prefix,
        node_concentration=scene.node_concentration,
        flow_scale=flow_scale,
        cells_dominant_angle=scene.cells_angle,
        about=about,
    )


def state_entry_counts(state: MapState) -> tuple[int, int]:
    """The entries of ``state`` (places and hash cells with a model) and the latest graph's
    places that hold none (``aion predict`` lists them too, with family "none"): what
    :func:`entries_text` says."""
    from aion_cli.engine.query import places_without_entry

    entries = state.entries
    graph = latest_graph(state)
    kind, node_id = entries.kind[: entries.n], entries.node_id[: entries.n]
    without = 0 if graph is None else places_without_entry(kind, node_id, graph.places.ids)
    return len(entries.live_rows()), without


def entry_counts(path: Path | str) -> tuple[int, int]:
    """:func:`state_entry_counts` of the map at ``path`` from its graph and two entry
    members, without reading its accumulators."""
    from aion_cli.engine.entries import FREE
    from aion_cli.engine.query import places_without_entry
    from aion_cli.formats.mapfile import open_map

    graph = load_map_head(path).graph
    with open_map(path) as members:
        names = set(members)
        if "entry_kind" not in names:
            return 0, 0 if graph is None else len(graph.places)
        kind = np.asarray(members["entry_kind"])
        node_id = np.asarray(members["entry_node_id"])
    without = 0 if graph is None else places_without_entry(kind, node_id, graph.places.ids)
    return int(np.count_nonzero(kind != FREE)), without


def entries_text(entries: int, without: int) -> str:
    """How ``info``, ``compact`` and ``report`` give a map's entries: ``365 (+37 places
    without data)``; the places without data are rows of ``aion predict`` and
    ``entries.csv`` (family "none") that hold no entry."""
    if not without:
        return f"{entries:,}"
    return f"{entries:,} (+{without:,} place{'s' if without != 1 else ''} without data)"
