"""Applying a build's graph schedule (:func:`aion_cli.graph_schedule.graph_schedule`) to the
stream: :func:`thin_graphs` drops the scene graphs the schedule leaves out, and stands in the
next whole graph of the same window for a used graph that turns out to be a partial update
(``full_update`` false, which the stream skips): the schedule is decided on log times alone,
before the stream, and cannot tell partial updates apart."""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aion_cli.build_report import ProgressSink
    from aion_cli.formats.raw import RawMessage
    from aion_cli.graph_feed import GraphFeed


def thin_graphs(
    feed: GraphFeed,
    messages: Iterator[RawMessage],
    graph_topics: set[str],
    progress: ProgressSink,
    logset: Any = None,
) -> Iterator[RawMessage]:
    """The stream without the scene graphs ``feed``'s schedule leaves out (counted in
    ``graphs_skipped_period``, the progress bar still advances). They go before the detection
    chunks are cut, so a skipped graph neither cuts the Mapper's feed into smaller pieces nor
    is decoded. Every message passes when every graph is used.

    With ``logset``, a used graph that is a partial update does not leave its period without
    a graph: the next whole graph logged in the same window (``feed.window_ns``; a shard of a
    parallel build starts at a window, so one pass and shards choose alike) is used too. Only
    the used graphs and those looked at for a stand-in are read for their flag, once: each
    goes on with what was read of it (:meth:`GraphFeed.is_whole`), which its decoding uses.
    When every graph is used, ``messages`` itself (no generator step per message)."""
    used = feed.used
    if used is None or bool(used.all()):
        return messages
    return _thinned(feed, messages, graph_topics, progress, logset, used.tolist())


def _thinned(
    feed: GraphFeed,
    messages: Iterator[RawMessage],
    graph_topics: set[str],
    progress: ProgressSink,
    logset: Any,
    flags: list[bool],
) -> Iterator[RawMessage]:
    """:func:`thin_graphs` when the schedule leaves graphs out (``flags``: used or not, per
    graph message in order)."""
    from aion_cli.formats.raw import Unread

    window_ns = feed.window_ns

    def window(msg: RawMessage) -> int:
        return msg.log_time_ns // window_ns if window_ns > 0 else 0

    k = 0
    wanted: int | None = None  # the window of a used partial update, awaiting its stand-in
    for msg in messages:
        if msg.topic in graph_topics:
            keep = k >= len(flags) or flags[k]
            k += 1
            whole: bool | None = None  # not read yet
            if keep:
                wanted = None
            elif wanted is not None and not isinstance(msg.data, Unread):
                same = window(msg) == wanted
                if same:
                    whole, msg = feed.is_whole(logset, msg)
                keep = bool(whole)
                if keep or not same:
                    wanted = None
            if not keep:
                feed.report.graphs_skipped_period += 1
                progress.advance(1)
                continue
            if isinstance(msg.data, Unread):  # unread_hint named only graphs left out
                raise RuntimeError(
                    f"a scene graph at {msg.log_time_ns} ns was left unread but is used"
                )
            if logset is not None and whole is None:
                whole, msg = feed.is_whole(logset, msg)  # msg: with the fields read of it
                if not whole:
                    wanted = window(msg)
        yield msg
