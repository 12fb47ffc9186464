"""The notes and warnings a build's scene-graph feed (:mod:`aion_cli.graph_feed`) gives, and
the texts a parallel build's parent recognises them by when it joins its shards' reports
(:mod:`aion_cli.shard_reports`, :mod:`aion_cli.shard_fold`): a module of its own so that the
feed's stream logic and the words it reports stay apart.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from aion_cli.build_report import BuildReport

__all__ = [
    "DAMAGED_GRAPHS_NOTE",
    "GRAPH_COUNTS_NOTE",
    "NO_GRAPH_NOTES",
    "PARTIAL_GRAPHS_NOTE",
    "graph_counts_note",
    "other_frame_warning",
    "pins_blocker",
    "session_break_note",
]

GRAPH_COUNTS_NOTE = "scene graphs: "
DAMAGED_GRAPHS_NOTE = "damaged scene-graph message(s) skipped"
PARTIAL_GRAPHS_NOTE = (
    "partial scene-graph update(s) (full_update false) skipped: aion applies whole graphs "
    "only, and the graph stays as it was until the next one"
)


def other_frame_warning(topic: str, frame: str, map_frame: str) -> str:
    """The warning for a scene-graph topic whose graphs say they are in ``frame``, not the
    map frame: aion takes a graph's positions as the map frame's (Hydra's frontend graph is
    in ``odom``, its backend graph in ``map``), so with the detections in ``map_frame`` a
    drifting ``map -> odom`` puts the people beside the places they walked through."""
    return (
        f"the scene graphs on {topic} are in frame '{frame}', not the map frame "
        f"'{map_frame}': their positions are read as the map frame's (Hydra's frontend "
        f"graph is in odom, its backend graph in map); give the backend's graph "
        f"(--graph-topic), or build with --map-frame {frame}"
    )


NO_GRAPH_NOTES = ("no scene graph: ", "--nav-layer ignored: no scene graph is read")
"""How the notes of a build that reads no scene graph start (a parallel build's parent leaves
out a shard's when another shard read one)."""


def graph_counts_note(r: BuildReport) -> str | None:
    """The note on the graphs a build applied, decoded, reused and left out (None when it
    applied and decoded every one)."""
    if not (r.graphs_skipped_period or r.graphs_skipped_identical):
        return None
    seen = r.graph_messages + r.graph_skipped + r.graphs_skipped_period
    return (
        f"{GRAPH_COUNTS_NOTE}{r.graph_messages:,} of {seen:,} applied "
        f"({r.graph_decoded:,} decoded, {r.graphs_read_by_changes:,} of them by the "
        f"nodes that changed; {r.graphs_skipped_identical:,} identical to "
        f"the payload before and not decoded again); {r.graphs_skipped_period:,} left "
        f"out by --graph-period {r.graph_period_ns / 1e9:g}s"
    )


def pins_blocker(
    before: tuple[str | None, str | None], shard: tuple[str | None, str | None]
) -> str | None:
    """Why graphs read with the pins ``shard`` chose from scratch (:attr:`GraphFeed.pins` of a
    shard of a parallel build) would not be read as one pass reads them, with the pins the
    graphs ``before`` them chose; None when they would (the same pins, or one side has none)."""
    for what, mine, theirs in zip(("spark_dsg version", "navigational layer"), before, shard,
                                  strict=True):
        if mine is not None and theirs is not None and mine != theirs:
            return (
                f"their scene graphs chose another {what} ({theirs}) than the graphs before "
                f"them ({mine}), which one pass keeps for the rest of the stream"
            )
    return None


def session_break_note(released: list[int], tolerance: float) -> str:
    """The note for a build whose scene graphs at a later log began another session
    (``released``: per such log, the node entries released), as ``aion merge`` does for two
    sessions' maps: their flows stay where they were seen, not at the new session's places of
    the same ids."""
    whose = "a later log's" if len(released) == 1 else f"{len(released)} later logs'"
    return (
        f"{whose} scene graphs hold the place ids of "
        f"the graph before at other places (most farther than {tolerance:g} m: another "
        f"scene-graph session): the map's node entries ({sum(released):,}) were released "
        "to hash cells there, which bind to the new session's places as the build goes, as "
        "aion merge does for two sessions' maps"
    )
