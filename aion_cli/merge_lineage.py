"""Which lineage a merge uses: whether the maps' node ids name the same places.

Node ids mean the same place only within one scene-graph session (Hydra numbers every
session's places from p0). ``"same"``: the maps' node entries add by id. ``"different"``:
every map releases its node entries to hash cells first and the merged map binds to the
target graph. :func:`choose_lineage` takes the user's ``--lineage`` or, for ``"auto"``, decides
from the graphs (the rules are in :mod:`aion_cli.merging`'s docstring) and says why.

Why apart from :mod:`aion_cli.merging`: the decision reads only each map's latest graph and
the bind radius, and is the one part of a merge a user asks about ("why different?").
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from pathlib import Path

    from aion_cli.engine.types import GraphSnapshot
    from aion_cli.mapquery import MapHead

__all__ = ["LINEAGES", "LineageInput", "check_lineage", "choose_lineage"]

LINEAGES = ("auto", "same", "different")
"""What ``--lineage`` takes, for ``aion merge`` and ``aion build --map`` alike."""


def check_lineage(lineage: str) -> None:
    """:class:`InputError` unless ``lineage`` is one of :data:`LINEAGES`."""
    from aion_cli.errors import InputError

    if lineage not in LINEAGES:
        raise InputError(f"unknown lineage {lineage!r}", hint=f"one of {', '.join(LINEAGES)}")


class LineageInput(Protocol):
    """What the decision reads of an input map: its name, latest graph and head (config)."""

    @property
    def name(self) -> str: ...

    @property
    def graph(self) -> GraphSnapshot | None: ...

    @property
    def head(self) -> MapHead: ...


def choose_lineage(
    maps: Sequence[LineageInput],
    lineage: str,
    notes: list[str],
    target: GraphSnapshot | None = None,
    graph_file: Path | None = None,
) -> tuple[str, str]:
    """The lineage to use and why (``lineage`` given, or decided from the graphs: the maps'
    with each other, then a ``--graph`` target with the newest of them, which the merged
    map binds to)."""
    auto, why = _auto_lineage(maps)
    if auto == "same" and target is not None and graph_file is not None:
        auto, why = _target_lineage(maps, target, graph_file, why)
    if lineage == "auto":
        return auto, why
    if lineage != auto:
        notes.append(f"--lineage {lineage} given; auto would choose {auto} ({why})")
    return lineage, "given with --lineage"


def _target_lineage(
    maps: Sequence[LineageInput], target: GraphSnapshot, graph_file: Path, why: str
) -> tuple[str, str]:
    """``"different"`` when the ``--graph`` target holds the newest map's place ids at other
    places (another scene-graph session numbers its places from p0 again: its p0 is not the
    maps' p0), else ``"same"`` with ``why`` unchanged. Ids the target lacks release at the
    bind either way."""
    from aion_cli.engine.rebind import graph_agreement

    newest = next((m for m in reversed(maps) if m.graph is not None), None)
    if newest is None:
        return "same", why
    tolerance = maps[0].head.config.bind_radius
    agreement = graph_agreement(newest.graph, target, tolerance)
    if agreement.shared == 0 or agreement.same:
        return "same", why
    return "different", (
        f"of the {agreement.shared} node ids both {newest.name} and the target graph "
        f"{graph_file.name} hold, {agreement.agreeing} lie within {tolerance:g} m (the target "
        "is another scene-graph session)"
    )


def _auto_lineage(maps: Sequence[LineageInput]) -> tuple[str, str]:
    from aion_cli.engine.rebind import graph_agreement

    if len(maps) == 1:  # a part map merged alone: nothing to compare
        return "same", "one map"
    without = [m.name for m in maps if m.graph is None]
    if len(without) == len(maps):
        return "same", "no map has a scene graph (hash cells only)"
    if without:
        return "different", f"{without[0]} has no scene graph: its cells bind to the target graph"
    tolerance = maps[0].head.config.bind_radius
    shared = agreeing = 0
    for early, late in pairwise(maps):
        agreement = graph_agreement(early.graph, late.graph, tolerance)
        what = (
            f"of the {agreement.shared} node ids both {early.name} and {late.name} hold, "
            f"{agreement.agreeing} lie within {tolerance:g} m"
        )
        if not agreement.same:
            if agreement.shared == 0:
                what = f"{early.name} and {late.name} share no node id"
            return "different", what + " (different scene-graph sessions)"
        shared += agreement.shared
        agreeing += agreement.agreeing
    return "same", f"{agreeing} of {shared} shared node ids lie within {tolerance:g} m"
