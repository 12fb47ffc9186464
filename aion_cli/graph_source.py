"""Where a build's scene graph comes from (:func:`graph_source`): ``--graph FILE``, the log's
scene-graph stream (read by :class:`aion_cli.graph_feed.GraphFeed`), the continued map's graph,
``--derive-graph``, or none; the options that had no effect become notes of the report.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from aion_cli.engine.types import GraphSnapshot
from aion_cli.graph_notes import NO_GRAPH_NOTES
from aion_cli.topics import FRONTEND_REASON, several_graph_topics

if TYPE_CHECKING:
    from aion_cli.build_report import BuildReport
    from aion_cli.topics import TopicPlan

__all__ = ["GraphOptions", "graph_source"]


class GraphOptions(Protocol):
    """The build options :func:`graph_source` reads (``pipeline.BuildOptions`` has them)."""

    @property
    def graph_file(self) -> Path | None: ...
    @property
    def nav_layer(self) -> str | None: ...
    @property
    def derive_graph(self) -> bool: ...


def graph_source(
    report: BuildReport,
    plan: TopicPlan,
    opts: GraphOptions,
    continued_graph: bool,
    start: int,
    derive: Callable[[], GraphSnapshot],
    graph_topics_at_once: Callable[[], list[str]],
    graph_streams_at_once: Callable[[], tuple[str, list[str], list[str]] | None],
) -> GraphSnapshot | None:
    """Where the map's graph comes from, in this order: ``--graph FILE`` (the log's scene
    graphs are then ignored), the log's scene-graph stream (read by :class:`GraphFeed`;
    refused when ``graph_topics_at_once`` names topics whose graphs would take turns, or
    ``graph_streams_at_once`` a topic on which robots recording at once carry graphs of other
    sessions: :mod:`aion_cli.graph_owners`), the
    continued map's graph (``continued_graph``), ``--derive-graph`` (``derive``: where people
    walk), else none (flows on hash cells). Says which in ``report.graph_source`` (with the
    options that had no effect as notes) and returns the graph added once at ``start``, the
    log's first time (None: no graph, or the stream's)."""
    if opts.graph_file is not None:
        from aion_cli.formats.dsg import load_graph

        if plan.graph:
            report.notes.append("--graph given: scene graphs in the log are ignored")
            plan.graph = []
        if opts.derive_graph:
            report.notes.append("--derive-graph ignored: the places are --graph FILE's")
        report.graph_source = f"file {opts.graph_file.name}"
        loaded = load_graph(opts.graph_file, start, opts.nav_layer)
        report.graph_layer = str(loaded.nav.layer)
        report.notes.extend(loaded.notes())
        return loaded.snapshot
    if len(plan.graph) > 1 and (clash := graph_topics_at_once()):
        raise several_graph_topics(clash)
    if plan.graph and (robots := graph_streams_at_once()) is not None:
        from aion_cli.graph_owners import graphs_at_once_error

        raise graphs_at_once_error(*robots)
    if plan.graph:
        report.graph_source = "log"
        report.graph_topics = sorted(plan.names("graph"))
        left = sorted(topic for topic, why in plan.reasons.items() if why == FRONTEND_REASON)
        if left:
            report.notes.append(f"{', '.join(left)} left out: {FRONTEND_REASON}")
        if opts.derive_graph:
            report.notes.append("--derive-graph ignored: the log has scene graphs")
        return None
    if opts.nav_layer is not None:
        report.notes.append(NO_GRAPH_NOTES[1])
    if continued_graph:
        report.graph_source = "continued map"
        if opts.derive_graph:
            report.notes.append(
                "--derive-graph ignored: the continued map keeps its places (derived from the "
                "logs of its first build); to derive places from every log, build them at once"
            )
        return None
    if not opts.derive_graph:
        report.notes.append(
            f"{NO_GRAPH_NOTES[0]}flows are kept on hash cells (try --graph FILE or --derive-graph)"
        )
        return None
    report.graph_source = "derived from walking people"
    return derive()
