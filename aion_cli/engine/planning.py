"""A* over the navigational layer with the Aion temporal traversal cost.

Cost (the paper, section IV "Planning"), for travelling the edge from node i to node j::

    cost(i, j) = d + (c̄_t + c_d(i, j)) · d

- ``d`` is the Euclidean (3-D) distance between the nodes.
- ``c_t(n) = (plan_w_entropy · H_n + plan_w_flow) · f_n`` per node, with ``H_n`` the normalised
  directional entropy (0..1) and ``f_n = min(F_n / plan_flow_scale, 1)`` the busy-ness, ``F_n``
  the predicted flow in expected detections per window. ``c̄_t`` is the mean over i and j.
  Entropy weighs as much as the place is busy: the paper's "variability of activity" is
  people's, and a place nobody walks (whose forecast directions are its prior's, spread) has
  none; weighed in full, it made plans in an empty building at night detour around places
  nobody was at (before 2026-12-06).
- ``c_d(i, j)`` is the mean over i and j of the per-node directional penalty
  ``plan_w_direction · (1 − cos(α − θ_n)) / 2 · κ_n · f_n``, with ``α`` the horizontal travel
  direction of the edge (i -> j), ``θ_n`` the node's mean flow direction (the circular mean
  of its direction histogram) and ``κ_n`` its concentration (that mean's resultant length,
  0..1): ``κ_n (1 − cos(α − θ_n))`` is ``κ_n`` minus the mean flow vector along the edge.
  Walking against a concentrated busy flow costs the most (``w_direction``), walking with it
  costs nothing, crossing it half; in a corridor walked both ways alike (κ ≈ 0) neither way
  costs more. A node without
  flow (NaN angle / entropy) contributes no penalty; a purely vertical edge has no direction.

Every term is >= 0, so ``cost(i, j) >= d(i, j)``: the Euclidean heuristic is admissible and
consistent, and the distance-only plan is the special case with every penalty zero. The cost
never uses a probability directly (no zero-probability infinities: entropy and concentration are
already floored/bounded by the descriptors). Unlike the reference implementation we use no hidden
factors (its ×3, caps at 10 and 5, 0.7/0.3 node weights, extra ``2H`` terms): the three weights
and the flow scale are the config's ``plan_*`` parameters.

Beyond the paper, costs are time-dependent: a node's costs come from ``node_cost(t_s)`` evaluated
at its estimated arrival time ``depart_s + g_distance / speed`` (``g_distance`` = path length
from the start along the best-cost path found so far). ``node_cost`` is evaluated once per time
bucket (default the model window ``config.window_s``, aligned as the map's windows are to the
UNIX epoch; a bucket is evaluated at its start, or at the departure time for the departure
bucket), and the per-edge cost terms of a bucket are
computed for the whole graph with numpy, so the Python A* loop only adds numbers. A node is
settled once, with the arrival time of its best-cost path (label-setting; exact for static
costs, a standard approximation of the time-dependent shortest path otherwise).
"""

from __future__ import annotations

import heapq
import math
from array import array
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.nav_graph import Arcs, NavGraph, NavGraphError
from aion_cli.engine.node_ids import node_label
from aion_cli.engine.windows import EPOCH_NS
from aion_cli.errors import AionError, InputError, NoPathError

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
U64 = npt.NDArray[np.uint64]



class NodeCostError(AionError):
    """``node_cost`` returned arrays of the wrong shape (a caller bug, not a user error)."""


@dataclass(frozen=True)
class NodeCosts:
    """Per-node dynamics at one time, the inputs of the temporal cost (all float64[m]).

    ``entropy`` normalised directional entropy 0..1 (NaN = no flow), ``flow_per_window``
    expected detections per window (raw: the planner normalises by ``plan_flow_scale``),
    ``mean_angle`` radians, the circular mean of the direction histogram (NaN = no flow),
    ``concentration`` its mean resultant length 0..1. These are the fields of the engine's
    ``Descriptors`` with the same meaning (not its ``dominant_angle``, the most frequent
    direction: in a corridor walked both ways the penalty follows the mean flow vector, which
    is short there).
    """

    entropy: F64
    flow_per_window: F64
    mean_angle: F64
    concentration: F64

    @classmethod
    def zeros(cls, m: int) -> NodeCosts:
        """No flow anywhere: every penalty is zero (the distance-only costs)."""
        nan = np.full(m, np.nan)
        return cls(nan, np.zeros(m), nan.copy(), np.zeros(m))


@dataclass(frozen=True)
class PlanResult:
    """A planned path. ``path`` are row indices into the graph, ``path_ids`` their node ids,
    ``arrival_s`` the estimated arrival time at each path node (model seconds), ``cost`` the
    total traversal cost (metres-equivalent; equals ``length_m`` for a distance-only plan),
    ``expanded`` the number of nodes A* settled, ``walked_m`` the path length from the start
    to each path node (``arrival_s - depart_s`` times the speed, without the float rounding of
    model seconds: nanosecond arrival times are counted from it)."""

    path: I64
    path_ids: U64
    arrival_s: F64
    length_m: float
    duration_s: float
    cost: float
    expanded: int
    walked_m: F64


# -- cost terms ------------------------------------------------------------------------------


def _checked(costs: NodeCosts, m: int) -> tuple[F64, F64, F64, F64]:
    """Validated copies with NaN -> no flow, bounded to their ranges."""
    arrays = (costs.entropy, costs.flow_per_window, costs.mean_angle, costs.concentration)
    out = []
    for name, a in zip(("entropy", "flow", "angle", "concentration"), arrays, strict=True):
        arr = np.asarray(a, dtype=np.float64)
        if arr.shape != (m,):
            raise NodeCostError(f"node_cost {name} must have shape ({m},), got {arr.shape}")
        out.append(arr)
    entropy = np.clip(np.nan_to_num(out[0], nan=0.0), 0.0, 1.0)
    flow = np.nan_to_num(out[1], nan=0.0, posinf=0.0, neginf=0.0).clip(min=0.0)
    conc = np.clip(np.nan_to_num(out[3], nan=0.0), 0.0, 1.0)
    return entropy, flow, out[2], conc


def node_terms(costs: NodeCosts, m: int, config: ModelConfig) -> tuple[F64, F64, F64]:
    """Per node: ``c_t``, the directional weight ``w_d · κ · f`` and the mean flow angle."""
    entropy, flow, angle, conc = _checked(costs, m)
    busy = np.minimum(flow / config.plan_flow_scale, 1.0)
    c_t = (config.plan_w_entropy * entropy + config.plan_w_flow) * busy
    dir_weight = config.plan_w_direction * conc * busy
    return c_t, dir_weight, angle


def arc_halves(graph: NavGraph, costs: NodeCosts, config: ModelConfig) -> tuple[F64, F64]:
    """Per arc, the source node's and the destination node's half of the cost multiplier.

    ``cost(arc) = length · (1 + src_half[arc] + dst_half[arc])`` where ``src_half`` uses the
    source node's costs and ``dst_half`` the destination's (they may come from different time
    buckets). Each half is ``(c_t(n) + pen(n, α)) / 2``.
    """
    arcs = graph.arcs
    c_t, dir_weight, angle = node_terms(costs, len(graph), config)

    def half(nodes: I64) -> F64:
        theta = angle[nodes]
        opposed = (1.0 - np.cos(arcs.alpha - theta)) / 2.0
        pen = np.where(np.isfinite(opposed), opposed * dir_weight[nodes], 0.0)
        return 0.5 * (c_t[nodes] + pen)

    return half(arcs.src), half(arcs.dst)


def arc_costs(graph: NavGraph, costs: NodeCosts | None, config: ModelConfig) -> F64:
    """Static cost of every arc (``graph.arcs`` order) with one set of node costs."""
    if costs is None:
        return graph.arcs.length.copy()
    src_half, dst_half = arc_halves(graph, costs, config)
    return graph.arcs.length * (1.0 + src_half + dst_half)


NodeCostFn = Callable[[float], NodeCosts]


class _BucketTables:
    """``node_cost`` evaluated once per time bucket, turned into per-arc cost terms."""

    def __init__(
        self,
        graph: NavGraph,
        node_cost: NodeCostFn,
        config: ModelConfig,
        depart_s: float,
        speed: float,
        bucket_s: float,
    ) -> None:
        self.graph, self.node_cost, self.config = graph, node_cost, config
        self.depart_s, self.speed, self.bucket_s = depart_s, speed, bucket_s
        self.tables: dict[int, tuple[F64, F64, array[float]]] = {}
        # Buckets are the map's windows, aligned to the UNIX epoch, not to the model epoch
        # (model seconds count from EPOCH_NS, which a window such as 700 s does not divide):
        # bucket b starts at model second b·bucket_s − phase.
        self.phase = math.fmod(EPOCH_NS / 1e9, bucket_s)
        # bucket(d) = floor(t0 + d·k): the A* loop inlines this exact formula.
        self.t0 = (depart_s + self.phase) / bucket_s
        self.k = 1.0 / (speed * bucket_s)

    def bucket(self, distance: float) -> int:
        """Time bucket of arrival after walking ``distance`` metres from the start."""
        return math.floor(self.t0 + distance * self.k)

    def eval_time(self, bucket: int) -> float:
        return max(bucket * self.bucket_s - self.phase, self.depart_s)

    def get(self, bucket: int) -> tuple[F64, F64, array[float]]:
        """``(src_half, dst_half, full)`` per arc for ``bucket``; ``full`` (a packed array, for
        the hot loop) is the arc cost when both ends fall in this bucket, the common case; the
        halves stay arrays, read only for arcs that cross into the next bucket."""
        table = self.tables.get(bucket)
        if table is None:
            costs = self.node_cost(self.eval_time(bucket))
            src_half, dst_half = arc_halves(self.graph, costs, self.config)
            full = self.graph.arcs.length * (1.0 + src_half + dst_half)
            # a packed array, not a list: as fast to index in the A* loop, but 8 bytes per arc
            # instead of a float object and a pointer (32), times every bucket a slow walk
            # crosses (a 10^5-place map at 0.02 m/s: 53 buckets, 1.6 GB before, 0.9 GB now)
            packed = array("d")
            packed.frombytes(full.tobytes())
            table = (src_half, dst_half, packed)
            self.tables[bucket] = table
        return table


def _check_motion(speed: float, depart_s: float, bucket_s: float) -> None:
    if not (math.isfinite(speed) and speed > 0):
        raise InputError(
            f"speed must be a positive number of m/s, got {speed!r}",
            hint="a walking speed such as 1.0 (the default)",
        )
    if not math.isfinite(depart_s):
        raise InputError(f"departure time must be finite, got {depart_s!r}")
    if not (math.isfinite(bucket_s) and bucket_s > 0):
        raise InputError(f"time bucket must be positive seconds, got {bucket_s!r}")


# -- search ----------------------------------------------------------------------------------


def no_path_error(graph: NavGraph, start: int, goal: int) -> NoPathError:
    """The error of rows ``start`` and ``goal`` not connected: the graph's components, the
    places the start reaches (or the radius its places were joined within)."""
    labels = graph.components
    sizes = np.bincount(labels)
    n_comp = len(sizes)

    def describe(row: int) -> str:
        comp = labels[row]
        return f"{node_label(int(graph.ids[row]))} is in a component of {sizes[comp]} node(s)"

    if graph.joined_within is not None:  # no place edges: the radius made them
        hint = (
            "the scene graph has no place edges, so its places were joined within "
            f"plan_connect_radius = {graph.joined_within:g} m: rebuild the map with a larger "
            "one (aion build --config FILE with a line plan_connect_radius = ...)"
        )
    else:
        shown = 6
        held = np.flatnonzero(labels == labels[start])
        held = held[held != start]
        examples = ", ".join(node_label(int(graph.ids[r])) for r in held[:shown])
        more = ", ..." if len(held) > shown else ""
        hint = (
            f"pick a goal in the start's component: {examples}{more}"
            if len(held)
            else "the start has no edge to any other place: pick a start in the goal's component"
        )
    return NoPathError(
        f"no path from {node_label(int(graph.ids[start]))} to {node_label(int(graph.ids[goal]))}:"
        f" the graph has {n_comp} disconnected components; {describe(start)}, {describe(goal)}",
        hint=hint,
    )


_Search = tuple[list[float], list[float], list[int], bytearray, int]


def _astar(arcs: Arcs, h: list[float], s: int, goal: int, tables: _BucketTables | None) -> _Search:
    """Label-setting A* on plain Python lists (the hot loop: no numpy per step).

    Returns per node the best cost, the path distance of that label, the parent row, the
    settled flags and the number of settled nodes. With ``tables`` the arc cost is
    ``length · (1 + src_half[bucket(i)] + dst_half[bucket(j)])``, else the length.
    """
    indptr, dst, length = arcs.lists
    m = len(h)
    best, dist, parent, closed = [math.inf] * m, [0.0] * m, [-1] * m, bytearray(m)
    best[s] = 0.0
    heap: list[tuple[float, int]] = [(h[s], s)]
    pop, push, floor = heapq.heappop, heapq.heappush, math.floor
    expanded = 0
    # Distance-only: one "bucket" that never ends, whose full arc cost is the length.
    full: Sequence[float] = length
    src_half, d_next = arcs.length, math.inf
    t0 = k = 0.0
    if tables is not None:
        t0, k = tables.t0, tables.k
    b_cur = None
    while heap:
        i = pop(heap)[1]
        if closed[i]:
            continue
        closed[i] = 1
        expanded += 1
        if i == goal:
            break
        g_i, d_i = best[i], dist[i]
        if tables is not None:
            b_i = floor(t0 + d_i * k)
            if b_i != b_cur:
                b_cur = b_i
                src_half, _, full = tables.get(b_i)
                d_next = (b_i + 1 - t0) / k  # path distance at which the next bucket starts
        for a in range(indptr[i], indptr[i + 1]):
            j = dst[a]
            if closed[j]:
                continue
            d_j = d_i + length[a]
            if d_j < d_next:
                c = g_i + full[a]
            else:  # the arc ends in a later bucket: mix the two buckets' halves
                assert tables is not None
                dst_half = tables.get(floor(t0 + d_j * k))[1]
                c = g_i + length[a] * (1.0 + float(src_half[a]) + float(dst_half[a]))
            if c < best[j]:
                best[j], dist[j], parent[j] = c, d_j, i
                push(heap, (c + h[j], j))
    return best, dist, parent, closed, expanded


def _reconstruct(parent: list[int], goal: int) -> I64:
    path = [goal]
    while parent[path[-1]] >= 0:
        path.append(parent[path[-1]])
    return np.asarray(path[::-1], dtype=np.int64)


def plan(
    graph: NavGraph,
    start: int,
    goal: int,
    depart_s: float,
    speed: float,
    node_cost: NodeCostFn | None,
    config: ModelConfig,
    *,
    time_bucket_s: float | None = None,
) -> PlanResult:
    """Least-cost path from node id ``start`` to node id ``goal`` (A*, Euclidean heuristic).

    ``depart_s`` and the times passed to ``node_cost`` are model seconds; ``speed`` m/s.
    ``node_cost=None`` plans by distance only. ``time_bucket_s`` (default ``config.window_s``)
    is the granularity at which ``node_cost`` is re-evaluated. Raises
    :class:`UnknownNodeError` for ids not in the graph and :class:`NoPathError` (naming the
    components) when start and goal are not connected.
    """
    bucket_s = config.window_s if time_bucket_s is None else float(time_bucket_s)
    _check_motion(speed, depart_s, bucket_s)
    s, g_row = graph.index_of(start), graph.index_of(goal)
    arcs = graph.arcs
    h = np.sqrt(((graph.xyz - graph.xyz[g_row]) ** 2).sum(axis=1)).tolist()
    tables = (
        None
        if node_cost is None
        else _BucketTables(graph, node_cost, config, depart_s, speed, bucket_s)
    )
    best, dist, parent, closed, expanded = _astar(arcs, h, s, g_row, tables)
    if not closed[g_row]:
        raise no_path_error(graph, s, g_row)
    path = _reconstruct(parent, g_row)
    walked = np.asarray([dist[r] for r in path.tolist()], dtype=np.float64)
    return PlanResult(
        path=path,
        path_ids=graph.ids[path],
        arrival_s=depart_s + walked / speed,
        length_m=dist[g_row],
        duration_s=dist[g_row] / speed,
        cost=best[g_row],
        expanded=expanded,
        walked_m=walked,
    )


def evaluate_path_cost(
    graph: NavGraph,
    path: npt.ArrayLike,
    depart_s: float,
    speed: float,
    node_cost: NodeCostFn | None,
    config: ModelConfig,
    *,
    time_bucket_s: float | None = None,
) -> float:
    """The temporal cost of walking ``path`` (row indices) as :func:`plan` would count it.

    Used to report the distance-only path's temporal cost beside the temporal plan. Raises
    :class:`NavGraphError` if consecutive path nodes are not joined by an edge.
    """
    bucket_s = config.window_s if time_bucket_s is None else float(time_bucket_s)
    _check_motion(speed, depart_s, bucket_s)
    rows = np.asarray(path, dtype=np.int64).reshape(-1)
    arcs = graph.arcs
    total, walked = 0.0, 0.0
    tables = (
        None
        if node_cost is None
        else _BucketTables(graph, node_cost, config, depart_s, speed, bucket_s)
    )
    for i, j in zip(rows[:-1].tolist(), rows[1:].tolist(), strict=True):
        lo, hi = int(arcs.indptr[i]), int(arcs.indptr[i + 1])
        hits = np.flatnonzero(arcs.dst[lo:hi] == j)
        if len(hits) == 0:
            raise NavGraphError(f"path step {i} -> {j} is not an edge of the graph")
        a = lo + int(hits[0])
        d = float(arcs.length[a])
        factor = 1.0
        if tables is not None:
            src_half = float(tables.get(tables.bucket(walked))[0][a])
            dst_half = float(tables.get(tables.bucket(walked + d))[1][a])
            factor += src_half + dst_half
        total += d * factor
        walked += d
    return total
