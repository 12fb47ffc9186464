"""Warnings that a built map's detections are not what they seem: nearly all of them away from
every place of the scene graph (:func:`far_from_graph_warning`: the graph and the detections
in different frames or units), most of a continuing build's new detections away from every
entry the continued map held (:func:`new_ground_warning`: a log of another place), or moving
faster on average than people can (:func:`fast_people_warning`: times or positions that
mislead).

Why a module of its own: these judge the map as a whole, from its counts and mean speed, after
the detections were read; ``build``, ``merge`` and a parallel build's parent
(:mod:`aion_cli.shard_reports`) ask them alike, while :mod:`aion_cli.build_report` keeps the
report and the rules over the detections read per topic.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from aion_cli.build_report import BuildReport
    from aion_cli.engine.state import MapState
    from aion_cli.engine.types import F64, I64, U64

__all__ = [
    "FAR_FROM_GRAPH_SHARE",
    "FAST_PEOPLE_WARNING",
    "NEW_GROUND_SHARE",
    "PLAUSIBLE_SPEED_M_S",
    "Ground",
    "away_by_map",
    "far_from_graph_of",
    "far_from_graph_warning",
    "fast_people_warning",
    "held_ground",
    "merge_ground_warning",
    "new_ground_warning",
]

#: share of a map's detections on hash cells, with a scene graph, above which the graph and
#: the detections probably do not share a frame (:func:`far_from_graph_warning`)
FAR_FROM_GRAPH_SHARE = 0.95


def far_from_graph_warning(
    on_cells: float, on_nodes: float, places: int, places_with_flow: int
) -> str | None:
    """A warning when a map with a scene graph holds nearly all of its detections on hash
    cells, away from every place (``on_cells`` / ``on_nodes``: detections on each, ``places``
    the graph's places, ``places_with_flow`` those holding any): the detections and the graph
    are most likely in different frames or units (a graph file of another building, a
    ``--map-frame`` that is not the graph's). None when the graph holds a fair share, or
    there is no graph or no detection."""
    total = on_cells + on_nodes
    if places == 0 or total <= 0 or on_cells / total < FAR_FROM_GRAPH_SHARE:
        return None
    return (
        f"{on_cells:,.0f} of the {total:,.0f} detections lie away from every place of the "
        f"scene graph (on hash cells; {places_with_flow:,} of its {places:,} places hold any): are "
        "the detections and the graph in the same frame and units? (--map-frame, --graph; "
        "aion predict MAP --layer cells shows where the detections are)"
    )


def far_from_graph_of(state: Any, stats: dict[str, int]) -> str | None:
    """:func:`far_from_graph_warning` of a map state about to be written (``stats``: its
    :func:`aion_cli.mapquery.state_counts`): what ``build`` warns and ``merge`` notes."""
    from aion_cli.engine.ownership import stable_nodes
    from aion_cli.mapquery import detections_by_kind

    on_cells, on_nodes = detections_by_kind(state)
    warning = far_from_graph_warning(on_cells, on_nodes, stats["nodes"], stats["nodes_with_flow"])
    end = state.log_time_ns
    if warning is not None and end is not None and not stable_nodes(state, end).any():
        # not the frame: no place was stable long enough to take over its cells
        stability = state.config.stability_s
        return (
            f"{on_cells:,.0f} of the {on_cells + on_nodes:,.0f} detections stay on hash cells: "
            f"none of the scene graph's {stats['nodes']:,} places had been stable for "
            f"{stability:g} s of log time when the log ended (a place takes over its cells "
            "then; stability_s in --config), so the map's flows are on its cells"
        )
    return warning


NEW_GROUND_SHARE = 0.5
"""The share of a continuing build's new detections away from every entry the continued map
held (:func:`new_ground_warning`) above which the new logs are warned of as (mostly) of
another place: more than half, "most" as ``aion evaluate``'s holdout warning
(:data:`aion_cli.evaluation.holdout.MOSTLY_APART`) has it. Measured (docs/EVALUATION.md,
stop 70): a simulated day of the office continuing the office sample's map leaves 1 % away;
an ETH-UCY hotel log, 85 %, a THÖR log, 63 %. Not a refusal: a robot may explore new ground."""


@dataclass(frozen=True)
class Ground:
    """Where a map holds its detections, as :func:`new_ground_warning` and
    :func:`merge_ground_warning` compare maps: the positions of its live entries, the node
    id of each (0 for a hash cell: ``is_node`` says which are places) and the detections
    each holds. A few arrays per entry, no state: a merge keeps one per input map while it
    reads their states one at a time."""

    xyz: F64
    node_id: U64
    is_node: NDArray[np.bool_]
    detections: F64

    @classmethod
    def of(cls, state: MapState) -> Ground:
        """The ground of ``state`` as it is now (copies: the state may change after)."""
        import numpy as np

        from aion_cli.engine.entries import NODE, held_detections

        entries = state.entries
        live = entries.live_rows()
        held = held_detections(entries, live)
        return cls(
            entries.xyz[live].copy(),
            entries.node_id[live].copy(),
            entries.kind[live] == NODE,
            np.asarray(held, np.float64),
        )

    @classmethod
    def joined(cls, grounds: Sequence[Ground]) -> Ground:
        """The ground of several maps at once (their entries side by side)."""
        import numpy as np

        return cls(
            np.concatenate([g.xyz.reshape(-1, 3) for g in grounds]),
            np.concatenate([g.node_id for g in grounds]),
            np.concatenate([g.is_node for g in grounds]),
            np.concatenate([g.detections for g in grounds]),
        )

    @property
    def total(self) -> float:
        """Every detection it holds."""
        return float(self.detections.sum())

    def away_from(self, held: Ground, reach: float, *, by_id: bool = True) -> float:
        """The detections of this ground that lie away from every entry of ``held``
        (:func:`away_by_map` of the two)."""
        return float(away_by_map([held, self], reach, by_id=by_id)[1])


#: neighbours looked up at once per entry by :func:`away_by_map`; an entry whose this many
#: nearest are all its own map's and within its reach is looked up with a ball (a cell has
#: up to 13 cell centres within 1 m; 4, 8 and 16 measured alike, docs/BENCHMARKS.md)
_NEIGHBOURS = 8


def away_by_map(grounds: Sequence[Ground], reach: float, *, by_id: bool = True) -> F64:
    """Per ground, the detections it holds away from every entry of the other grounds: on
    cells farther than ``reach`` (``bind_radius``: within it a cell joins a place) from each,
    or on places 2 ``reach`` or farther (a place gathers the cells within reach of it) and,
    with ``by_id`` (node ids of one scene-graph session name one place wherever it moved),
    of ids no other ground has a place of. One KD-tree of every entry and one query of its
    nearest few per entry (the cost of one ground against all others is not paid per
    ground: a merge of 30 maps would build 30 trees of all the others); an entry whose few
    nearest are all its own ground's, within its reach, is looked up in full."""
    import numpy as np

    every = Ground.joined(grounds)
    n = len(every.detections)
    owner = np.repeat(np.arange(len(grounds)), [len(g.detections) for g in grounds])
    near = np.zeros(n, bool)
    if n and len(grounds) > 1:
        near = _near_another(every, owner, reach)
    if by_id and every.is_node.any():
        ids = every.node_id[every.is_node]
        whose = owner[every.is_node].astype(np.uint64)  # uint64 beside the ids, no floats
        pairs = np.unique(np.column_stack([ids, whose]), axis=0)
        uniq, maps_of = np.unique(pairs[:, 0], return_counts=True)
        sole = pairs[np.isin(pairs[:, 0], uniq[maps_of == 1])]  # ids one ground alone holds
        alone = np.isin(ids, sole[:, 0])
        sole_owner = np.zeros(len(ids), np.int64)
        sole_owner[alone] = sole[np.searchsorted(sole[:, 0], ids[alone]), 1].astype(np.int64)
        shared = ~alone | (sole_owner != whose.astype(np.int64))
        near[np.flatnonzero(every.is_node)[shared]] = True
    away = np.where(near, 0.0, every.detections)
    return np.bincount(owner, weights=away, minlength=len(grounds)).astype(np.float64)


def _near_another(every: Ground, owner: I64, reach: float) -> NDArray[np.bool_]:
    """Per entry of ``every`` (``owner``: its ground), whether an entry of another ground lies
    within its reach (:func:`away_by_map`). Entries at one position are one point of the
    tree (maps of one place share their cells' centres): a position that two grounds hold is
    near for both, and only the positions one ground alone holds are looked up."""
    import numpy as np

    from aion_cli.engine.nearest import horizontal_tree

    xy = np.ascontiguousarray(every.xyz[:, :2])
    order = np.lexsort((owner, xy[:, 1], xy[:, 0]))  # by position, then ground
    ranked = xy[order]
    starts = np.ones(len(order), bool)
    starts[1:] = (ranked[1:] != ranked[:-1]).any(axis=1)
    at_point = np.empty(len(order), np.int64)
    at_point[order] = np.cumsum(starts) - 1
    points = ranked[starts]
    first, last = owner[order][starts], owner[order][np.r_[starts[1:], True]]
    sole = np.where(first == last, first, -1)  # the one ground holding a point; -1: several
    near = sole[at_point] == -1
    rows = np.flatnonzero(~near)
    if rows.size == 0 or len(points) == 1:
        return near
    bound = np.where(every.is_node[rows], 2 * reach, reach)
    k = min(_NEIGHBOURS, len(points))
    tree = horizontal_tree(points)
    dist, at = tree.query(xy[rows], k=k, distance_upper_bound=2 * reach)  # < 2 reach
    dist, at = dist.reshape(rows.size, k), at.reshape(rows.size, k)
    found = at < len(points)
    other = found & (sole[np.minimum(at, len(points) - 1)] != owner[rows, None])
    near[rows] = (other & (dist <= bound[:, None])).any(axis=1)
    more = ~near[rows] & found[:, -1] & (dist[:, -1] <= bound)  # more past the k-th
    if more.any():
        ask = rows[more]
        radius = np.where(every.is_node[ask], np.nextafter(2 * reach, 0), reach)
        sizes = tree.query_ball_point(xy[ask], radius, return_length=True)
        hits = np.concatenate(tree.query_ball_point(xy[ask], radius)).astype(np.int64)
        row = np.repeat(ask, sizes)
        near[np.unique(row[sole[hits] != owner[row]])] = True
    return near


def held_ground(state: MapState) -> Ground:
    """What :func:`new_ground_warning` compares a continuing build's result with, taken from
    the continued map before the logs go into it (:meth:`Ground.of`)."""
    return Ground.of(state)


def new_ground_warning(state: MapState, ground: Ground, name: str) -> str | None:
    """A warning when more than :data:`NEW_GROUND_SHARE` of the detections a build added to
    the continued map ``name`` (``ground``: its :func:`held_ground`) lie away from every
    entry it held (:meth:`Ground.away_from`: on cells farther than ``bind_radius`` from each
    of its entries, or on places, none of its own, farther than twice that). Such an entry
    held none of the continued map's detections (cells never move; places are known by id),
    so its detections are all new, and the new logs are most likely of another place, which
    ``--map`` joins as if one. None when the map held no entry or the build added no
    detection."""
    from aion_cli.fixed_sensor_text import share_text

    result = Ground.of(state)
    new = result.total - ground.total
    if len(ground.xyz) == 0 or new <= 0:
        return None
    reach = state.config.bind_radius
    away = result.away_from(ground, reach)
    share = min(away / new, 1.0)
    if share <= NEW_GROUND_SHARE:
        return None
    return (
        f"{share_text(share)} of the {new:,.0f} detections the logs added to {name} "
        f"({away:,.0f}) lie farther than {reach:g} m (bind_radius) from every entry it held: "
        "are the logs of another place? --map is for more logs of the same place: build "
        "another place's logs into a map of their own (aion merge joins maps that share "
        "a frame)"
    )


def merge_ground_warning(
    grounds: Sequence[tuple[str, Ground]], reach: float, *, by_id: bool
) -> str | None:
    """A warning when more than :data:`NEW_GROUND_SHARE` of some input map's detections lie
    away from every entry of the other maps of a merge (``grounds``: each map's name and
    :class:`Ground` before the merge; ``reach``: ``bind_radius``; ``by_id``: the maps' node
    ids name one session's places, lineage ``"same"``), as ``aion build LOG --map OLD``
    warns of logs away from OLD: maps of another place, or of one place recorded in another
    frame (Lincoln's 2017-05-31, turned by 171°), which ``aion merge`` adds as if their
    positions were one frame. Names each such map with its share; None when none is, or
    fewer than two maps hold detections."""
    from aion_cli.fixed_sensor_text import share_text

    holding = [(name, g) for name, g in grounds if g.total > 0]
    if len(holding) < 2:
        return None
    apart = away_by_map([g for _, g in holding], reach, by_id=by_id)
    away = [
        f"{share_text(a / g.total)} of the {g.total:,.0f} of {name}"
        for (name, g), a in zip(holding, apart, strict=True)
        if a / g.total > NEW_GROUND_SHARE
    ]
    if not away:
        return None
    which = "the other map" if len(holding) == 2 else "every other map"
    return (
        f"most detections of a map lie farther than {reach:g} m (bind_radius) from every "
        f"entry of {which} ({'; '.join(away)}): are the maps of another place, or of one "
        "place in another frame? aion merge adds positions as they are: put every log in "
        "one frame (align it) before building, or keep another place's map apart"
    )


#: the mean speed of a build's detections above which people cannot be walking (m/s; people
#: walk at about 1.4 m/s, and even a running crowd's mean stays below this)
PLAUSIBLE_SPEED_M_S = 3.0
#: how :func:`fast_people_warning`'s line begins (a parallel build writes it once, from sums)
FAST_PEOPLE_WARNING = "people move at "


def fast_people_warning(report: BuildReport) -> str | None:
    """A warning when the build's detections move faster on average than people can
    (:data:`PLAUSIBLE_SPEED_M_S`): their times or positions are not what they seem, and the
    map's speeds and counts per window with them. Real cases: a bag re-recorded faster than
    real time whose messages carry no header stamps (log times used), positions in pixels or
    millimetres. None when they are plausible or have no speed."""
    mean = report.mean_speed()
    if mean is None or mean <= PLAUSIBLE_SPEED_M_S:
        return None
    return (
        f"{FAST_PEOPLE_WARNING}{mean:,.1f} m/s on average ({report.speed_n:,} detections "
        "with a speed; people walk at about 1.4 m/s): the detections' times or positions are "
        "probably not what they seem (a log recorded faster than real time whose messages' "
        "log times stand in for missing header stamps, positions in pixels or millimetres), "
        "and the map's speeds and flows per window are not people's"
    )
