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

The same holds between logs: a log whose first scene graph lacks places of the last graph of
the log before it (another Hydra session: its node ids are its own) would be built by a worker
only for its join to be refused. :func:`kept_together` keeps such logs in one group, built in
sequence, before any worker starts.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.types import I64

if TYPE_CHECKING:
    from aion_cli.build_options import BuildOptions
    from aion_cli.engine.types import GraphSnapshot
    from aion_cli.formats.raw import RawMessage
    from aion_cli.graph_feed import GraphFeed


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
    read by time, a graph does not decode). Robots at once logging one session's graphs
    (:func:`aion_cli.graph_owners.graphs_at_once`): the second part, whatever its graphs, as
    the map's graph is the union of each robot's latest graph (:mod:`aion_cli.session_graphs`)
    that a part built apart would start without the graphs before it."""
    if graph_times.size < 2 or len(parts) < 2:
        return None
    from aion_cli.build_options import build_topics
    from aion_cli.graph_owners import graphs_at_once

    topics = build_topics(logset, opts).names("graph")
    if not topics:
        return None
    if graphs_at_once(logset, topics):  # from the indexes, whether or not read by time
        return parts[1]
    if not logset.skips_by_time():
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


def kept_together(
    groups: list[tuple[Path, ...]], opts: BuildOptions, tolerance: float
) -> tuple[list[tuple[Path, ...]], str | None, frozenset[int]]:
    """``groups`` with every group whose first scene graph lost places of the group before
    it (:func:`aion_cli.shard_graphs.graph_breaks`: another Hydra session) joined to that
    group, a note naming them, and the indices of the groups so joined: such a group's join
    would be refused and its logs learnt again in sequence after a worker had built them (the
    parallel build of four simulated sessions took 0.88x the time of one pass), so they are
    built in sequence at once. A joined group is not cut into time shards either: a part
    after the first would hold the session boundary or follow it, and its graph changes
    there (:func:`changing_part` would refuse it after reading and decoding its times)."""
    breaks = graph_breaks(groups, opts, tolerance)
    if not any(breaks):
        return groups, None, frozenset()
    out = [groups[0]]
    joined = set()
    for group, lost in zip(groups[1:], breaks, strict=True):
        if lost:
            out[-1] = out[-1] + group
            joined.add(len(out) - 1)
        else:
            out.append(group)
    later = [g[0].name for g, lost in zip(groups[1:], breaks, strict=True) if lost]
    shown = ", ".join(later[:3]) + (", ..." if len(later) > 3 else "")
    note = (
        f"{shown}: {'their' if len(later) > 1 else 'its'} first scene graph lacks places of "
        "the log before (another session) or moved them: one pass releases them there, which "
        f"a shard built apart cannot know, so {'they are' if len(later) > 1 else 'it is'} "
        "built in sequence after the log before"
    )
    return out, note, frozenset(joined)


def graph_breaks(
    groups: list[tuple[Path, ...]], opts: BuildOptions, tolerance: float
) -> list[bool]:
    """Per boundary between consecutive ``groups`` of logs (in time order): whether the first
    scene graph of the later group lacks a place of the last graph of the earlier one, or has
    one moved farther than ``tolerance`` (another Hydra session, whose node ids are its own;
    a graph rebuilt). One pass releases those places at that graph, and a shard built apart
    from the earlier ones cannot know them, so its join would be refused and its logs learnt
    again in sequence (``engine.join_blockers.join_blocker``); the planner keeps such groups
    together instead. False where it cannot be told (no scene graph, no index, a graph that
    does not decode): the join decides then, as before.

    The two graphs are decoded only where their payloads differ: a fleet's logs that publish
    one saved graph cost two small reads per log, no decoding."""
    if len(groups) < 2 or opts.graph_file is not None:
        return [False] * max(len(groups) - 1, 0)
    ends = [_graph_ends(group, opts) for group in groups]
    out = []
    for k, (before, after) in enumerate(pairwise(ends)):
        if before is None or after is None:
            out.append(False)
        elif before.last_payload is not None and before.last_payload == after.first_payload:
            out.append(False)  # the same bytes: the same graph, nothing lost
        else:
            last = _decoded(groups[k], opts, before.last_ns)
            first = _first_graph(groups[k + 1], opts)
            out.append(
                last is not None and first is not None and places_lost(last, first, tolerance)
            )
    return out


@dataclass(frozen=True)
class _GraphEnds:
    """When a group's first and last scene graphs were logged, and their DsgUpdate payloads
    (None where one does not read); the first is the first the build uses
    (:func:`aion_cli.build_lineage.first_used_graph`: no stray log time, no partial update,
    no message whose payload does not read; a damaged payload is passed over when it is
    decoded, :func:`_first_graph`)."""

    first_ns: int
    last_ns: int
    first_payload: bytes | None
    last_payload: bytes | None


def _graph_ends(group: tuple[Path, ...], opts: BuildOptions) -> _GraphEnds | None:
    """:class:`_GraphEnds` of a group of logs; None where there is no scene graph or the logs
    cannot be read by time."""
    from aion_cli.build_lineage import first_used_graph
    from aion_cli.build_options import build_topics
    from aion_cli.errors import AionError
    from aion_cli.formats.logs import open_logs

    try:
        with open_logs(list(group), opts.log_format) as logset:
            topics = build_topics(logset, opts).names("graph")
            if not topics or not logset.skips_by_time():
                return None
            found = logset.index_times(topics)
            if found is None or len(found) == 0:
                return None
            used = first_used_graph(
                group, opts.log_format, logset, topics, lambda m: _payload(logset, opts, m)
            )
            if used is None:
                return None
            last = int(np.max(np.asarray(found.t, dtype=np.int64)))
            last_payload = _payload_at(logset, opts, topics, last)
            return _GraphEnds(used.msg.log_time_ns, last, used.value, last_payload)
    except AionError:  # the build reports what it cannot read
        return None


def _payload(logset: Any, opts: BuildOptions, msg: RawMessage) -> bytes | None:
    """A DsgUpdate's payload as the build reads it (``GraphFeed.payload``), without decoding
    the graph; None for a partial update or a message that does not read."""
    from aion_cli.errors import AionError

    try:
        return bytes(_feed(opts).payload(logset, msg)[0])
    except AionError:
        return None


def _first_graph(group: tuple[Path, ...], opts: BuildOptions) -> GraphSnapshot | None:
    """The first scene graph a group of logs' build applies, decoded as the build decodes it
    (:func:`aion_cli.build_lineage.first_used_graph`; a damaged one is passed over as the
    stream passes it over); None where none does."""
    from aion_cli.build_lineage import first_used_graph
    from aion_cli.build_options import build_topics
    from aion_cli.errors import AionError
    from aion_cli.formats.logs import open_logs

    try:
        with open_logs(list(group), opts.log_format) as logset:
            topics = build_topics(logset, opts).names("graph")
            feed = _feed(opts)
            used = first_used_graph(
                group, opts.log_format, logset, topics, lambda m: feed.peek(logset, m)
            )
            return None if used is None else used.value
    except AionError:
        return None


def _payload_at(logset: Any, opts: BuildOptions, topics: set[str], t_ns: int) -> bytes | None:
    """The DsgUpdate payload logged at ``t_ns`` on ``topics``, as the build reads it
    (``GraphFeed.payload``), without decoding the graph (None: none there, or it does not
    read)."""
    from aion_cli.errors import AionError

    msg = _message_at(logset, topics, t_ns)
    if msg is None:
        return None
    try:
        return bytes(_feed(opts).payload(logset, msg)[0])
    except AionError:
        return None


def _decoded(group: tuple[Path, ...], opts: BuildOptions, t_ns: int) -> GraphSnapshot | None:
    """The scene graph a group of logs logged at ``t_ns``, decoded as the build decodes it
    (None where it does not decode)."""
    from aion_cli.build_options import build_topics
    from aion_cli.errors import AionError
    from aion_cli.formats.logs import open_logs

    try:
        with open_logs(list(group), opts.log_format) as logset:
            topics = build_topics(logset, opts).names("graph")
            return _graph_at(logset, opts, topics, t_ns)
    except AionError:
        return None


def places_lost(before: GraphSnapshot, after: GraphSnapshot, tolerance: float) -> bool:
    """Whether places of ``before`` are not in ``after``, or are but moved farther than
    ``tolerance`` (3D); places ``after`` adds do not count."""
    ids_b, ids_a = before.places.ids, after.places.ids
    if len(ids_b) == 0:
        return False
    order = np.argsort(ids_a, kind="stable")
    at = np.searchsorted(ids_a[order], ids_b)
    at_c = np.minimum(at, max(len(ids_a) - 1, 0))
    present = (at < len(ids_a)) & (ids_a[order][at_c] == ids_b) if len(ids_a) else at < 0
    if not present.all():
        return True
    step = after.places.xyz[order][at_c] - before.places.xyz
    return bool(np.any(np.sqrt(np.sum(step**2, axis=1)) > tolerance))


def places_changed(a: GraphSnapshot, b: GraphSnapshot, tolerance: float) -> bool:
    """Whether ``b``'s navigational places are not ``a``'s: other ids, or one moved farther
    than ``tolerance`` (3D): places lost either way (:func:`places_lost`)."""
    return places_lost(a, b, tolerance) or places_lost(b, a, tolerance)


def _graph_at(
    logset: Any, opts: BuildOptions, topics: set[str], t_ns: int
) -> GraphSnapshot | None:
    """The scene graph logged at ``t_ns`` (the first message of ``topics`` at that time),
    decoded as the build decodes it; None when there is none or it does not decode."""
    from aion_cli.errors import AionError

    msg = _message_at(logset, topics, t_ns)
    if msg is None:
        return None
    try:
        return _feed(opts).decode(logset, msg)
    except AionError:
        return None


def _message_at(logset: Any, topics: set[str], t_ns: int) -> RawMessage | None:
    """The first message of ``topics`` logged at ``t_ns`` (None: none)."""
    for msg in logset.messages(topics, (t_ns, t_ns + 1)):
        if msg.log_time_ns > t_ns:
            return None
        if msg.log_time_ns == t_ns and msg.topic in topics:
            return msg
    return None


def _feed(opts: BuildOptions) -> GraphFeed:
    """A graph reader with the build's version and layer choice, whose counts are its own
    (not the build's)."""
    from aion_cli.build_report import BuildReport
    from aion_cli.graph_feed import GraphFeed

    return GraphFeed(BuildReport(Path()), opts.dsg_version, opts.nav_layer, 0)
