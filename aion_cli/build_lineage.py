"""Whether ``aion build --map MAP --graph FILE`` goes on in MAP's scene-graph session.

Node ids mean the same place only within one session (Hydra numbers every session's places
from p0): a graph file of another session given to a continued map would take over MAP's
node entries by id and bind its flows to unrelated places. :func:`continue_on_graph` asks
the same question ``aion merge`` asks of a ``--graph`` target
(:func:`aion_cli.engine.rebind.graph_agreement`): of the place ids both graphs hold, do most
lie within the bind radius? ``--lineage auto`` refuses a graph that says no; ``same`` takes
the user's word (ids add by id); ``different`` releases MAP's node entries to hash cells
first (:func:`aion_cli.engine.rebind.release_all`, as ``aion merge --lineage different``
does), which the build then binds to the file's places as it binds a map of cells only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from aion_cli.errors import InputError

if TYPE_CHECKING:
    from pathlib import Path

    from aion_cli.mapquery import LoadedMap

LINEAGES = ("auto", "same", "different")


def continue_on_graph(
    loaded: LoadedMap,
    name: str,
    graph_file: Path | None,
    nav_layer: str | None,
    lineage: str,
    notes: list[str],
) -> None:
    """Check (``auto``) or apply (``different``: release every node entry of ``loaded``, in
    place) the ``lineage`` of the continued map ``loaded`` (file ``name``) and the graph file
    ``graph_file`` it is built on; notes go to ``notes``. :class:`InputError` when ``auto``
    finds the file's place ids at other places than the map's (another session)."""
    if lineage not in LINEAGES:
        raise InputError(f"unknown lineage {lineage!r}", hint=f"one of {', '.join(LINEAGES)}")
    if graph_file is None:
        if lineage != "auto":
            notes.append(f"--lineage {lineage} ignored: no --graph FILE to continue the map on")
        return
    if lineage == "same" or loaded.graph is None:  # the user's word; a map of cells only
        return
    if lineage == "different":
        from aion_cli.engine.rebind import release_all

        released = release_all(loaded.state)
        loaded.graph = None
        notes.append(
            f"--lineage different: {name}'s {released:,} node entries were released to hash "
            f"cells, which bind to {graph_file.name}'s places as the build goes"
        )
        return
    from aion_cli.engine.rebind import graph_agreement
    from aion_cli.formats.dsg import load_graph

    target = load_graph(graph_file, 0, nav_layer).snapshot
    tolerance = loaded.config.bind_radius
    agreement = graph_agreement(loaded.graph, target, tolerance)
    if agreement.shared == 0 or agreement.same:
        return  # ids the file lacks release at the bind, by position
    raise InputError(
        f"{graph_file.name} is a scene graph of another session than {name}'s: of the "
        f"{agreement.shared:,} place ids both hold, {agreement.agreeing:,} lie within "
        f"{tolerance:g} m, so {name}'s flows would go to unrelated places",
        hint="if it is another session, add --lineage different (the map's places are "
        "released to hash cells and re-bound to the file's); if it is the map's own session "
        "whose places moved, add --lineage same",
    )
