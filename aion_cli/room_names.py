"""Rooms and buildings by their names in the scene graph (Hydra's room labels, such as
"kitchen" or "office 1"), wherever a node id is accepted: ``plan --from/--to``,
``export --path-from/--path-to``, ``predict --node`` and the Python API. A name matches in any
case, and with underscores for its spaces (``office_1``: one shell word, as shell completion
offers it, :func:`shell_word`); a label that is only the node's id (``R3``) is not a name,
and an id of a node the graph holds is that node before it is any room's name.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import TYPE_CHECKING

from aion_cli.engine.node_ids import node_label, parse_node_id

if TYPE_CHECKING:
    from aion_cli.engine.types import GraphSnapshot, Layer


def parse_id_or_name(text: str, graph: GraphSnapshot | None) -> int:
    """:func:`parse_node_id`, whose error also lists the graph's room names, if it has any,
    or says that the map has none (no scene graph, a graph without rooms, rooms without
    names) and where names come from, for a word not of an id's form (``kitchen``)."""
    from aion_cli.errors import InputError

    try:
        return parse_node_id(text)
    except InputError as exc:
        names = [] if graph is None else room_names(graph)
        if not names:
            if _printed_id(text.strip()):  # an id's form (too large): its own error
                raise
            why, where = _no_names(graph)
            raise InputError(
                f"not a node id or room name: {text!r} ({why})",
                hint=f'node ids look like "p12" (see `aion predict MAP`); {where}',
            ) from exc
        raise InputError(
            f"not a node id or room name: {text!r}",
            hint='node ids look like "p12"; rooms and buildings by name: ' + ", ".join(names[:12]),
        ) from exc


def _no_names(graph: GraphSnapshot | None) -> tuple[str, str]:
    """Why a map has no room names to read a word as, and where names come from."""
    source = "room names are the room labels of a Hydra scene graph"
    if graph is None:
        return "the map has no scene graph, so no rooms", f"{source} (build with --graph FILE)"
    if len(graph.rooms) == 0 and len(graph.buildings) == 0:
        return (
            "the map's scene graph has no rooms",
            f"{source} that has rooms (a graph aion derives has places only)",
        )
    ids = [node_label(int(i)) for i in graph.rooms.ids[:6]]
    return "the map's rooms have no names", f"{source}; this map's rooms by id: {', '.join(ids)}"


def room_in_other_case(node_id: int, graph: GraphSnapshot) -> int | None:
    """The room or building of ``graph`` whose id is ``node_id`` with its letter in the other
    case (``R1`` for ``r1``: ids keep their letter's case, names do not), for a "did you
    mean"; None when there is none."""
    import numpy as np

    from aion_cli.engine.node_ids import other_case

    other = other_case(node_id)
    if other is None:
        return None
    wanted = np.uint64(other)
    held = bool((graph.rooms.ids == wanted).any() or (graph.buildings.ids == wanted).any())
    return other if held else None


def other_case_hint(nodes: Sequence[str | int], graph: GraphSnapshot) -> str | None:
    """``did you mean R1 (hallway)? ...`` when each of ``nodes`` (ids as given, not found)
    names a room or building of ``graph`` with its letter in the other case (``r1``), else
    None: the hint ``plan`` and ``predict`` give alike."""
    from aion_cli.errors import InputError

    guesses = []
    for node in nodes:
        try:
            node_id = node if isinstance(node, int) else parse_node_id(node.strip())
        except InputError:  # a hash cell's c<key>, or no id at all
            return None
        other = room_in_other_case(node_id, graph)
        if other is None:
            return None
        guesses.append(other)
    if not guesses:
        return None
    names = names_by_id(graph)
    said = ", ".join(
        label + (f" ({names[label]})" if label in names else "")
        for label in dict.fromkeys(node_label(g) for g in guesses)
    )
    return f"did you mean {said}? (ids are case-sensitive; room names are not)"


def name_of(layer: Layer, k: int) -> str | None:
    """The name the graph gives node ``k`` of ``layer`` ("kitchen"); None when it gives none,
    or only the node's id (``R3``)."""
    label = layer.labels[k] if k < len(layer.labels) else ""
    return label if label and label != node_label(int(layer.ids[k])) else None


def names_by_id(graph: GraphSnapshot) -> dict[str, str]:
    """The graph's names of its rooms and buildings by id as predict prints it ("R2":
    "kitchen"); those without a name of their own are left out."""
    out: dict[str, str] = {}
    for layer in (graph.rooms, graph.buildings):
        for k in range(len(layer)):
            name = name_of(layer, k)
            if name is not None:
                out[node_label(int(layer.ids[k]))] = name
    return out


def rooms_off_the_nav_layer(graph: GraphSnapshot) -> tuple[str, str] | None:
    """The error and hint for a graph that has rooms none of which holds a place of its
    navigational layer (a graph whose rooms hold its 3D places, ``PLACES``, while its 2D
    places, ``MESH_PLACES``, were taken as the navigational layer); None otherwise."""
    import numpy as np

    if len(graph.rooms) == 0 or np.isin(graph.places.parent, graph.rooms.ids).any():
        return None
    n = len(graph.rooms)
    return (
        f"none of the scene graph's {n:,} room{'s' if n != 1 else ''} holds a place of the "
        f"map's navigational layer ({graph.layer_name})",
        "its rooms hold places of another layer: rebuild with --nav-layer naming that layer "
        "(e.g. --nav-layer PLACES); `aion info GRAPH_FILE --nav-layer PLACES` shows how many "
        "of a layer's places are in a room",
    )


def room_names(graph: GraphSnapshot) -> list[str]:
    """The names of the graph's rooms and buildings (:func:`name_of`)."""
    return list(names_by_id(graph).values())


def _match_key(name: str) -> str:
    """What two spellings of one name share: case, runs of spaces and underscores ignored."""
    return " ".join(name.replace("_", " ").split()).casefold()


_SHELL_SAFE = re.compile(r"[\w.+:@%,=-]+")


def shell_word(name: str) -> str | None:
    """``name`` as one word a shell passes through unquoted ("office 1" -> "office_1"), which
    :func:`named_node` reads back; None for a name with characters a shell would interpret
    (quotes, ``$``, ``*``, ...)."""
    word = "_".join(name.split())
    return word if _SHELL_SAFE.fullmatch(word) else None


def named_node(text: str, graph: GraphSnapshot) -> int | None:
    """The room or building whose name is ``text`` (any case, ``_`` for a space; Hydra's
    room names, such as "kitchen" or "office 1"), or None when no name matches (then ``text``
    is read as an id); :class:`~aion_cli.errors.InputError` when two share the name. An id
    of a node ``graph`` holds is that node, whatever a room is named (a room named "p3"
    beside place p3: ``p3`` is the place, the room is asked for by its id)."""
    from aion_cli.errors import InputError

    held = _held_id(text, graph)
    if held is not None:
        return held
    wanted = _match_key(text)
    hits = [
        int(node_id)
        for layer in (graph.rooms, graph.buildings)
        for node_id, label in zip(layer.ids.tolist(), layer.labels, strict=False)
        if label and _match_key(label) == wanted
    ]
    if len(hits) > 1:
        raise InputError(
            f"{len(hits)} rooms are named {text!r}: "
            + ", ".join(node_label(h) for h in hits),
            hint="give the room's id instead",
        )
    return hits[0] if hits else None


def _held_id(text: str, graph: GraphSnapshot) -> int | None:
    """The node id ``text`` spells when ``graph`` holds that node (a place, room or
    building), else None."""
    import numpy as np

    from aion_cli.errors import InputError

    try:
        node_id = np.uint64(parse_node_id(text.strip()))
    except InputError:
        return None
    layers = (graph.places, graph.rooms, graph.buildings)
    return int(node_id) if any(bool((layer.ids == node_id).any()) for layer in layers) else None


def with_names_resolved(
    nodes: Sequence[str | int], graph: GraphSnapshot | None
) -> list[str | int]:
    """``nodes`` with every room or building name replaced by its id (others as given); a
    word that is neither a name nor an id is an error listing the graph's names, as ``plan``
    gives (``predict --node kitchn`` said only "not a node id"), or saying that the map has
    none (:func:`parse_id_or_name`)."""
    out: list[str | int] = []
    for node in nodes:
        named = named_node(node, graph) if isinstance(node, str) and graph is not None else None
        if named is None and isinstance(node, str):
            text = node.strip()
            if not _printed_id(text):  # predict's own ids are for the map to answer
                parse_id_or_name(text, graph)
        out.append(named if named is not None else node)
    return out


def _printed_id(text: str) -> bool:
    """Whether ``text`` has the form of an id ``predict`` prints: a category character and an
    index (``p12``, a hash cell's ``c<key>``, ``#67`` of a graph whose places are in category
    ``#``: :func:`~aion_cli.engine.node_ids.node_label` prints any printable ASCII one), which
    the map's entry table, not :func:`parse_node_id`, decides."""
    return len(text) > 1 and "!" <= text[0] <= "~" and text[1:].isascii() and text[1:].isdigit()
