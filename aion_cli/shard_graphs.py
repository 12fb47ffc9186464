"""Whether the parts of a log cut into time shards keep their scene graph: cut only where a
part can join.

A part of a log learnt apart binds its cells to the places of its own graph. Where that graph
changes inside the part — a live Hydra stream adds places as the robot explores, merges and
moves them at loop closures — ownership changes after the part's first day has closed, which
its join cannot replay: the part is learnt again in sequence, built twice on the same cores
(a single simulated Hydra log took 18 % longer with two workers than with one). So before a
log is cut, :func:`changing_part` compares, for every part after the first, the first and the
last scene graph logged in it, decoded with the build's own reader: other place ids, or a
place moved farther than ``stable_move_tolerance`` (the distance at which ownership moves),
means the graph changes there and the log is left whole. A graph that stays (a saved map
published again, places that drift by millimetres) keeps the cut. Where the log cannot be
read a few seconds at a time, or a graph does not decode, the parts are kept and the join
decides, as before.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.types import I64

if TYPE_CHECKING:
    from aion_cli.build_options import BuildOptions
    from aion_cli.engine.types import GraphSnapshot


def changing_part(
    logset: Any,
    opts: BuildOptions,
    graph_times: I64,
    parts: list[tuple[int, int]],
    tolerance: float,
) -> tuple[int, int] | None:
    """The first of ``parts`` after the first whose scene graph changes inside it (its
    first and last graph, at ``graph_times``, sorted, differ; ``tolerance``: the model's
    ``stable_move_tolerance``); None when none does or it cannot be told (the log is not
    read by time, a graph does not decode)."""
    if graph_times.size < 2 or len(parts) < 2 or not logset.skips_by_time():
        return None
    from aion_cli.build_options import build_topics

    topics = build_topics(logset.topics, opts).names("graph")
    if not topics:
        return None
    for lo, hi in parts[1:]:
        inside = graph_times[(graph_times >= lo) & (graph_times < hi)]
        if inside.size < 2 or inside[0] == inside[-1]:
            continue
        first = _graph_at(logset, opts, topics, int(inside[0]))
        last = _graph_at(logset, opts, topics, int(inside[-1]))
        if first is None or last is None:
            return None
        if places_changed(first, last, tolerance):
            return lo, hi
    return None


def places_changed(a: GraphSnapshot, b: GraphSnapshot, tolerance: float) -> bool:
    """Whether ``b``'s navigational places are not ``a``'s: other ids, or one moved farther
    than ``tolerance`` (3D)."""
    ids_a, ids_b = np.sort(a.places.ids), np.sort(b.places.ids)
    if not np.array_equal(ids_a, ids_b):
        return True
    xyz_a = a.places.xyz[np.argsort(a.places.ids, kind="stable")]
    xyz_b = b.places.xyz[np.argsort(b.places.ids, kind="stable")]
    moved = np.sqrt(np.sum((xyz_a - xyz_b) ** 2, axis=1)) if len(xyz_a) else np.zeros(0)
    return bool(np.any(moved > tolerance))


def _graph_at(
    logset: Any, opts: BuildOptions, topics: set[str], t_ns: int
) -> GraphSnapshot | None:
    """The scene graph logged at ``t_ns`` (the first message of ``topics`` at that time),
    decoded as the build decodes it; None when there is none or it does not decode."""
    from aion_cli.build_report import BuildReport
    from aion_cli.errors import AionError
    from aion_cli.graph_feed import GraphFeed

    for msg in logset.messages(topics, (t_ns, t_ns + 1)):
        if msg.log_time_ns > t_ns:
            return None
        if msg.log_time_ns == t_ns and msg.topic in topics:
            counts = BuildReport(Path())  # the decode's counts, not the build's
            feed = GraphFeed(counts, opts.dsg_version, opts.nav_layer, 0)
            try:
                return feed.decode(logset, msg)
            except AionError:
                return None
    return None
