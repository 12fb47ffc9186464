"""Which entries of an entry table ``aion predict``, ``export`` and ``Map.predict`` answer for:
the layer that ``--node`` values name (:func:`layer_of_nodes`), the rows ``--layer``, ``--node``
and ``--at`` choose (:func:`select`), and the refusal of a layer the map does not have
(:func:`refuse_empty_layer`), all at once for a query (:func:`chosen_entries`). The records
themselves are :mod:`aion_cli.predictions`'."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from aion_cli.predictions import entry_ids, entry_table, kind_label

if TYPE_CHECKING:
    from aion_cli.mapquery import LoadedMap


def chosen_entries(
    loaded: LoadedMap,
    t_ns: int | None,
    layer: str,
    nodes: Sequence[str | int],
    at: str | None,
) -> tuple[Any, str, Any, dict[str, str]]:
    """What a query (``--layer``, ``--node`` by id or room name, ``--at``) answers for at
    ``t_ns``: the entry table of the layer it answers on, that layer, the rows chosen (a
    layer the map lacks refused) and the graph's room and building names; ``predict``'s
    records at one time and its series both start here."""
    from aion_cli.room_names import names_by_id, other_case_hint, with_names_resolved

    graph = loaded.graph
    _refuse_points(nodes)
    wanted = with_names_resolved(nodes, graph)
    layer = layer_of_nodes(layer, wanted, graph)
    table = entry_table(loaded, t_ns, layer)
    index = select(
        table, layer, wanted, at, in_map=_in_map(loaded, t_ns),
        # r1 for the graph's R1: named, as plan names it
        suggest=None if graph is None else (lambda missing: other_case_hint(missing, graph)),
        owners=place_owners(graph, layer) if at is not None else None,
    )
    index = refuse_empty_layer(table, layer, index)
    names = {} if loaded.graph is None else names_by_id(loaded.graph)
    return table, layer, index, names


def place_owners(graph: Any, layer: str) -> tuple[Any, Any] | None:
    """For ``--layer rooms`` / ``buildings``: the graph's places' positions and the room (or
    building, through its room) each belongs to, by which ``--at`` picks the room holding the
    place nearest the point; None for other layers."""
    if graph is None or layer not in ("rooms", "buildings"):
        return None
    from aion_cli.engine.query import parent_ids

    owner = parent_ids(graph.places.ids, graph.places.parent, graph.places.ids)
    if layer == "buildings":
        owner = parent_ids(graph.rooms.ids, graph.rooms.parent, owner)
    return graph.places.xyz, owner


def _refuse_points(nodes: Sequence[str | int]) -> None:
    """A ``--node`` value that is coordinates (``4,0``, as ``plan --from`` takes them): an
    :class:`InputError` pointing to ``--at``, not "not a node id"."""
    from aion_cli.engine.node_ids import parse_point
    from aion_cli.errors import InputError

    for node in nodes:
        if isinstance(node, str) and parse_point(node) is not None:
            raise InputError(
                f"--node takes ids and room names; {node.strip()!r} is a point",
                hint=f"--at {node.strip()} answers for the entry nearest to it (Map.predict: at=)",
            )


def refuse_empty_layer(table: Any, layer: str, index: Any) -> Any:
    """``index``, or an :class:`InputError` when ``--layer places`` chose no row of a map of
    hash cells only (as :func:`entry_table` for rooms: empty reads as "nobody walks")."""
    from aion_cli.errors import InputError

    if len(index) or layer != "places" or len(table.xyz) == 0:
        return index
    raise InputError(
        "the map has no places, only hash cells",
        hint="build with a scene graph (--graph FILE or --derive-graph) to get places; "
        "without --layer, predict answers per hash cell",
    )


def _wanted_label(node: str | int, by_id: dict[str, int]) -> str:
    """The entry id a ``--node`` value names: an id as ``predict`` prints it (``p12``,
    ``R2``, a hash cell's ``c<key>``), or a node id in any form ``parse_node_id`` reads."""
    from aion_cli.engine.node_ids import node_label, parse_node_id

    if isinstance(node, str):
        text = node.strip()
        if text in by_id or (text[:1] == "c" and text[1:].isdigit()):  # a cell: c<key>
            return text
        return node_label(parse_node_id(text))
    return node_label(node)


def _refuse_other_layers(
    layer: str, missing: list[str], labels: list[str], in_map: Callable[[list[str]], bool] | None
) -> None:
    """``--layer rooms`` (``buildings``) with a ``--node`` of another kind (a place, a hash
    cell, a building): an error that says so, not "not in the map" (``p4`` is in it).
    ``in_map``: whether the map holds those ids on another layer; one it lacks (``p999``) is
    "not in the map", as without --layer (where the hint would send the user)."""
    from aion_cli.errors import UnknownNodeError

    if layer not in ("rooms", "buildings"):
        return
    others = [m for m in missing if m[:1] != ("R" if layer == "rooms" else "B")]
    if not others:
        return  # a room id the map lacks: "not in the map", as without --layer
    if in_map is not None and not in_map(others):
        return  # not in the map on any layer: "not in the map"
    listed = f"; the map's {layer}: {', '.join(labels[:8])}" if labels else ""
    raise UnknownNodeError(
        f"--layer {layer} answers {layer} only: {', '.join(others)} "
        + (f"is no {layer[:-1]}" if len(others) == 1 else f"are no {layer}"),
        hint=f"ask for {', '.join(others)} without --layer{listed}",
    )


def _in_map(loaded: LoadedMap, t_ns: int | None) -> Callable[[list[str]], bool]:
    """Whether the map holds every one of some ids as ``predict`` prints them (places, hash
    cells, rooms and buildings), computed when asked (an error's case only)."""

    def holds(ids: list[str]) -> bool:
        from aion_cli.engine.node_ids import node_label

        table = entry_table(loaded, t_ns)
        known = {str(i) for i in entry_ids(table, range(len(table.xyz)))}
        if loaded.graph is not None:
            for part in (loaded.graph.rooms, loaded.graph.buildings):
                known.update(node_label(int(i)) for i in part.ids)
        return set(ids) <= known

    return holds


def layer_of_nodes(layer: str, nodes: Sequence[str | int], graph: Any) -> str:
    """The layer that answers ``--node`` without ``--layer``: ``rooms`` when every node asked
    for is a room of the map's scene graph (by id or name, already resolved), ``buildings``
    when every one is a building; else ``layer`` as given (places and cells, whose unknown ids
    :func:`select` reports), or an :class:`InputError` for rooms or buildings in a mix."""
    from aion_cli.engine.node_ids import node_label, parse_node_id
    from aion_cli.errors import InputError

    if layer in ("rooms", "buildings") or not nodes or graph is None:
        return layer
    ids: set[int] = set()
    alone = layer == "all"  # every node asked for may be of one grouped layer
    for n in nodes:
        try:
            ids.add(n if isinstance(n, int) else parse_node_id(n))
        except InputError:  # a hash cell's c<key> (no node index), or an id select reports
            alone = False
    for name, part in (("rooms", graph.rooms), ("buildings", graph.buildings)):
        if alone and len(part) and ids <= {int(i) for i in part.ids}:
            return name
    grouped = ids & {int(i) for part in (graph.rooms, graph.buildings) for i in part.ids}
    if grouped:  # select would call them "not in the map"
        raise InputError(
            f"{', '.join(sorted(node_label(i) for i in grouped))}: rooms and buildings are "
            "answered on their own layer, not beside places, cells or the other layer",
            hint="rooms are answered when asked for alone (or with --layer rooms), buildings "
            "likewise (--layer buildings)",
        )
    return layer


def select(
    table: Any,
    layer: str = "all",
    nodes: Sequence[str | int] = (),
    at: str | None = None,
    in_map: Callable[[list[str]], bool] | None = None,
    suggest: Callable[[list[str]], str | None] | None = None,
    owners: tuple[Any, Any] | None = None,
) -> Any:
    """Row numbers of the entries asked for (``--layer``, ``--node``, ``--at``), in table
    order (``--node``: in the order given, an entry named twice once, where first named:
    ``--node p2 --node p2`` or ``--node kitchen --node R2`` is one row), as an int64 array.
    ``in_map``: whether the map holds ids on other layers than ``table``'s (``--layer rooms
    --node p4``: a place, not a room; None: taken as held). ``suggest``: the hint for ids
    not found, when it has one (``did you mean R1``), before the table's own. ``owners``
    (rooms and buildings: the graph's places' positions and the id of the room or building
    each belongs to): ``--at`` answers for the entry owning the place nearest the point, not
    for the entry whose centre is nearest (a point beside a long room's end is in that room,
    not in the small room whose centre is closer)."""
    import numpy as np

    from aion_cli.engine.nearest import distances_from
    from aion_cli.engine.node_ids import (
        point_distance,
        refuse_far_point,
        require_point,
    )
    from aion_cli.errors import InputError, UnknownNodeError

    index = np.arange(len(table.xyz), dtype=np.int64)
    if layer in ("places", "cells"):
        kind = np.asarray(table.kind)
        names = (
            np.asarray([kind_label(k) for k in np.unique(kind).tolist()], dtype=object)
            if kind.dtype.kind in "iu"
            else None
        )
        want = "node" if layer == "places" else "cell"
        if names is not None:
            codes = np.unique(kind)[names == want]
            index = index[np.isin(kind, codes)]
        else:
            index = index[kind == want]
    if nodes and at is not None:
        raise InputError(
            "choose --node or --at, not both (the point would be ignored)",
            hint="--at X,Y gives the entry nearest the point; --node names entries",
        )
    if nodes:
        labels = [str(i) for i in entry_ids(table, index)]
        by_id = dict(zip(labels, index.tolist(), strict=True))
        wanted = [_wanted_label(n, by_id) for n in nodes]
        missing = [w for w in wanted if w not in by_id]
        if missing:
            _refuse_other_layers(layer, missing, labels, in_map)
            everyone = {str(i) for i in entry_ids(table, np.arange(len(table.xyz)))}
            suggested = suggest(missing) if suggest is not None else None
            message = (
                f"node {missing[0]} is not in the map"
                if len(missing) == 1
                else f"nodes {', '.join(missing)} are not in the map"
            )
            if suggested is not None:
                hint = suggested
            elif layer in ("places", "cells") and set(missing) <= everyone:
                # in the map, on the other layer: "not in the map" would send the user to
                # check an id that is right
                other = ("a place", "places") if layer == "cells" else ("a hash cell", "hash cells")
                what = f"is {other[0]}" if len(missing) == 1 else f"are {other[1]}"
                message = f"{', '.join(missing)} {what} of the map, not on --layer {layer}"
                hint = f"--layer {layer} leaves {', '.join(missing)} out: ask without --layer"
            elif layer not in ("rooms", "buildings") and all(m[:1] in "RB" for m in missing):
                # the graph's own rooms and buildings are answered (layer_of_nodes)
                hint = "the map has no such room or building: aion info MAP lists its rooms"
            elif layer not in ("rooms", "buildings") and all(
                m[:1] in "rb" and m[1:].isdigit() for m in missing
            ):  # r1 for R1: "ids include p0, p1, ..." read as though rooms had no ids
                hint = (
                    "room and building ids are upper case (R1, B0), their names any case: "
                    "aion info MAP lists the map's rooms"
                )
            elif all(m.swapcase() in by_id for m in missing):  # P103 for p103
                hint = (
                    f"did you mean {', '.join(m.swapcase() for m in missing)}? (node ids "
                    "are case-sensitive)"
                )
            else:
                kind_names = [kind_label(table.kind[e]) for e in index.tolist()]
                ids = [i for i, k in zip(labels, kind_names, strict=True) if k != "cell"][:8]
                cells = len(labels) - sum(k != "cell" for k in kind_names)
                if ids:
                    hint = f"ids include {', '.join(ids)}"
                elif cells:  # a map of hash cells: their ids are spatial-hash keys
                    hint = (
                        f"the map has no nodes, only {cells:,} hash cells: pick one by "
                        "position with --at X,Y, or list ids with --top 10"
                    )
                else:
                    hint = "the map has no entries"
            raise UnknownNodeError(message, hint=hint)
        index = np.asarray(list(dict.fromkeys(by_id[w] for w in wanted)), dtype=np.int64)
    if at is not None:
        x, y, z = require_point(at, "--at")
        if not index.size:
            return index
        owned = _owner_row(table, index, owners, (x, y, z))
        if owned is not None:
            row, place, far = owned
            label = f"in {entry_ids(table, np.array([row]))[0]}"
            refuse_far_point(at, far, label, place, "place")
            return np.array([row], dtype=np.int64)
        xyz = np.asarray(table.xyz, dtype=np.float64)[index]
        dist = distances_from(xyz, (x, y, z))
        nearest = float(dist.min())
        # candidates by numpy, the choice by math.dist as the rows' own floats give it
        close = index[dist <= nearest * (1 + 1e-9) + 1e-12] if math.isfinite(nearest) else index
        def away(e: int) -> float:
            return point_distance(tuple(float(v) for v in table.xyz[e][:3]), (x, y, z))

        best = min(close.tolist(), key=away)
        label = str(entry_ids(table, np.array([best]))[0])
        refuse_far_point(at, away(best), label, table.xyz, "entry")
        index = np.array([best], dtype=np.int64)
    return index



def _owner_row(
    table: Any, index: Any, owners: tuple[Any, Any] | None, point: tuple[float, float, float]
) -> tuple[int, Any, float] | None:
    """The row among ``index`` owning the place nearest ``point`` (``owners``: places'
    positions and their owners' ids), the places' positions and that place's distance; None
    without owners or when that place's owner has no row (an empty room)."""
    import numpy as np

    from aion_cli.engine.nearest import distances_from

    if owners is None or not len(owners[0]):
        return None
    xyz, owner = np.asarray(owners[0], dtype=np.float64), np.asarray(owners[1])
    dist = distances_from(xyz, point)
    nearest = int(np.argmin(dist))
    rows = index[np.asarray(table.node_id)[index] == owner[nearest]]
    if not rows.size:
        return None
    return int(rows[0]), xyz, float(dist[nearest])
