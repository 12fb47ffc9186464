"""Planning on a loaded map with temporal costs: the one planner behind ``aion plan``,
``aion export --path-from/--path-to`` and :meth:`aion_cli.Map.plan`.

A plan is always two paths: the *temporal* one (A* over the navigational graph, each node's
cost predicted at the time the walker is expected to arrive, ``engine.planning.plan``) and the
*distance-only* one beside it, with the temporal cost it would have had. Without a time (a
historical export) both are the distance-only path.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.node_ids import (
    node_label,
    parse_point,
    point_distance,
    point_text,
    refuse_far_point,
    refuse_malformed_point,
    shown_point,
)
from aion_cli.room_names import (
    name_of,
    named_node,
    other_case_hint,
    parse_id_or_name,
    rooms_off_the_nav_layer,
)

if TYPE_CHECKING:
    from aion_cli.engine.nav_graph import NavGraph
    from aion_cli.engine.planning import PlanResult
    from aion_cli.engine.types import GraphSnapshot
    from aion_cli.mapquery import LoadedMap

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]


@dataclass(frozen=True)
class Endpoint:
    """A plan's start or goal: its node id, and where a typed point was snapped from."""

    node_id: int
    point: tuple[float, float, float] | None = None
    distance_m: float = 0.0
    # the room or building (``("room", id of R3)``) whose place this is, when one was asked for
    within: tuple[str, int] | None = None
    name: str | None = None  # that room's name in the graph ("kitchen"), if it has one
    # the room's place nearest its centre was not joined to the other end: this is its
    # nearest place of those that are
    reachable_only: bool = False

    def snapped(self, option: str) -> dict[str, Any] | None:
        """The ``snapped`` record of ``aion plan --format json`` (None for a node id); for a
        room or building, its id under ``room`` / ``building`` and ``point`` its centre."""
        if self.point is None:
            return None
        record: dict[str, Any] = {"option": option}
        if self.within is not None:
            record[self.within[0]] = node_label(self.within[1])
            if self.name is not None:
                record["name"] = self.name
        if self.reachable_only:
            record["reachable_only"] = True
        return record | {
            "point": shown_point(self.point),
            "node": node_label(self.node_id),
            "distance_m": self.distance_m,
        }


def resolve_endpoint(
    where: str | int,
    nav: NavGraph,
    graph: GraphSnapshot | None = None,
    spanned: npt.ArrayLike = (),
) -> Endpoint:
    """A node id (``"p12"``, ``"p(12)"``, an int), a room or building of ``graph`` (``"R3"``:
    its place nearest the room's centre), or coordinates ``"x,y[,z]"`` snapped to the nearest
    node; :class:`~aion_cli.errors.UnknownNodeError` for an id not in the graph (or a room
    without a place in it), :class:`~aion_cli.errors.InputError` for a point far from every
    node (:func:`~aion_cli.engine.node_ids.refuse_far_point`), farther than the graph and the
    positions ``spanned`` (the map's entries, its hash cells: ``mapquery.entry_positions``)
    span together."""
    if isinstance(where, (int, np.integer)):  # a NodeSymbol value: a place, room, ...
        return _node_endpoint(int(where), nav, graph)
    point = parse_point(where)
    if point is None:
        _refuse_cell(where)
        named = None if graph is None else named_node(where, graph)
        if named is None:
            refuse_malformed_point(where)  # "1,2,3,4", "(1,2)": not "not a node id"
        node_id = named if named is not None else parse_id_or_name(where, graph)
        return _node_endpoint(node_id, nav, graph)
    row = nav.nearest(point)
    node_id = int(nav.ids[row])
    distance = point_distance(tuple(float(v) for v in nav.xyz[row]), point)
    held = np.concatenate([nav.xyz.reshape(-1, 3), np.asarray(spanned, np.float64).reshape(-1, 3)])
    refuse_far_point(where, distance, node_label(node_id), held)
    return Endpoint(node_id, point, distance)


def _refuse_cell(where: str) -> None:
    """A hash cell's id as ``predict`` prints it (``c<key>``: a key far beyond any node
    index): an :class:`~aion_cli.errors.InputError` saying plans run between places, not
    "node index too large"."""
    from aion_cli.engine.node_ids import INDEX_MASK
    from aion_cli.errors import InputError

    text = where.strip()
    digits = text[1:]
    if text[:1] == "c" and digits.isascii() and digits.isdigit() and int(digits) > INDEX_MASK:
        raise InputError(
            f"{text} is a hash cell (an entry predict lists), not a place of the scene graph: "
            "paths run between places",
            hint=f"give its position as x,y (aion predict MAP --node {text} shows it), a "
            "place id or a room",
        )


def _node_endpoint(node_id: int, nav: NavGraph, graph: GraphSnapshot | None) -> Endpoint:
    """A room or building of ``graph`` (its place nearest the centre), else a place of
    ``nav`` (:class:`~aion_cli.errors.UnknownNodeError` with examples when it is not)."""
    if graph is not None:
        inside = _room_endpoint(node_id, nav, graph)
        if inside is not None:
            return inside
        _refuse_unknown_room(node_id, graph)
        if not (nav.ids == np.uint64(node_id)).any():
            _refuse_room_in_other_case(node_id, graph)
    nav.index_of(node_id)
    return Endpoint(node_id)


def _refuse_room_in_other_case(node_id: int, graph: GraphSnapshot) -> None:
    """``r1`` where the graph has a room ``R1``: an
    :class:`~aion_cli.errors.UnknownNodeError` that names it (the places' hint listed
    ``p0, p1, ...``, as though the map had no such room)."""
    from aion_cli.errors import UnknownNodeError

    hint = other_case_hint([node_id], graph)
    if hint is not None:
        raise UnknownNodeError(
            f"node {node_label(node_id)} is not in the navigational graph", hint=hint
        )


def _refuse_unknown_room(node_id: int, graph: GraphSnapshot) -> None:
    """An id in a room's (``R``) or building's (``B``) category that ``graph`` does not hold:
    :class:`~aion_cli.errors.UnknownNodeError` naming that layer's ids (the places' hint
    would list places for a mistyped room)."""
    from aion_cli.errors import UnknownNodeError

    kinds = {"R": ("room", graph.rooms.ids), "B": ("building", graph.buildings.ids)}
    label = node_label(node_id)
    if label[:1] not in kinds or not label[1:].isdigit():
        return
    kind, ids = kinds[label[:1]]
    shown = 12  # every id of a usual graph; a few of a large one, said to be a few
    examples = ", ".join(node_label(int(i)) for i in ids[:shown])
    listed = f"its {kind}s: {examples}" if len(ids) <= shown else (
        f"its {len(ids):,} {kind}s include {examples}"
    )
    raise UnknownNodeError(
        f"{kind} {label} is not in the map",
        hint=listed if examples else f"the map has no {kind}s: plan to a "
        "place (p12) or to a point x,y",
    )


def _room_endpoint(
    node_id: int, nav: NavGraph, graph: GraphSnapshot, within: int | None = None
) -> Endpoint | None:
    """The place of room (or building) ``node_id`` nearest its centre (of its places in
    component ``within`` of ``nav``, when given: None if it has none there); None when
    ``node_id`` is neither."""
    from aion_cli.errors import UnknownNodeError

    wanted = np.uint64(node_id)
    if np.any(graph.rooms.ids == wanted):
        kind, layer = "room", graph.rooms
        rooms = np.asarray([wanted], dtype=np.uint64)
    elif np.any(graph.buildings.ids == wanted):
        kind, layer = "building", graph.buildings
        rooms = graph.rooms.ids[graph.rooms.parent == wanted]
    else:
        return None
    label = node_label(node_id)
    candidates = np.isin(nav.ids, graph.places.ids[np.isin(graph.places.parent, rooms)])
    if within is not None:
        candidates &= nav.components == within
        if not candidates.any():
            return None
    rows = np.flatnonzero(candidates)
    if rows.size == 0:
        off = rooms_off_the_nav_layer(graph)
        raise UnknownNodeError(
            f"{kind} {label} holds no place of the navigational graph"
            + ("" if off is None else f": {off[0]}"),
            hint="plan to a place (p12) or to a point x,y" if off is None else off[1],
        )
    at = int(np.flatnonzero(layer.ids == wanted)[0])
    centre = layer.xyz[at]
    if not np.all(np.isfinite(centre)):
        centre = nav.xyz[rows].mean(axis=0)
    d2 = ((nav.xyz[rows] - centre) ** 2).sum(axis=1)
    row = int(rows[int(np.argmin(d2))])
    return Endpoint(
        int(nav.ids[row]),
        (float(centre[0]), float(centre[1]), float(centre[2])),
        float(np.sqrt(d2.min())),
        (kind, node_id),
        name_of(layer, at),
        within is not None,
    )


def resolve_ends(
    start: str | int,
    goal: str | int,
    nav: NavGraph,
    graph: GraphSnapshot | None = None,
    spanned: npt.ArrayLike = (),
) -> tuple[Endpoint, Endpoint]:
    """:func:`resolve_endpoint` of both ends of a plan (``spanned``: the map's entries'
    positions, which a point may lie as far as they span); a room or building whose place
    nearest its centre is not joined to the other end (an isolated place of the scene graph)
    stands for its nearest place of those that are, if it has one: the room is reachable.
    Ends that are still not joined are a :class:`~aion_cli.errors.NoPathError` that says
    which place a point or room given as an end stood for."""
    a = resolve_endpoint(start, nav, graph, spanned)
    b = resolve_endpoint(goal, nav, graph, spanned)
    comp = nav.components
    row_a, row_b = nav.index_of(a.node_id), nav.index_of(b.node_id)
    if comp[row_a] == comp[row_b]:
        return a, b
    if graph is not None and b.within is not None:
        moved = _room_endpoint(b.within[1], nav, graph, int(comp[row_a]))
        if moved is not None:
            return a, moved
    if graph is not None and a.within is not None:
        moved = _room_endpoint(a.within[1], nav, graph, int(comp[row_b]))
        if moved is not None:
            return moved, b
    raise _unjoined(nav, (a, row_a), (b, row_b))


def _unjoined(nav: NavGraph, *ends: tuple[Endpoint, int]) -> Exception:
    """The no-path error of two ends in different components, saying which place a point,
    room or building given as an end stood for (the notes that say it on success are not
    printed on failure: "no path from p0 to p5" named a place nobody typed)."""
    from aion_cli.engine.planning import no_path_error
    from aion_cli.errors import NoPathError

    err = no_path_error(nav, ends[0][1], ends[1][1])
    said = []
    for role, (end, _) in zip(("start", "goal"), ends, strict=True):
        label = node_label(end.node_id)
        if end.within is not None:
            said.append(f"the {role} {node_label(end.within[1])} stands for its place {label}")
        elif end.point is not None:
            typed = point_text(shown_point(end.point))
            said.append(f"the {role} {typed} snapped to {label} ({end.distance_m:.2f} m away)")
    if not said:
        return err
    return NoPathError(f"{err} ({'; '.join(said)})", hint=err.hint)


@dataclass(frozen=True)
class Route:
    """One path: rows into the graph, node ids, length, walking time, temporal cost and the
    arrival time at each node (nanoseconds since 1970, UTC)."""

    rows: I64
    node_ids: tuple[int, ...]
    length_m: float
    duration_s: float
    cost: float
    arrival_ns: tuple[int, ...]

    @property
    def nodes(self) -> list[str]:
        """The path as node labels (``["p12", "p13", ...]``)."""
        return [node_label(i) for i in self.node_ids]


@dataclass(frozen=True)
class Routes:
    """The temporal plan and the distance-only plan beside it."""

    start: int
    goal: int
    depart_ns: int | None
    speed_mps: float
    temporal: Route
    distance_only: Route


def plan_routes(
    loaded: LoadedMap,
    start: int,
    goal: int,
    depart_ns: int | None,
    speed: float | None = None,
    nav: NavGraph | None = None,
) -> Routes:
    """Both plans from node ``start`` to node ``goal`` departing at ``depart_ns`` (None: no
    time, both distance-only) at ``speed`` m/s (None: the map's ``plan_speed``)."""
    return _Planning(loaded, start, goal, speed, nav).routes(depart_ns)


class _Planning:
    """What the plans of one start, goal and speed share whatever the departure: the map's
    planning config, the distance-only path (its nodes and lengths do not depend on the time)
    and the node costs of the last few times asked for (``plan --leave``'s departures every
    window read the same windows' forecasts)."""

    def __init__(
        self,
        loaded: LoadedMap,
        start: int,
        goal: int,
        speed: float | None,
        nav: NavGraph | None,
    ) -> None:
        from functools import lru_cache

        from aion_cli.engine.planning import plan
        from aion_cli.mapquery import nav_graph, node_cost_fn, planning_config

        self.loaded, self.start, self.goal = loaded, start, goal
        self.nav = nav if nav is not None else nav_graph(loaded)
        self.config = planning_config(loaded)
        self.speed = float(speed if speed is not None else self.config.plan_speed)
        self.shortest = plan(self.nav, start, goal, 0.0, self.speed, None, self.config)
        self.cost_fn = lru_cache(maxsize=8)(node_cost_fn(loaded, self.nav.ids))

    def routes(self, depart_ns: int | None) -> Routes:
        from aion_cli.engine.planning import evaluate_path_cost, plan
        from aion_cli.engine.windows import to_model_seconds

        v, shortest = self.speed, self.shortest
        if depart_ns is None:
            route = _route(shortest, shortest.cost, None, v)
            return Routes(self.start, self.goal, None, v, route, route)
        # UTC seconds: a walk's timeline; each node's cost turns them back into a time
        # (mapquery.node_cost_fn), whose prediction takes FreMEn's clock itself
        depart_s = float(to_model_seconds(depart_ns))
        nav, config, cost_fn = self.nav, self.config, self.cost_fn
        temporal = plan(nav, self.start, self.goal, depart_s, v, cost_fn, config)
        shortest_cost = evaluate_path_cost(nav, shortest.path, depart_s, v, cost_fn, config)
        beside = _route(shortest, shortest_cost, depart_ns, v)
        # The search keeps one arrival per node (label-setting), so with costs that change
        # over time it can miss a path whose earlier arrivals pay off later. The distance-only
        # path is one such path it may miss: never offer a plan dearer than it.
        if shortest_cost < temporal.cost:
            return Routes(self.start, self.goal, depart_ns, v, beside, beside)
        return Routes(
            self.start, self.goal, depart_ns, v, _route(temporal, temporal.cost, depart_ns, v),
            beside,
        )


def _route(result: PlanResult, cost: float, depart_ns: int | None, speed: float) -> Route:
    # from the distance walked, not from model seconds: at ~2e8 s (2026) a float's step is
    # 30 ns, which arrival_s - depart_s would carry into the nanoseconds
    base = 0 if depart_ns is None else depart_ns
    arrival = tuple(base + round(float(w) / speed * 1e9) for w in result.walked_m)
    return Route(
        np.asarray(result.path, dtype=np.int64),
        tuple(int(i) for i in result.path_ids),
        float(result.length_m),
        float(result.duration_s),
        float(cost),
        arrival,
    )


def plan_departures(
    loaded: LoadedMap,
    start: int,
    goal: int,
    times_ns: list[int],
    speed: float | None = None,
    nav: NavGraph | None = None,
    progress: Callable[[int], None] | None = None,
    observed: Sequence[bool | None] | None = None,
) -> tuple[list[Routes], int]:
    """:func:`plan_routes` for each departure of ``times_ns`` (``aion plan --leave``), and
    the index of the best one (:func:`best_departure`, ``observed``: per departure, whether
    the map observed its hour, ``predictions.hour_flags``, which the departures' rows show
    too); ``progress(k)`` after each departure."""
    if not times_ns:
        raise ValueError("no departure time")
    planning = _Planning(loaded, start, goal, speed, nav)
    plans = []
    for k, t in enumerate(times_ns, start=1):
        plans.append(planning.routes(t))
        if progress is not None:
            progress(k)
    return plans, best_departure([p.temporal.cost for p in plans], observed)


DEPARTURE_TIE = 1e-3
"""Departure costs within this share of the least are one cost (``aion plan --leave``): the
table shows a tenth of a unit, and forecasts are not that exact."""


def best_departure(costs: list[float], observed: Sequence[bool | None] | None = None) -> int:
    """The index of the best departure: the earliest whose temporal cost is within
    :data:`DEPARTURE_TIE` of the least, preferring one at an hour the map observed
    (``observed``: per departure, ``predictions.hour_flags``; False marks an extrapolated
    hour). Costs of 8.000133 and 8.000100 both read 8.0: the earlier departure is the answer,
    not a later one by a ten-thousandth; and among equal costs a forecast the map saw the
    hour of, not an extrapolated one (a static map costs every hour alike)."""
    least = min(costs)
    tied = [k for k, c in enumerate(costs) if c <= least * (1.0 + DEPARTURE_TIE)]
    seen = [k for k in tied if observed is None or observed[k] is not False]
    return (seen or tied)[0]
