"""A map's scenes over a time series as one MCAP file: ``aion export --format mcap`` and
:meth:`aion_cli.Map.export` with ``format="mcap"`` (no click or rich here).

Each step is the scene of ``aion predict``'s entry table at its time
(``aion_cli.scene.scene_of_table``, the arrays the PLY export draws too), styled by
``formats.scene_style.style_scene`` and written by ``formats.scene_mcap``. Entities are named
by the entry ids of ``aion predict`` (``p12``, ``c<key>``), in the map's entry order, which is
the same at every step. Sphere sizes share one scale over the whole series
(:func:`series_flow_scale`; in a map of hash cells only, the cells' arrow lengths): the busiest
node of the busiest step is drawn at full size (or a high quantile of all steps' flows when it
dwarfs them, ``formats.scene_colours.display_flow_scale``), so a node that grows on the
timeline is busier then (a PLY / PCD series of folders shares the scale too:
``exports.export_frames``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.time_text import Zone

if TYPE_CHECKING:
    from aion_cli.formats.scene_style import SceneStyle
    from aion_cli.mapquery import LoadedMap


def export_mcap(
    loaded: LoadedMap,
    map_path: Any,
    out: Path,
    times: Sequence[int | None],
    zone: Zone | None,
    ends: tuple[Any, int, int] | None = None,
    on_frame: Callable[[], None] | None = None,
) -> Path:
    """Write the scenes at ``times`` (None: historical) as the MCAP file ``out``, one step per
    time logged at that time (a historical step at the end of the map's data), with the path
    between ``ends`` (``exports.path_ends``) planned at each step; ``on_frame`` after each
    step. ``out`` is checked before anything is computed and appears complete or not at all."""
    from aion_cli.engine.time_text import format_ns
    from aion_cli.formats.outputs import safe_text
    from aion_cli.formats.scene_markers import FRAME
    from aion_cli.formats.scene_mcap import (
        SceneMcapWriter,
        check_scene_target,
        check_step_times,
    )
    from aion_cli.manifest import Manifest
    from aion_cli.predictions import hour_flags, observed_text

    check_scene_target(out)
    check_step_times([_log_time(loaded, t) for t in times])  # before any scene is computed
    # the frame the map's positions are in (aion build --map-frame; map by default)
    frame = Manifest.from_dict(loaded.manifest).map_frame or FRAME
    scale = series_flow_scale(loaded, times)
    steps = [t for t in times if t is not None]
    flags = hour_flags(loaded, steps)
    metadata = {
        "map": safe_text(map_path),
        "mode": "predicted" if steps else "historical",
        "steps": str(len(times)),
        "first": format_ns(steps[0], zone) if steps and zone is not None else "",
        "last": format_ns(steps[-1], zone) if steps and zone is not None else "",
        "zone": zone.name if zone is not None else "",
        "frame": frame,
        # the steps at an hour no day observed (their flows extrapolated), comma-separated
        "extrapolated": ", ".join(
            format_ns(t, zone)
            for t, seen in zip(steps, flags, strict=True)
            if seen is False and zone is not None
        ),
        # per step, in order, predict's hour_observed as its CSV writes it (true / false);
        # empty where not known: historical, or a map that lists no hours
        "hour_observed": (
            "" if None in flags else ", ".join(str(observed_text(seen)) for seen in flags)
        ),
    }
    with SceneMcapWriter(out, metadata, frame) as writer:
        for t_ns in times:
            style, node_ids, cell_ids = step_scene(loaded, t_ns, ends, scale)
            writer.write_step(_log_time(loaded, t_ns), style, node_ids, cell_ids)
            if on_frame is not None:
                on_frame()
    return out


def step_scene(
    loaded: LoadedMap,
    t_ns: int | None,
    ends: tuple[Any, int, int] | None,
    flow_scale: float | None,
) -> tuple[SceneStyle, list[str], list[str]]:
    """The drawn scene at ``t_ns`` (None: historical) with the path planned between ``ends``,
    and the entry ids of its nodes and of its unbound cells (in the scene's order)."""
    from aion_cli.engine.entries import CELL, NODE
    from aion_cli.exports import planned_path
    from aion_cli.formats.scene_style import style_scene
    from aion_cli.predictions import entry_ids, entry_table
    from aion_cli.scene import scene_of_table

    table = entry_table(loaded, t_ns)
    scene = scene_of_table(loaded, table, t_ns)
    style = style_scene(
        scene.nodes_xyz,
        scene.node_flow,
        scene.node_entropy,
        scene.node_angle,
        cells_xyz=scene.cells_xyz,
        cells_flow=scene.cells_flow,
        cells_entropy=scene.cells_entropy,
        edges_xyz_pairs=scene.edges_xyz,
        mesh=scene.mesh,
        path_xyz=None if ends is None else planned_path(loaded, t_ns, ends),
        cell_size=scene.cell_size,
        node_concentration=scene.node_concentration,
        flow_scale=flow_scale,
        cells_dominant_angle=scene.cells_angle,
    )
    kind = np.asarray(table.kind)
    ids = [
        [str(i) for i in entry_ids(table, rows)] if len(rows) else []
        for rows in (np.flatnonzero(kind == NODE), np.flatnonzero(kind == CELL))
    ]
    return style, ids[0], ids[1]


def series_flow_scale(loaded: LoadedMap, times: Sequence[int | None]) -> float | None:
    """The flow drawn at full size in every step of a series: ``display_flow_scale`` of the
    flows of what the scenes at ``times`` size by flow (the busiest, or a high quantile when
    the busiest dwarfs the rest): the nodes' spheres and arrows, or in a scene without nodes
    (a map of hash cells only) the cells' arrows; None when none has flow (each step then
    scales on its own, as a single export does). The predicted steps' flows come from the
    predictor's batch path for those rows only (``prediction_series.entry_flows``: the
    tables' values, element by element), not from a whole scene per step, which the export
    then builds once more to draw it; a historical step (None) from its scene."""
    from aion_cli.engine.entries import CELL, NODE
    from aion_cli.formats.scene_colours import display_flow_scale
    from aion_cli.prediction_series import entry_flows
    from aion_cli.scene import scene_at

    entries = loaded.state.entries
    graph = loaded.graph
    # a scene has nodes when an entry is a node or the graph has places (drawn without flow)
    with_nodes = entries.node_rows().size > 0 or (graph is not None and len(graph.places) > 0)
    sized = NODE if with_nodes else CELL
    flows = []
    timed = [int(t) for t in times if t is not None]
    if timed:
        rows, _ = loaded.state.predictor()
        drawn = np.flatnonzero(np.asarray(entries.kind)[rows] == sized)
        flows.append(entry_flows(loaded, drawn, timed, None).reshape(-1))
    if len(timed) < len(times):
        scene = scene_at(loaded, None)
        flows.append(scene.node_flow if sized == NODE else scene.cells_flow)
    pooled = np.concatenate(flows) if flows else np.zeros(0)
    if not (np.nan_to_num(pooled) > 0).any():
        return None
    return display_flow_scale(pooled)[0]


def _log_time(loaded: LoadedMap, t_ns: int | None) -> int:
    """A step's log time: its time; for the historical scene, the end of the map's data."""
    from aion_cli.manifest import Manifest

    if t_ns is not None:
        return int(t_ns)
    end = Manifest.from_dict(loaded.manifest).end_ns
    return end if end is not None and end >= 0 else 0
