"""Whose scene graph a build's map takes: robots recording at the same time in one build
(``aion build robot1.mcap robot2.mcap``) each publish their own Hydra graph on the same topic
(``/hydra/backend/dsg``), and a map holds one graph. Merged by time into one stream, each
robot's graph replaced the other's at every message: every graph was decoded anew (the bytes
differ from the graph before), the places of one session moved to the other's positions and
back with every message (another Hydra session numbers its places from p0 again, elsewhere),
and the map kept whichever robot's graph came last in time.

The rule (:func:`graph_streams_at_once`, as :mod:`aion_cli.tf_trees` decides whose TF tree
and :mod:`aion_cli.track_owners` whose tracks): on a scene-graph topic, recordings (a path
given; the storage files of one rosbag2 bag are one recording) whose files holding that topic
span a time another such recording's overlap are graph streams at once, in groups that
overlap one another (directly or through others: :func:`aion_cli.tf_trees.overlap_groups`),
each judged on its own. When the first graphs with places of a group's recordings are of one
scene-graph session (``aion merge``'s lineage test,
:func:`aion_cli.engine.rebind.graph_agreement`: more than half of the place ids both hold lie
within ``bind_radius`` of each other: robots sharing one multi-robot graph, or one recording
twice) they are one session's graph, which the map takes, while that group's time lasts, as
the union of each of its recordings' latest graph (:func:`graph_groups`,
:class:`aion_cli.session_graphs.SessionGraphs`). Two robots sharing one session in the
morning and two sharing another (Hydra restarted) in the afternoon are two groups, one after
the other as one robot's logs of two days are.
Otherwise (another session's places, no shared id, a recording none of whose first
:data:`FIRST_GRAPHS` graphs decodes with places) the build refuses them
(:func:`graphs_at_once_error`) rather than let them take turns. The map the user wants is
the one ``aion merge`` gives of each robot's own map (its lineage rule finds two sessions
there too, and binds the flows to the newest map's graph); a build of both logs would have
to pick one graph and rebind the other robot's flows as the merge does, which it cannot do
while streaming. ``--graph FILE`` (one graph for the whole fleet) builds them at once, the
logs' graphs ignored.

Recordings of one topic one after the other (one robot's logs: ``rosbag record --split``
files, days), and groups of recordings at once one after the other, are one stream in time
order, a later graph (a later group's union) replacing an earlier one as in one file; a
recording split by topic (the graphs in one log, the detections or ``/tf`` in another) has
one stream. Both build as before the rule; a later group whose first graph is of another
session releases the map's node entries first
(:meth:`aion_cli.build_stream.StreamStep._take_graph`).

Overlapping recordings always build in one shard of a parallel build (a shard is a group of
logs that overlap or touch), so a shard refuses them as one pass does.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from itertools import islice
from typing import TYPE_CHECKING, Any

from aion_cli.errors import InputError, path_word
from aion_cli.tf_trees import overlap_groups

if TYPE_CHECKING:
    from aion_cli.engine.types import GraphSnapshot
    from aion_cli.formats.raw import RawMessage

__all__ = [
    "FIRST_GRAPHS",
    "graph_groups",
    "graph_streams_at_once",
    "graphs_at_once",
    "graphs_at_once_error",
]

#: a recording's first graph messages tried for one that decodes with places
FIRST_GRAPHS = 10

#: the map of a build's logs beside the refused ones, in :func:`graphs_at_once_error`'s hint
OTHERS_MAP = "other-logs.aion"

#: a scene-graph message decoded apart from the stream (None: damaged or partial), as
#: :meth:`aion_cli.graph_feed.GraphFeed.peek` decodes it
Peek = Callable[[Any, "RawMessage"], "GraphSnapshot | None"]


def graph_streams_at_once(
    logset: Any, topics: Iterable[str], peek: Peek, tolerance: float
) -> tuple[str, list[str], list[str]] | None:
    """The first scene-graph topic of ``topics`` (sorted) that recordings of ``logset``
    (:meth:`formats.logs.LogSet.recording_times`, by the logs' indexes) carry over times that
    overlap, with graphs of other sessions, those recordings' paths (each one's first file;
    the folder of a rosbag2 bag's storage files) and the paths of the logset's other
    recordings, in the order given; None when there is no such topic.
    Each group of recordings that overlap one another, directly or through others
    (:func:`aion_cli.tf_trees.overlap_groups`), is judged on its own (:func:`_one_session`)
    and refused by its own paths: two robots of one session in the morning and two of
    another (Hydra restarted) in the afternoon are two groups, the afternoon's graphs
    following the morning's as one robot's later recording's do."""
    for topic in sorted(topics):
        for group in _at_once(overlap_groups(logset.recording_times([topic]))):
            if not _one_session(logset, topic, group, peek, tolerance):
                others = [key for key in dict.fromkeys(logset.recordings) if key not in group]
                paths = [_recording_path(logset, key) for key in group]
                return topic, paths, [_recording_path(logset, key) for key in others]
    return None


def graph_groups(logset: Any, topics: Iterable[str]) -> dict[int, int]:
    """Per recording of ``logset`` carrying the scene-graph ``topics``, its group of
    recordings that overlap in time (:func:`aion_cli.tf_trees.overlap_groups`, numbered in
    time order; a recording that overlaps none is a group of its own), when two or more
    carry them (empty: one recording, one stream). A group of several is graph streams at
    once of one session (after :func:`graph_streams_at_once` found no other), whose graphs
    the map joins while their group's time lasts; a later group's graphs follow (
    :class:`aion_cli.session_graphs.SessionGraphs`)."""
    spans = logset.recording_times(topics)
    return overlap_groups(spans) if len(spans) > 1 else {}


def graphs_at_once(logset: Any, topics: Iterable[str]) -> bool:
    """Whether recordings of ``logset`` carry the scene-graph ``topics`` over times that
    overlap (:func:`graph_groups` of several recordings)."""
    return bool(_at_once(graph_groups(logset, topics)))


def _at_once(groups: dict[int, int]) -> list[list[int]]:
    """The groups of ``groups`` (key: its group) that hold more than one key: recordings at
    once, each group's keys sorted, the groups in time order."""
    members: dict[int, list[int]] = {}
    for key in sorted(groups):
        members.setdefault(groups[key], []).append(key)
    return [keys for _, keys in sorted(members.items()) if len(keys) > 1]


def _one_session(
    logset: Any, topic: str, recordings: list[int], peek: Peek, tolerance: float
) -> bool:
    """Whether the first graph with places of each of ``recordings`` on ``topic`` is of the
    first one's scene-graph session (``tolerance``: the model's ``bind_radius``); False when
    a recording has no such graph among its first :data:`FIRST_GRAPHS`."""
    from aion_cli.engine.rebind import graph_agreement

    graphs = [_first_graph(logset, topic, key, peek) for key in recordings]
    first = graphs[0]
    return first is not None and all(
        g is not None and graph_agreement(first, g, tolerance).same for g in graphs[1:]
    )


def _first_graph(logset: Any, topic: str, key: int, peek: Peek) -> GraphSnapshot | None:
    """The first of the first :data:`FIRST_GRAPHS` graphs on ``topic`` of recording ``key``
    (its files in order) that decodes with places; None when none does."""
    from aion_cli.formats.log_overlaps import file_messages

    tried = 0
    for index, (recording, file) in enumerate(zip(logset.recordings, logset.files, strict=True)):
        if recording != key:
            continue
        span = (int(file.start_ns), int(file.end_ns) + 1)
        for msg in islice(file_messages(logset, index, {topic}, span), FIRST_GRAPHS - tried):
            tried += 1
            graph = peek(logset, msg)
            if graph is not None and len(graph.places):
                return graph
        if tried >= FIRST_GRAPHS:
            break
    return None


def _recording_path(logset: Any, key: int) -> str:
    """The path recording ``key`` of ``logset`` was read from: its file's, or the folder
    holding a rosbag2 bag's several storage files."""
    files = [f.path for r, f in zip(logset.recordings, logset.files, strict=True) if r == key]
    return str(files[0] if len(files) == 1 else files[0].parent)


def graphs_at_once_error(
    topic: str, paths: list[str], others: Sequence[str] = ()
) -> InputError:
    """The refusal of logs of robots recording at once that carry graphs of other scene-graph
    sessions on ``topic``: their graphs would take turns as the map's graph; the hint tells
    how to build their map (each robot's map, then ``aion merge``, with the map of the
    build's ``others`` logs, which the refusal does not name: the morning's robots of one
    session beside the afternoon's refused ones) or give one graph for all (``--graph
    FILE``)."""
    words = [path_word(p) for p in paths]
    maps = [path_word(m) for m in _map_names(paths)]
    steps = [f"aion build {w} -o {m}" for w, m in zip(words, maps, strict=True)]
    if others:
        steps.append(f"aion build {' '.join(path_word(p) for p in others)} -o {OTHERS_MAP}")
        maps.append(OTHERS_MAP)
    builds = "; ".join(steps)
    return InputError(
        f"{len(paths)} logs carry scene graphs on {topic} at the same time "
        f"({', '.join(paths)}), of other scene-graph sessions (robots recording at once): "
        "their graphs would take turns as the map's graph; nothing was built",
        hint=(
            f"build each robot's map and merge them ({builds}; aion merge "
            f"{' '.join(maps)} -o fleet.aion), or build on one graph with --graph FILE"
        ),
    )


def _map_names(paths: list[str]) -> list[str]:
    """A map file name of its own per robot log of ``paths``: the log's name as ``.aion``
    (``robot1.mcap`` -> ``robot1.aion``), numbered where two logs share a name (a fleet whose
    robots each write ``run.mcap`` in a folder of their own)."""
    from pathlib import Path

    stems = [Path(p).stem or "robot" for p in paths]
    return [
        f"{stem}.aion" if stems.count(stem) == 1 else f"{stem}{k + 1}.aion"
        for k, stem in enumerate(stems)
    ]
