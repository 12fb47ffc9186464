"""Which scene graph a merged map keeps (``aion merge`` without ``--graph``), as one build of
the maps' logs would keep it.

* Lineage ``"same"``, maps one after the other: the newest map's latest graph, which the
  engine's merge keeps (:func:`aion_cli.engine.merge.merge_maps`: the later map is the
  base), as a later log's graph replaces an earlier one's in one build.
* Lineage ``"same"``, maps whose time spans overlap (two robots of one session at once,
  directly or through others: :func:`aion_cli.tf_trees.overlap_groups`): the union of their
  latest graphs (:func:`aion_cli.engine.graph_union.union_graphs`: a place while any of them
  holds it, at the position of the newest graph that holds it), as one build of their logs
  joins one session's robots' graphs (:mod:`aion_cli.session_graphs`). The engine's merge
  kept only the later map's graph and released the places it lacks to hash cells; binding
  to the union gives them back. Only the last such group counts: a later group's graph
  replaces an earlier one's, in one build as here.
* Lineage ``"different"``: the newest map's latest graph, which every map's released cells
  bind to; of maps whose spans overlap, the one whose latest graph is the newest (its time,
  not the map's start: a robot that started later may have stopped first). One build refuses
  robots of two sessions at once; the fleet's map binds to the newest graph.

Why a module of its own: :mod:`aion_cli.merging` reads, checks and folds the maps; which graph
the result keeps is one decision, read from the maps' heads alone, that the report names.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from aion_cli.engine.types import GraphSnapshot
    from aion_cli.manifest import Manifest

__all__ = ["GraphInput", "merged_graph"]


class GraphInput(Protocol):
    """What the choice reads of an input map: its name, latest graph and manifest (span)."""

    @property
    def name(self) -> str: ...

    @property
    def graph(self) -> GraphSnapshot | None: ...

    @property
    def manifest(self) -> Manifest: ...


def merged_graph(
    maps: Sequence[GraphInput], lineage: str, kept: GraphSnapshot | None
) -> tuple[GraphSnapshot | None, str]:
    """The graph the merged map binds to (None: the graph ``kept`` by the engine's merge
    stays, no bind) and how the report names where it comes from (``"none"`` without any
    graph). ``maps`` in time order (by start); see the module docstring."""
    with_graph = [m for m in maps if m.graph is not None]
    if not with_graph:
        return None, "none"
    at_once = _last_group(with_graph)
    if lineage == "different":  # maps one after the other: the last; at once: the newest
        newest = max(reversed(at_once), key=_graph_time)  # the later map on a tie
        return newest.graph, f"{newest.name}'s latest graph"
    if len(at_once) > 1:
        from aion_cli.engine.graph_union import union_graphs

        ordered = sorted(at_once, key=_graph_time)  # newest last: its positions win
        union = union_graphs([m.graph for m in ordered if m.graph is not None])
        if kept is None or not _same_places(union, kept):
            names = ", ".join(m.name for m in ordered[:-1]) + f" and {ordered[-1].name}"
            return union, f"the union of {names}'s latest graphs (maps at once)"
    owner = _owner(with_graph, kept)
    return None, f"{owner.name}'s latest graph"


def _graph_time(m: GraphInput) -> int:
    return -1 if m.graph is None else int(m.graph.t_ns)


def _last_group(maps: Sequence[GraphInput]) -> list[GraphInput]:
    """The maps of the last group of ``maps`` whose time spans overlap (one map alone when
    the last overlaps none; maps without a span are each their own)."""
    from aion_cli.tf_trees import overlap_groups

    spans: dict[int, tuple[int, int]] = {}
    for k, m in enumerate(maps):
        lo, hi = m.manifest.start_ns, m.manifest.end_ns
        if lo is not None and hi is not None:
            spans[k] = (lo, hi)
    groups = overlap_groups(spans)
    if len(groups) < 2:
        return list(maps[-1:])
    last = max(groups.values())
    return [maps[k] for k, g in groups.items() if g == last]


def _same_places(a: GraphSnapshot, b: GraphSnapshot) -> bool:
    """Whether ``a`` and ``b`` hold the same place ids (the union adds none to the kept)."""
    import numpy as np

    return bool(np.array_equal(np.sort(a.places.ids), np.sort(b.places.ids)))


def _owner(maps: Sequence[GraphInput], kept: GraphSnapshot | None) -> GraphInput:
    """The map whose latest graph the engine's merge kept (its time and places), else the
    last map with a graph."""
    if kept is not None:
        for m in reversed(maps):
            g = m.graph
            if g is not None and g.t_ns == kept.t_ns and _same_places(g, kept):
                return m
    return maps[-1]
