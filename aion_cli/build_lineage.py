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

Without ``--graph FILE`` the logs' own scene graphs (DsgUpdate messages) are asked the same
question (:func:`check_log_graph`): the first one the build applies (a sequential build) or
the same one peeked (the parent of a parallel build, :mod:`aion_cli.parallel_build`, whose
shards do not see MAP: :func:`first_applied_graph`, which skips what the stream skips before
its first graph: stray and unrepresentable log times, damaged messages); ``different``
releases MAP's node entries before the stream (:func:`release_for_logs`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from aion_cli.errors import InputError
from aion_cli.merge_lineage import check_lineage

if TYPE_CHECKING:
    from pathlib import Path

    from aion_cli.engine.rebind import Agreement
    from aion_cli.engine.types import GraphSnapshot
    from aion_cli.formats.raw import RawMessage
    from aion_cli.mapquery import LoadedMap

T = TypeVar("T")

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
    check_lineage(lineage)
    if graph_file is None:  # the logs' own graphs, if any: check_log_graph, release_for_logs
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
    raise _another_session(f"{graph_file.name} is a scene graph", name, agreement, tolerance)


def _another_session(what: str, name: str, agreement: Agreement, tolerance: float) -> InputError:
    """The refusal of ``what`` (a graph file, the logs' scene graph) of another session than
    the continued map ``name``'s."""
    return InputError(
        f"{what} of another session than {name}'s: of the "
        f"{agreement.shared:,} place ids both hold, {agreement.agreeing:,} lie within "
        f"{tolerance:g} m, so {name}'s flows would go to unrelated places",
        hint="if it is another session, add --lineage different (the map's places are "
        "released to hash cells and re-bound to the graph's); if it is the map's own session "
        "whose places moved, add --lineage same",
    )


def release_for_logs(
    loaded: LoadedMap, name: str, logs_have_graphs: bool, lineage: str, notes: list[str]
) -> None:
    """Without ``--graph FILE``: ``--lineage different`` releases every node entry of the
    continued map ``loaded`` (file ``name``) to hash cells before the logs' scene graphs
    (``logs_have_graphs``) come, which then bind them by position; a lineage the logs give
    nothing to decide is noted as ignored."""
    if lineage == "auto":
        return
    if not logs_have_graphs:
        notes.append(
            f"--lineage {lineage} ignored: neither --graph FILE nor scene graphs in the logs "
            "to continue the map on"
        )
        return
    if lineage == "different" and loaded.graph is not None:  # (a map of cells: nothing to)
        from aion_cli.engine.rebind import release_all

        released = release_all(loaded.state)
        loaded.graph = None
        notes.append(
            f"--lineage different: {name}'s {released:,} node entries were released to hash "
            "cells, which bind to the logs' scene-graph places as the build goes"
        )


def check_log_graph(
    map_graph: GraphSnapshot, name: str, first: GraphSnapshot, logs: str, tolerance: float
) -> None:
    """``--lineage auto`` without ``--graph FILE``: :class:`InputError` when ``first``, the
    first scene graph of the logs ``logs`` (their names), holds the place ids of the continued
    map ``name``'s graph ``map_graph`` at other places (another Hydra session). A graph
    sharing no place id, or whose shared ids mostly lie within ``tolerance``, goes on."""
    from aion_cli.engine.rebind import graph_agreement

    agreement = graph_agreement(map_graph, first, tolerance)
    if agreement.shared == 0 or agreement.same:
        return
    raise _another_session(f"the scene graph in {logs} is", name, agreement, tolerance)


def other_session(before: GraphSnapshot, after: GraphSnapshot, tolerance: float) -> bool:
    """Whether ``after`` holds place ids of ``before`` mostly farther than ``tolerance``
    from their places in ``before`` (another Hydra session, which numbers its places from p0
    again: :func:`aion_cli.engine.rebind.graph_agreement`, ``aion merge``'s lineage test);
    False when they share no place id."""
    from aion_cli.engine.rebind import graph_agreement

    agreement = graph_agreement(before, after, tolerance)
    return agreement.shared > 0 and not agreement.same


def first_applied_graph(
    logs: list[Path],
    log_format: str | None,
    logset: Any,
    topics: set[str],
    peek: Callable[[RawMessage], GraphSnapshot | None],
) -> GraphSnapshot | None:
    """The first scene graph on ``topics`` that one pass over ``logs`` (open as ``logset``)
    applies, decoded by ``peek`` (None: it does not decode): :func:`first_used_graph`'s."""
    found = first_used_graph(logs, log_format, logset, topics, peek)
    return None if found is None else found.value


@dataclass(frozen=True)
class FirstUsed(Generic[T]):
    """The first graph message a build uses (``msg``), what ``peek`` read of it (``value``)
    and how many graph messages came before it in the stream, left out (``passed``: stray or
    out-of-range log times, damaged messages, partial updates)."""

    msg: RawMessage
    value: T
    passed: int


def first_used_graph(
    logs: list[Path] | tuple[Path, ...],
    log_format: str | None,
    logset: Any,
    topics: set[str],
    peek: Callable[[RawMessage], T | None],
) -> FirstUsed[T] | None:
    """The first scene-graph message on ``topics`` that one pass over ``logs`` (open as
    ``logset``) uses, with what ``peek`` read of it: the first message the time rules keep
    (:mod:`aion_cli.log_times`: a stray log time, a day from the topic's others, or one out
    of range is dropped; its topic's times read from the indexes, else from the messages, in
    a set of logs of their own, which vouches for nothing the caller reads) that ``peek``
    reads (None: a damaged message or a partial update, which the stream skips,
    :meth:`aion_cli.graph_feed.GraphFeed.decode_or_skip`). The first graph to come
    (``--graph-period`` always uses it). None when none is left. The one notion of "the first
    graph the build uses" of the lineage check, ``aion info`` and the parallel build's
    grouping (:mod:`aion_cli.shard_graphs`)."""
    from aion_cli.formats.logs import open_logs
    from aion_cli.log_times import TopicTimes

    times = TopicTimes(topics)
    with open_logs(list(logs), log_format) as own:
        indexed = own.index_times(topics)
        if indexed is not None:
            times.add_stream(indexed)
        else:
            early = _settled_early(own.messages(topics), peek)
            if early is not None:
                return early
            for msg in own.messages(topics):
                times.add(msg.topic, msg.log_time_ns)
        recordings = list(own.recording_times().values())
    seen = [0]

    def counted(messages: Iterator[RawMessage]) -> Iterator[RawMessage]:
        for msg in messages:
            seen[0] += 1
            yield msg

    for msg in times.check(topics, recordings).filter(counted(logset.messages(topics))):
        value = peek(msg)
        if value is not None:
            return FirstUsed(msg, value, seen[0] - 1)
    return None


def _settled_early(
    messages: Iterator[RawMessage], peek: Callable[[RawMessage], T | None]
) -> FirstUsed[T] | None:
    """:func:`first_used_graph` of a log without an index, from the first graph messages
    alone where they settle it (None: they do not; the caller reads every graph's time).
    A message in a run of more than ``STRAY_MAX_MESSAGES`` of its topic's times without a
    ``STRAY_GAP_NS`` gap is never a stray (:func:`aion_cli.log_times.stray_mask`; more
    messages only join runs, and a recording's own run is only ever kept), so once the
    in-range messages read so far put each one up to the first that ``peek`` reads in such a
    run, that one is the answer the whole log's times would give. Reads at most
    ``4 * (STRAY_MAX_MESSAGES + 1)`` in-range messages."""
    import numpy as np

    from aion_cli.engine.mapper import MAX_TIME_NS, MIN_TIME_NS
    from aion_cli.log_times import STRAY_GAP_NS, STRAY_MAX_MESSAGES

    need, limit = STRAY_MAX_MESSAGES + 1, 4 * (STRAY_MAX_MESSAGES + 1)
    held: list[tuple[int, RawMessage]] = []  # (messages before it, message), in-range only
    times: dict[str, list[int]] = {}
    seen = 0
    for msg in messages:
        seen += 1
        if not MIN_TIME_NS <= msg.log_time_ns <= MAX_TIME_NS:
            continue
        held.append((seen - 1, msg))
        times.setdefault(msg.topic, []).append(msg.log_time_ns)
        if len(held) >= limit:
            break
    for before, msg in held:
        t = np.sort(np.asarray(times[msg.topic], dtype=np.int64))
        cuts = np.concatenate([[0], np.flatnonzero(np.diff(t) > STRAY_GAP_NS) + 1, [t.size]])
        at = int(np.searchsorted(cuts, np.searchsorted(t, msg.log_time_ns), "right"))
        if int(cuts[at] - cuts[at - 1]) < need:
            return None  # it may be a stray: the whole log's times decide
        value = peek(msg)
        if value is not None:
            return FirstUsed(msg, value, before)
    return None
