"""Checks of a map state just read from a file: member shapes, then the loaded state's
entries, temporal accumulators, pending day, tables, graph and metadata.

A map file is untrusted input: :meth:`~aion_cli.engine.state.MapState.from_arrays` calls
:func:`check_member_shapes` before its components index the members, and
:func:`check_loaded` on the state it built; both raise
:class:`~aion_cli.errors.MapCorruptError` naming the first problem found.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.entries import ADDITIVE, CELL, HEADING_SUMS, NODE
from aion_cli.engine.grouping import contained
from aion_cli.engine.temporal.stored_layout import all_finite
from aion_cli.engine.types import GraphSnapshot
from aion_cli.errors import MAP_REBUILD_HINT, MapCorruptError, MapFileError, MapVersionError

if TYPE_CHECKING:
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.state import MapState

STATE_VERSION = 3
"""The version of the model state a map stores (``state_version`` in its manifest). 3 added
the pending day's provisional scores (``provisional_*`` members); a version-2 map is read as
it was written, its queries choosing families by its closed days alone."""
OLDEST_READABLE = 2
"""The oldest state this aion reads (1: before flows became rates)."""


@dataclass(frozen=True)
class StateMeta:
    """The scalar part of a map's state (its manifest's ``state``), parsed and checked."""

    config: ModelConfig
    open_window: int | None
    log_time_ns: int | None
    accepted: int
    dropped: dict[str, int]
    graph: Any
    pending_day: Any


def parse_state_meta(meta: Mapping[str, Any]) -> StateMeta:
    """The state meta of a map this aion can read (:func:`check_state_version` first);
    :class:`MapCorruptError` when a field is missing or invalid. One parser for every
    reader (``MapState.from_arrays`` and ``mapquery.load_map_head``)."""
    from aion_cli.engine.config import ModelConfig

    check_state_version(meta)
    try:
        window, log_time = meta["open_window"], meta["log_time_ns"]
        return StateMeta(
            config=ModelConfig.from_stored(meta["config"]),  # MapCorruptError if invalid
            open_window=None if window is None else int(window),
            log_time_ns=None if log_time is None else int(log_time),
            accepted=int(meta["accepted"]),
            dropped={str(k): int(v) for k, v in meta["dropped"].items()},
            graph=meta["graph"],
            pending_day=meta.get("pending_day"),
        )
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise MapCorruptError(f"map state metadata is incomplete or invalid: {exc}") from exc


def check_state_version(meta: Mapping[str, Any]) -> None:
    """:class:`MapFileError` for a state an older aion wrote, :class:`MapVersionError` (with
    the hint to upgrade) for one a newer aion wrote, :class:`MapCorruptError` for a missing
    version (the first check of every reader of a map's state)."""
    try:
        version = int(meta["state_version"])
    except (KeyError, TypeError, ValueError) as exc:
        raise MapCorruptError(f"map state metadata is incomplete or invalid: {exc}") from exc
    if version < OLDEST_READABLE:
        raise MapFileError(
            f"the map was written by an older aion (model state version {version}, "
            "before flows became rates)",
            hint="rebuild the map from its logs with `aion build`",
        )
    if version > STATE_VERSION:
        raise MapVersionError(
            f"the map was written by a newer aion (model state version {version}; this aion "
            f"reads up to {STATE_VERSION})",
            hint="install a newer aion (pip install -U aion) to read this map",
        )


# A map's members pass their sha256 checks when they are what its writer wrote; these checks
# catch a map that another tool (or a bug) wrote consistently checksummed but inconsistent:
# negative or non-finite counts, arrays of different lengths, indices out of range, pending
# windows outside the pending day. Each would otherwise surface as negative flows or an
# internal error (exit 1) in some later query; here it is one MapCorruptError (exit 2) that
# names the member. The limits are what every map aion writes satisfies (see the invariants
# in DESIGN.md §4 and the temporal accumulators' docstring).

#: Relative slack of the count comparisons (sums of integer-valued floats are exact, merged
#: maps add them in another order).
_COUNT_SLACK = 1e-9


def check_member_shapes(arrays: Mapping[str, np.ndarray]) -> None:
    """Members read together must agree in length (and shape) before the node table,
    redirects, observation and graph are built from them."""
    groups = [
        ("node_ids", "node_xyz", "node_ref_xyz", "node_stable_since_ns"),
        ("redirect_keys", "redirect_nodes"),
        ("obs_pose_t", "obs_pose_xy"),
        ("obs_fixed_start", "obs_fixed_end"),
        ("graph_agents_t_ns", "graph_agents_xyz"),
        *[(f"graph_{name}_ids", f"graph_{name}_xyz", f"graph_{name}_parent")
          for name in ("places", "rooms", "buildings")],
    ]
    widths = {"xyz": 3, "ref_xyz": 3, "pose_xy": 2}
    problems = []
    for names in groups:
        present = [n for n in names if n in arrays]
        if not present:
            continue
        lengths = {n: np.shape(arrays[n])[0] if np.ndim(arrays[n]) else -1 for n in present}
        if len(set(lengths.values())) > 1:
            listed = ", ".join(f"{n} {lengths[n]}" for n in present)
            problems.append(f"members of different lengths ({listed})")
        for n in present:
            width = next((w for suffix, w in widths.items() if n.endswith(suffix)), 0)
            shape = np.shape(arrays[n])
            empty = len(shape) == 1 and shape[0] == 0  # an empty member of any width
            if not empty and shape[1:] != ((width,) if width else ()):
                problems.append(f"{n} has shape {shape}")
    if "graph_edges" in arrays and (
        np.ndim(arrays["graph_edges"]) != 2 or np.shape(arrays["graph_edges"])[1] != 2
    ):
        problems.append(f"graph_edges has shape {np.shape(arrays['graph_edges'])}")
    if problems:
        raise MapCorruptError(f"map state is inconsistent: {'; '.join(problems[:3])}")


def _first_bad(name: str, values: np.ndarray, nonnegative: bool) -> str | None:
    """A problem with ``values`` (not finite, or negative where counts must not be), naming
    the member, the value and its row; None when fine."""
    v = np.asarray(values)
    if not all_finite(v):
        finite = np.isfinite(v)
        row = np.unravel_index(int(np.flatnonzero(~finite.ravel())[0]), v.shape)[0]
        return f"{name} holds {v.ravel()[~finite.ravel()][0]} (row {row})"
    if nonnegative and v.size and v.real.min() < 0:
        flat = int(np.argmin(v.real.ravel()))
        row = np.unravel_index(flat, v.shape)[0]
        return f"{name} holds {v.ravel()[flat]} (row {row}; counts cannot be negative)"
    return None


_ROW_BLOCK = 4096
"""Rows compared at a time by :func:`first_row_over`."""


def first_row_over(part: np.ndarray, whole: np.ndarray, slack: float) -> int | None:
    """The first row where any ``part > whole + slack`` (None: none), compared a block of
    rows at a time: the same comparisons as over the whole arrays, with temporaries of a
    block (issue 15: ``whole + slack`` of a 10^5-entry map's E x B counts was 6.4 MB of
    fresh memory per pair checked, three pairs per query's load)."""
    n = len(part)
    for a in range(0, n, _ROW_BLOCK):
        b = min(n, a + _ROW_BLOCK)
        over = part[a:b] > whole[a:b] + slack
        if over.any():
            return a + int(np.flatnonzero(over.reshape(b - a, -1).any(axis=1))[0])
    return None


def check_loaded(state: MapState, arrays: Mapping[str, np.ndarray]) -> None:
    """:class:`MapCorruptError` naming the first problems of a loaded state (see above)."""
    problems = [
        *_entry_problems(state),
        *_temporal_problems(state),
        *_pending_problems(state, arrays),
        *_table_problems(state),
        *_graph_problems(state.graph),
        *_far_problems(state),
        *_meta_problems(state),
    ]
    if problems:
        raise MapCorruptError(
            f"map state is inconsistent: {'; '.join(problems[:3])}"
            + (f" and {len(problems) - 3} more" if len(problems) > 3 else ""),
            hint=MAP_REBUILD_HINT,
        )


def _first_far(name: str, values: np.ndarray, cell_size: float) -> str | None:
    """A problem with finite positions ``values`` beyond the spatial hash's range for
    ``cell_size`` (``spatial_hash.INDEX_MIN`` .. ``INDEX_MAX`` cells from the origin), naming
    the member, the value and its row: no build places anything there (it drops such
    detections as ``out_of_range``), and the queries would hash, group and measure
    distances of garbage (an entry at x = -1e300 grouped by an int64 cast, a pose's
    distance overflowing to inf). None when every position is in range."""
    from aion_cli.engine.spatial_hash import INDEX_MAX, INDEX_MIN

    v = np.asarray(values, np.float64)
    if v.size == 0:
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        scaled = np.floor(v / cell_size)
        far = ~((scaled >= INDEX_MIN) & (scaled <= INDEX_MAX)) & np.isfinite(v)
    if not far.any():
        return None
    flat = int(np.flatnonzero(far.ravel())[0])
    row = np.unravel_index(flat, v.shape)[0]
    return (
        f"{name} holds {v.ravel()[flat]:g} (row {row}), beyond the spatial hash's range "
        f"(±{-INDEX_MIN * cell_size:g} m at cell_size {cell_size:g})"
    )


def _far_problems(state: MapState) -> list[str]:
    """The positions of a loaded state beyond the spatial hash's range (:func:`_first_far`):
    its entries' and its robot poses', which the queries hash, group and measure, and its
    scene graph's places and node table's (positions and reference positions), which a build
    refuses (``ownership.check_graph``: a place may be released into a cell), so no map aion
    writes holds one (stop 71: a map's places were not checked on reading)."""
    size, n = state.config.cell_size, state.entries.n
    members = [("entry_xyz", state.entries.xyz[:n]), ("obs_pose_xy", state.observation.pose_xy)]
    if state.graph is not None:
        members.append(("graph_places_xyz", state.graph.places.xyz))
    members += [("node_xyz", state.nodes.xyz), ("node_ref_xyz", state.nodes.ref_xyz)]
    return [p for name, v in members if (p := _first_far(name, v, size)) is not None]


def _entry_problems(state: MapState) -> list[str]:
    ent, n = state.entries, state.entries.n
    out = [
        p
        for name in ADDITIVE
        if (p := _first_bad(f"entry_{name}", getattr(ent, name)[:n], name not in HEADING_SUMS))
        is not None
    ]
    if (p := _first_bad("entry_xyz", ent.xyz[:n], False)) is not None:
        out.append(p)
    if out:
        return out
    slack = _COUNT_SLACK * max(1.0, float(ent.counts[:n].max(initial=0.0)))
    for part, whole in (("window_counts", "counts"), ("window_nodir", "nodir"),
                        ("speed_n", "counts")):
        row = first_row_over(getattr(ent, part)[:n], getattr(ent, whole)[:n], slack)
        if row is not None:
            out.append(f"entry_{part} exceeds entry_{whole} (row {row})")
    kind = ent.kind[:n]
    cells = kind == CELL
    if (ent.key[:n][cells] < 0).any():
        out.append("a cell entry has a negative spatial-hash key")
    if (ent.node_id[:n][cells] != 0).any():
        out.append("a cell entry carries a node id")
    orphans = ~np.isin(ent.node_id[:n][kind == NODE], state.nodes.ids)
    if orphans.any():
        out.append(f"{int(orphans.sum())} node entries belong to no node of the node table")
    total = ent.total_count()
    if abs(total - state.accepted) > 0.5 + _COUNT_SLACK * max(total, 1.0):
        out.append(f"the entries hold {total:g} detections but the map accepted {state.accepted}")
    return out


#: Temporal members that are sums of counts or of windows (never negative); the others
#: (log-likelihood scores, Fourier sums) need only be finite.
_NONNEGATIVE_TEMPORAL = (
    "cnt_profile", "flow_chi2", "flow_scored", "flow_days", "flow_gain_sq", "dir_scored",
    "dir_days", "dir_gain_sq",
)


def _temporal_problems(state: MapState) -> list[str]:
    t, n = state.temporal, state.entries.n
    out = []
    # cnt_fourier, flow_score and dir_score need only be finite, and cnt_profile finite and
    # non-negative, which TemporalState.from_arrays has checked on the stored members (a
    # second pass over the largest members would cost more than reading them)
    for name in _NONNEGATIVE_TEMPORAL[1:]:
        values = getattr(t, name)[:n]
        if (p := _first_bad(f"temporal_{name}", values, name in _NONNEGATIVE_TEMPORAL)):
            out.append(p)
    for block, rows in (("glob", slice(0, 1)), ("obs", slice(0, n))):
        obs = getattr(t, block)
        for name, nonneg in (("n", True), ("profile", True), ("fourier", False)):
            p = _first_bad(f"temporal_{block}_{name}", getattr(obs, name)[rows], nonneg)
            if p is not None:
                out.append(p)
        first, last, seen = obs.first[rows], obs.last[rows], obs.n[rows] > 0
        bad = (np.isinf(first) | np.isinf(last)
               | (seen & ~(np.isfinite(first) & np.isfinite(last))) | (first > last))
        if bad.any():
            out.append(f"temporal_{block}_first / _last are not an interval of observed time "
                       f"(row {int(np.flatnonzero(bad)[0])})")
    return out


def _pending_problems(state: MapState, arrays: Mapping[str, np.ndarray]) -> list[str]:
    out = []
    values = np.asarray(arrays.get("pending_cnt_values", np.zeros((0, 1))))
    if (p := _first_bad("pending_cnt_values", values, True)) is not None:
        out.append(p)
    windows = state.pending.windows
    if windows:
        w = np.asarray(windows, np.int64)
        days = {state.window_day(int(x)) for x in (w.min(), w.max())}
        if w.min() < 0 or days != {state.pending.day}:
            out.append(f"pending_windows {w.min()}..{w.max()} are not windows of the pending "
                       f"day {state.pending.day}")
        if state.open_window is not None and w.max() >= state.open_window:
            out.append(f"pending window {w.max()} is not before the open window "
                       f"{state.open_window}")
    return out


def _table_problems(state: MapState) -> list[str]:
    out = []
    nodes = state.nodes
    if len(nodes.ids) > 1 and not (nodes.ids[1:] > nodes.ids[:-1]).all():
        out.append("node_ids are not sorted and unique")
    for name in ("xyz", "ref_xyz"):
        if (p := _first_bad(f"node_{name}", getattr(nodes, name), False)) is not None:
            out.append(p)
    red = state.redirects
    if (red.keys < 0).any():
        out.append("a redirected cell has a negative spatial-hash key")
    if not np.isin(red.nodes, nodes.ids).all():
        out.append("a redirect points at a node that is not in the node table")
    obs = state.observation
    if len(obs.pose_t) > 1 and (np.diff(obs.pose_t) < 0).any():
        out.append("obs_pose_t is not sorted")
    if (p := _first_bad("obs_pose_xy", obs.pose_xy, False)) is not None:
        out.append(p)
    if (obs.fixed_end < obs.fixed_start).any():
        out.append("a fixed-sensor interval (obs_fixed_start/_end) ends before it starts")
    return out


def _graph_problems(graph: GraphSnapshot | None) -> list[str]:
    if graph is None:
        return []
    out = []
    for name in ("places", "rooms", "buildings"):
        if (p := _first_bad(f"graph_{name}_xyz", getattr(graph, name).xyz, False)) is not None:
            out.append(p)
    n = len(graph.places.ids)
    if graph.edges.size and (graph.edges.min() < 0 or graph.edges.max() >= n):
        out.append(f"graph_edges refer to places outside 0..{n - 1}")
    mesh = graph.mesh
    if mesh is not None:
        v = len(mesh.vertices)
        if mesh.faces.size and (mesh.faces.min() < 0 or mesh.faces.max() >= v):
            out.append(f"graph_mesh_faces refer to vertices outside 0..{v - 1}")
        if len(mesh.colors) not in (0, v):
            out.append(f"graph_mesh_colors has {len(mesh.colors)} rows for {v} vertices")
        for name in ("vertices", "colors"):
            if (p := _first_bad(f"graph_mesh_{name}", getattr(mesh, name), False)) is not None:
                out.append(p)
    return out


def _meta_problems(state: MapState) -> list[str]:
    out = []
    limit = (2**63 - 1) // state.window_ns
    if state.open_window is not None and not 0 <= state.open_window <= limit:
        out.append(f"the open window {state.open_window} is outside 0..{limit}")
    if state.log_time_ns is not None and not 0 <= state.log_time_ns <= 2**63 - 1:
        out.append(f"the log time {state.log_time_ns} ns is outside 0..2^63-1")
    if state.accepted < 0:
        out.append(f"the map accepted {state.accepted} detections")
    negative = {k: v for k, v in state.dropped.items() if v < 0}
    if negative:
        out.append(f"negative drop counts {negative}")
    return out


def check_ownership(state: MapState) -> None:
    """:class:`MapCorruptError` unless every key and node has exactly one owner."""
    ent = state.entries
    cell_keys = ent.key[ent.cell_rows()]
    node_ids = ent.node_id[ent.node_rows()]
    problems = []
    if not _distinct(cell_keys):
        problems.append("two cell entries share a key")
    if not _distinct(node_ids):
        problems.append("two node entries share a node id")
    if contained(cell_keys, state.redirects.keys).any():
        problems.append("a redirected cell also has an entry")
    if not contained(node_ids, state.redirects.nodes).all():
        problems.append("a redirect points at a node without an entry")
    if problems:
        raise MapCorruptError(f"map state is inconsistent: {'; '.join(problems)}")


def _distinct(values: np.ndarray) -> bool:
    """Whether no value repeats: a map read back holds its keys in canonical (increasing)
    order, which one comparison of neighbours proves; anything else is sorted first."""
    if values.size < 2:
        return True
    if not bool(np.all(values[1:] > values[:-1])):
        values = np.sort(values)
        return bool(np.all(values[1:] != values[:-1]))
    return True
