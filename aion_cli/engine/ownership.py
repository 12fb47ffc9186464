"""Temporal ownership transfer (paper §III-D, DESIGN.md §4), with the reference code's bugs fixed.

* **Bind** (:func:`bind_cells`): every live cell entry whose centre has a *stable* node (present
  and within ``stable_move_tolerance`` of its reference position for ``stability_s`` of log time)
  within ``bind_radius`` horizontally and ``bind_vertical_tolerance`` vertically moves into the
  nearest such node's entry: counts, open-window counts, speed sums, temporal rows (``add_rows``:
  counts and scores add) are ADDED to what the node has (never overwritten), the observation
  with more windows is kept (same time span); the cell entry is deleted and
  φ(cell key) = node id is recorded, so later detections there go to the node.
* **Move** (:func:`apply_graph`): a node present in the new snapshot keeps its entry; the
  entry's position follows the node (a loop closure carries the dynamics along).
* **Release** (:func:`release_nodes`): the entry of a node absent from the new snapshot goes
  back to the hash cell at its last position — added to the live cell entry there, or a new one;
  if that cell is redirected to another (live) node, the state follows the redirect like a
  detection would — and every redirect to the released node is dropped.

Pairs are applied in a canonical order (cells by key, nodes by id) so floating-point sums do not
depend on the internal row layout. Uses 2D (horizontal) distances plus a vertical tolerance
throughout, a real per-cell redirect table, and a per-node stability timer.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.entries import CELL, NODE
from aion_cli.engine.nearest import BindIndex, nearest_nodes
from aion_cli.engine.node_drift import NodeDrift
from aion_cli.engine.node_ids import node_label
from aion_cli.engine.nodes import QuietCheck
from aion_cli.engine.spatial_hash import (
    cell_centres,
    cell_indices,
    keys_for_points,
    packable_mask,
    unpack_keys,
)
from aion_cli.engine.temporal.groups import sorted_group_keys
from aion_cli.engine.types import F64, I64, U64, BoolA, GraphSnapshot
from aion_cli.errors import CoordinateRangeError

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def check_graph(snapshot: GraphSnapshot, cell_size: float) -> None:
    """Node positions must be finite and hashable (a node may be released into a cell)."""
    xyz = np.asarray(snapshot.places.xyz, dtype=np.float64).reshape(-1, 3)
    bad = ~packable_mask(xyz, cell_size)
    if bad.any():
        rows = np.flatnonzero(bad)
        more = f" (and {len(rows) - 1:,} more)" if len(rows) > 1 else ""

        def name_of(_: int) -> str:
            return f"scene-graph place {node_label(snapshot.places.ids[rows[0]])}{more}"

        try:  # raises with the coordinate and the place named
            cell_indices(xyz[rows[0] : rows[0] + 1], cell_size, name_of)
        except CoordinateRangeError as exc:
            exc.hint = (
                "the scene graph's positions are damaged or not in metres: check it "
                "(aion info GRAPH) or build without it (--derive-graph)"
            )
            raise
        raise CoordinateRangeError(f"{name_of(0)} has an invalid position")


def apply_graph(state: MapState, snapshot: GraphSnapshot) -> None:
    """Take a new graph snapshot: update timers, move node entries, release vanished nodes.

    A snapshot that carries the very place layer of the graph applied before (the same
    object: a payload byte-identical to the last one, whose decoded graph the feed reuses
    with a new time) changes nothing but the graph's time: no node moved, appeared or
    vanished, and the timers run on by themselves."""
    previous = state.graph
    if (
        previous is not None
        and snapshot.places is previous.places
        and (state.deferred is None or state.deferred.first_graph is not None)
    ):
        state.graph = snapshot
        return
    cfg = state.config
    check_graph(snapshot, cfg.cell_size)
    table, _gone = state.nodes.updated(
        snapshot.places.ids, snapshot.places.xyz, int(snapshot.t_ns), cfg.stable_move_tolerance
    )
    state.nodes = table
    state.graph = snapshot
    held = state.deferred
    if held is not None:  # for the join (engine.shards)
        if held.first_graph is None:
            held.first_graph = snapshot.places.ids.copy()
            held.drift = NodeDrift.start(table, int(snapshot.t_ns))
        elif held.drift is not None:
            held.drift.observe(table, int(snapshot.t_ns))
        if held.group_keys is not None:
            held.graph_groups(sorted_group_keys(snapshot.places, cfg.pool_size))
    rows = state.entries.node_rows()
    ids = state.entries.node_id[rows]
    memo = table.entry_at
    if memo is not None and np.array_equal(memo[0], rows) and np.array_equal(memo[1], ids):
        state.entries.xyz[rows] = table.xyz[memo[2]]  # every node entry's node is present
        return
    pos = np.minimum(np.searchsorted(table.ids, ids), max(len(table) - 1, 0))
    present = (table.ids[pos] == ids) if len(table) else np.zeros(len(ids), bool)
    state.entries.xyz[rows[present]] = table.xyz[pos[present]]
    if present.all():
        table.entry_at = (rows, ids, pos)
    release_nodes(state, rows[~present])


def release_nodes(state: MapState, rows: I64) -> None:
    """Release node entries ``rows`` into the hash cells at their last positions."""
    if len(rows) == 0:
        return
    rows = rows[np.argsort(state.entries.node_id[rows], kind="stable")]
    state.redirects.drop_nodes(state.entries.node_id[rows])
    keys = keys_for_points(state.entries.xyz[rows], state.config.cell_size)
    dst = rows_for_keys(state, keys)
    state.move(rows, dst)
    state.rebuild_routes()


@dataclass(frozen=True)
class BindPlan:
    """Cells to bind (rows in key order) and the nodes they go to (ids and positions)."""

    cells: I64
    node_ids: U64
    node_xyz: F64
    memo: BindIndex | None = field(default=None, compare=False, repr=False)
    """The memo of the check that planned them with every cell in sight (:func:`plan_binds`):
    once they are bound, every cell left is one that check found unbound with these nodes,
    which the memo is told (None: a plan of some cells only)."""


def plan_binds(state: MapState, t_ns: int) -> BindPlan | None:
    """The binds a check at log time ``t_ns`` would make (None if none); no state changes
    (beyond the node table's memos of earlier checks: :class:`~aion_cli.engine.nodes.
    QuietCheck`, which answers a check that sees the stable nodes and the cells of one that
    planned nothing, and :class:`~aion_cli.engine.nearest.BindIndex`, which makes the answer
    cost the cells that are new since the last check, not every cell)."""
    cfg = state.config
    nodes = state.nodes
    stability_ns = round(cfg.stability_s * 1e9)
    params = (float(cfg.bind_radius), float(cfg.bind_vertical_tolerance))
    version = state.entries.cells_version
    held = state.deferred
    quiet = nodes.quiet
    if (
        quiet is not None
        and held is None  # a shard's check also records what it saw
        and quiet.covers(nodes.stable_since_ns, stability_ns, params, int(t_ns), version)
    ):
        return None
    stable = nodes.stable_mask(t_ns, stability_ns)

    def planned_none(cells_version: int | None) -> None:
        """Remember this check's answer, nothing to bind (:class:`QuietCheck`)."""
        start, end = nodes.stable_span(stable, stability_ns)
        since = nodes.stable_since_ns
        nodes.quiet = QuietCheck(since, stability_ns, params, start, end, cells_version)

    if held is not None and stable.any():  # a shard: where its stable places reached
        held.checked_stable(state.nodes.ids[stable], state.nodes.xyz[stable])
    if held is not None and held.first_stable is None:  # a shard, for the join (engine.shards)
        if stable.any():  # the first stable nodes it bound to
            held.remember_stable(state.nodes.ids[stable], state.nodes.xyz[stable])
        elif len(state.nodes):  # the cells near places not yet stable
            rows = state.entries.cell_rows()
            near = nearest_nodes(
                state.entries.xyz[rows],
                state.nodes.xyz,
                cfg.bind_radius,
                cfg.bind_vertical_tolerance,
            )
            held.reached_unstable(state.entries.key[rows[near >= 0]])
    if not stable.any():
        planned_none(None)
        return None
    xyz = nodes.xyz[stable]
    index = nodes.bind_index
    cells: I64 | None = None
    if index is not None:
        unbound = index.unbound_at(xyz, cfg.bind_radius, cfg.bind_vertical_tolerance)
        # the usual check (most of a build's): nothing changed since one that bound none,
        # known before the cells are listed (that check had cells: the same version has the
        # same); or only cells were added since (a window's new detections): only they can
        # bind, the others were seen unbound with the same nodes (issue 15: not every cell)
        if unbound == version:
            planned_none(version)
            return None
        if unbound is not None:
            cells = state.entries.cells_added_since(unbound)
            if cells is not None and cells.size == 0:
                index.bound_none(version)
                planned_none(version)
                return None
    if cells is None:
        cells = state.entries.cell_rows()
    if len(cells) == 0:
        planned_none(version)
        return None
    if index is None:
        index = nodes.bind_index = BindIndex()
    hit = index.nearest(
        cells,
        state.entries.key,
        state.entries.xyz,
        xyz,
        cfg.bind_radius,
        cfg.bind_vertical_tolerance,
    )
    bound = hit >= 0
    if not bound.any():
        index.bound_none(version)
        planned_none(version)
        return None
    cells, hit = cells[bound], hit[bound]
    order = np.argsort(state.entries.key[cells], kind="stable")  # canonical: by cell key
    cells, hit = cells[order], hit[order]
    return BindPlan(cells, nodes.ids[stable][hit], xyz[hit], index)


def plan_binds_plain(state: MapState, t_ns: int) -> BindPlan | None:
    """:func:`plan_binds` without the memo: every cell queried against a new KD-tree (the
    reference the memo is tested against)."""
    cfg = state.config
    stable = stable_nodes(state, t_ns)
    cells = state.entries.cell_rows()
    if not stable.any() or len(cells) == 0:
        return None
    cells = cells[np.argsort(state.entries.key[cells], kind="stable")]
    ids, xyz = state.nodes.ids[stable], state.nodes.xyz[stable]
    hit = nearest_nodes(state.entries.xyz[cells], xyz, cfg.bind_radius, cfg.bind_vertical_tolerance)
    bound = hit >= 0
    if not bound.any():
        return None
    return BindPlan(cells[bound], ids[hit[bound]], xyz[hit[bound]])


def apply_binds(state: MapState, plan: BindPlan) -> None:
    """Move the planned cells into their nodes' entries and record the redirects.

    The route table is updated in place (``RouteTable.reroute``): the moved cells' keys now
    lead to their nodes' rows, and nothing else changes (no other entry moves, node rows are
    new or kept), which is what rebuilding it from the live cells and the redirects gives
    (:func:`apply_binds_plain`; tested equal). Where the table does not route the moved keys
    to the moved cells (it was not current), it is rebuilt."""
    _apply_binds(state, plan, reroute=True)


def apply_binds_plain(state: MapState, plan: BindPlan) -> None:
    """:func:`apply_binds` rebuilding the whole route table (the reference it is tested
    against)."""
    _apply_binds(state, plan, reroute=False)


def _apply_binds(state: MapState, plan: BindPlan, reroute: bool) -> None:
    dst = node_rows_creating(state, plan.node_ids, plan.node_xyz)
    keys = state.entries.key[plan.cells].copy()
    state.move(plan.cells, dst)
    state.redirects.add(keys, plan.node_ids)
    if not (reroute and state.routes.reroute(keys, plan.cells, dst)):
        state.rebuild_routes()
    if plan.memo is not None:  # the cells left were all seen unbound (BindPlan.memo)
        plan.memo.bound_none(state.entries.cells_version)


def unentered_stable_nodes(state: MapState, t_ns: int) -> I64:
    """Node-table indices of the nodes stable at log time ``t_ns`` without an entry yet,
    while a robot trajectory says what was observed (none under a fixed sensor alone: its
    windows count for every entry, created later or not). :func:`enter_observed_nodes`
    enters them when the robot first observes them."""
    if state.observation.pose_t.size == 0:
        return np.zeros(0, np.int64)
    stable = np.flatnonzero(stable_nodes(state, t_ns))
    if stable.size == 0:
        return stable
    out: I64 = stable[state.node_entry_rows(state.nodes.ids[stable]) < 0]
    return out


def enter_observed_nodes(state: MapState, waiting: I64, observed: BoolA) -> I64:
    """Give the nodes ``waiting[observed]`` (node-table indices) empty entries, so the window
    the robot first observes a stable place in, and every later one, count for it with nobody
    seen there too; returns the nodes still waiting. Without it a place's entry began with
    its first detection, and every window the robot had watched it empty before was lost
    (its rate per observed window came out too high)."""
    new = waiting[observed]
    if new.size:
        node_rows_creating(state, state.nodes.ids[new], state.nodes.xyz[new])
    rest: I64 = waiting[~observed]
    return rest


def bind_cells(state: MapState, t_ns: int) -> int:
    """Bind every cell that has a stable node nearby at log time ``t_ns``; returns how many."""
    plan = plan_binds(state, t_ns)
    if plan is None:
        return 0
    apply_binds(state, plan)
    return len(plan.cells)


def stable_nodes(state: MapState, t_ns: int) -> BoolA:
    """Mask over the node table: nodes stable for ``stability_s`` at log time ``t_ns``."""
    return state.nodes.stable_mask(t_ns, round(state.config.stability_s * 1e9))


def node_rows_creating(state: MapState, node_ids: U64, xyz: np.ndarray) -> I64:
    """Entry rows of nodes, creating empty node entries for nodes that have none."""
    rows = state.node_entry_rows(node_ids)
    missing = rows < 0
    if missing.any():
        new_ids, first = np.unique(node_ids[missing], return_index=True)
        new_xyz = xyz[missing][first]
        state.allocate(NODE, np.full(len(new_ids), -1, np.int64), new_ids, new_xyz)
        rows = state.node_entry_rows(node_ids)
    return rows


def rows_for_keys(state: MapState, keys: I64) -> I64:
    """Where state arriving at cell ``keys`` belongs: a redirect's node entry, the live cell
    entry, or a new cell entry (created here)."""
    state.rebuild_routes()

    def create(new_keys: I64) -> I64:
        centres = cell_centres(new_keys, state.config.cell_size)
        return state.allocate(CELL, new_keys, np.zeros(len(new_keys), np.uint64), centres)

    return state.routes.route(keys, unpack_keys(keys), create)
