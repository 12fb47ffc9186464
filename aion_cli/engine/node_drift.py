"""How far the nodes of a shard's first scene graph moved before their timers first restarted:
what a join needs to give them the stability timers one pass gives them.

A node's stability timer (:class:`~aion_cli.engine.nodes.NodeTable`) restarts when the node
moves farther than ``stable_move_tolerance`` from its *reference* position, or leaves the
graph. A shard (:mod:`aion_cli.engine.shards`) starts with an empty node table, so it judges
its nodes' moves against their positions in its own first graph; one pass judges them against
the references the map before the shard ended with. Where the two disagree about a restart,
the timers differ. :class:`NodeDrift` keeps, for every node of the shard's first graph, the
box its positions stayed in until its timer first restarted in the shard, and when and where
that restart happened; :func:`join_timers` then decides, for each node the earlier map also
holds, whether one pass kept the earlier timer, restarted exactly where the shard did, or
might have restarted elsewhere (:func:`timers_blocker`: the join is refused, and the shard is
learnt in sequence). Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.types import F64, I64, U64, BoolA
from aion_cli.errors import MapCorruptError

if TYPE_CHECKING:
    from aion_cli.engine.nodes import NodeTable

#: the arrays of a part map (``aion build --part``) that hold a :class:`NodeDrift`
_MEMBERS = ("ids", "first_xyz", "low", "high", "restart_ns", "restart_xyz")


@dataclass
class NodeDrift:
    """For the nodes of a shard's first graph (applied at ``t0_ns``; ``ids`` sorted): their
    positions there (``first_xyz``), the box [``low``, ``high``] of every position until their
    timer first restarted in the shard (or until now), and that restart's log time
    (``restart_ns``, −1: none yet) and reference position (``restart_xyz``; NaN where the node
    restarted by leaving the graph)."""

    t0_ns: int
    ids: U64
    first_xyz: F64
    low: F64
    high: F64
    restart_ns: I64
    restart_xyz: F64

    @classmethod
    def start(cls, table: NodeTable, t_ns: int) -> NodeDrift:
        """The drift of the nodes of a shard's first graph, ``table`` (every timer at ``t_ns``)."""
        n = len(table)
        return cls(
            int(t_ns),
            table.ids.copy(),
            table.xyz.copy(),
            table.xyz.copy(),
            table.xyz.copy(),
            np.full(n, -1, np.int64),
            np.full((n, 3), np.nan),
        )

    def observe(self, table: NodeTable, t_ns: int) -> None:
        """The node table after a later graph at ``t_ns``: nodes whose timer has not restarted
        yet either restarted now (moved beyond the tolerance, so their timer is no longer the
        first graph's; or gone) or widen their box by their position."""
        waiting = np.flatnonzero(self.restart_ns < 0)
        if waiting.size == 0:
            return
        if len(table) == 0:  # every node left the graph
            self.restart_ns[waiting] = int(t_ns)
            return
        ids = self.ids[waiting]
        at = np.minimum(np.searchsorted(table.ids, ids), len(table) - 1)
        present = table.ids[at] == ids
        moved = present & (table.stable_since_ns[at] != self.t0_ns)
        gone = waiting[~present]
        self.restart_ns[gone] = int(t_ns)
        restarted = waiting[moved]
        self.restart_ns[restarted] = table.stable_since_ns[at[moved]]
        self.restart_xyz[restarted] = table.ref_xyz[at[moved]]
        still = present & ~moved
        rows, xyz = waiting[still], table.xyz[at[still]]
        self.low[rows] = np.minimum(self.low[rows], xyz)
        self.high[rows] = np.maximum(self.high[rows], xyz)

    # -- persistence (a part map) ----------------------------------------------------------
    def to_arrays(self, prefix: str) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Members ``{prefix}{name}`` and the meta (the first graph's time)."""
        arrays = {f"{prefix}{name}": getattr(self, name).copy() for name in _MEMBERS}
        return arrays, {"t0_ns": self.t0_ns}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], meta: Any, prefix: str) -> NodeDrift:
        """Inverse of :meth:`to_arrays` (:class:`MapCorruptError` for inconsistent input)."""
        missing = [f"{prefix}{name}" for name in _MEMBERS if f"{prefix}{name}" not in arrays]
        if missing or not isinstance(meta, dict) or "t0_ns" not in meta:
            raise MapCorruptError(f"node drift incomplete, missing: {missing or ['t0_ns']}")
        ids = np.asarray(arrays[f"{prefix}ids"], np.uint64).reshape(-1)
        n = ids.size
        boxes = [
            np.asarray(arrays[f"{prefix}{name}"], np.float64)
            for name in ("first_xyz", "low", "high", "restart_xyz")
        ]
        restart = np.asarray(arrays[f"{prefix}restart_ns"], np.int64).reshape(-1)
        if any(b.shape != (n, 3) for b in boxes) or restart.shape != (n,):
            raise MapCorruptError("node drift arrays do not match their ids")
        if n > 1 and not bool(np.all(ids[1:] > ids[:-1])):
            raise MapCorruptError("node drift ids are not sorted and unique")
        first, low, high, restart_xyz = boxes
        return cls(int(meta["t0_ns"]), ids, first, low, high, restart, restart_xyz)


@dataclass(frozen=True)
class TimerVerdicts:
    """Per node of the shard's final table (``rows``, in its order): which one pass keeps
    the earlier map's timer and reference for (``keep_earlier``), and which it might have
    judged otherwise than both the shard and the earlier map (``unknown``)."""

    keep_earlier: BoolA
    unknown: BoolA
    earlier_at: I64


def timer_verdicts(
    later: NodeTable, earlier: NodeTable, drift: NodeDrift, tolerance: float
) -> TimerVerdicts:
    """For each node of ``later`` (the shard's final table) that ``earlier`` (the map before
    it) ends with and the shard's first graph had (``drift``), what one pass did:

    * its first position lay beyond ``tolerance`` from the earlier reference: one pass
      restarted the timer there, at the shard's first graph, as the shard did (shard's);
    * else, if every position until the shard's first restart lay within ``tolerance`` of
      the earlier reference (the farthest corner of the drift box does): one pass kept the
      earlier timer that long. Never restarted in the shard: the earlier timer and reference
      (``keep_earlier``). Restarted by leaving the graph: one pass too (shard's). Restarted by
      a move to a position beyond ``tolerance`` of the earlier reference: one pass too, at the
      same graph, with the same reference (shard's); within it: one pass did not (unknown);
    * else one pass may have restarted at another graph (unknown).
    Nodes new to one of the two maps, or to the shard's first graph, are the shard's."""
    n = len(later)
    none = np.zeros(n, bool)
    if n == 0 or len(earlier) == 0 or drift.ids.size == 0:
        return TimerVerdicts(none, none.copy(), np.zeros(n, np.int64))
    at = np.minimum(np.searchsorted(earlier.ids, later.ids), len(earlier) - 1)
    dr = np.minimum(np.searchsorted(drift.ids, later.ids), drift.ids.size - 1)
    both = (earlier.ids[at] == later.ids) & (drift.ids[dr] == later.ids)
    ref = earlier.ref_xyz[at]
    first_near = np.linalg.norm(drift.first_xyz[dr] - ref, axis=1) <= tolerance
    corner = np.maximum(np.abs(drift.low[dr] - ref), np.abs(drift.high[dr] - ref))
    box_near = np.linalg.norm(corner, axis=1) <= tolerance
    restart_ns, restart_xyz = drift.restart_ns[dr], drift.restart_xyz[dr]
    by_move = (restart_ns >= 0) & np.isfinite(restart_xyz).all(axis=1)
    move_near = by_move & (
        np.linalg.norm(np.where(by_move[:, None], restart_xyz, 0.0) - ref, axis=1) <= tolerance
    )
    judged = both & first_near
    keep = judged & box_near & (restart_ns < 0)
    unknown = judged & (~box_near | move_near)
    return TimerVerdicts(keep, unknown, at)


def timers_blocker(
    later: NodeTable, earlier: NodeTable, drift: NodeDrift | None, tolerance: float
) -> str | None:
    """Why the shard's node timers cannot be joined exactly (None: they can, or the shard
    kept no drift, as part maps of older versions: :func:`join_timers` then approximates)."""
    if drift is None:
        return None
    verdicts = timer_verdicts(later, earlier, drift, tolerance)
    count = int(verdicts.unknown.sum())
    if count == 0:
        return None
    return (
        f"{count} place(s) of these logs drifted about the stability tolerance from where the "
        "map before them had them, so one pass may have restarted their stability timers at "
        "other times"
    )


def join_timers(
    later: NodeTable, earlier: NodeTable, drift: NodeDrift | None, tolerance: float
) -> BoolA:
    """Give ``later``'s nodes (the shard's, changed in place) the timers and references one
    pass gives them (:func:`timer_verdicts`; a node whose verdict is unknown keeps the
    shard's, which :func:`timers_blocker` refuses first). Without ``drift``: the
    approximation of :func:`approximate_timers`. Returns the nodes that took the earlier
    map's timer."""
    if drift is None:
        return approximate_timers(later, earlier, tolerance)
    verdicts = timer_verdicts(later, earlier, drift, tolerance)
    keep, at = verdicts.keep_earlier, verdicts.earlier_at
    later.stable_since_ns[keep] = earlier.stable_since_ns[at[keep]]
    later.ref_xyz[keep] = earlier.ref_xyz[at[keep]]
    later.quiet = None  # its timers changed in place (NodeTable.quiet)
    return keep


def approximate_timers(later: NodeTable, earlier: NodeTable, tolerance: float) -> BoolA:
    """Nodes in both tables whose references lie within ``tolerance`` and whose timer in
    ``later`` never restarted (it started at ``later``'s first graph) keep the earlier timer
    and reference. A node of ``later`` whose timer started after ``later``'s earliest one
    restarted inside ``later``'s time (it moved beyond the tolerance there, or came back after
    leaving the graph): one pass restarted it too, so it keeps its own timer and reference,
    even where that reference lies near the earlier one (a node that drifted and was
    re-referenced). Not exact in every case: one pass judges ``later``'s moves against the
    earlier reference, ``later`` against its own first position, and where they disagree
    about a restart the timers differ (docs/SCALING.md); counts and the temporal state do not.
    What merging two ordinary maps does (they keep no drift), and joining a part map of an
    older version. Returns the nodes that took the earlier timer."""
    n = len(later)
    if len(earlier) == 0 or n == 0:
        return np.zeros(n, bool)
    ids = later.ids
    at = np.minimum(np.searchsorted(earlier.ids, ids), len(earlier) - 1)
    both = earlier.ids[at] == ids
    near = np.linalg.norm(later.ref_xyz - earlier.ref_xyz[at], axis=1) <= tolerance
    since = later.stable_since_ns
    unbroken = since == since.min()  # stable since later's first graph
    keep: BoolA = both & near & unbroken
    later.stable_since_ns[keep] = np.minimum(since[keep], earlier.stable_since_ns[at[keep]])
    later.ref_xyz[keep] = earlier.ref_xyz[at[keep]]
    later.quiet = None  # its timers changed in place (NodeTable.quiet)
    return keep


__all__ = [
    "NodeDrift",
    "TimerVerdicts",
    "approximate_timers",
    "join_timers",
    "timer_verdicts",
    "timers_blocker",
]
