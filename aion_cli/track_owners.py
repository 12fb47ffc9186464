"""Whose track a detection's track id names: robots recording at the same time in one build
(``aion build robot1.mcap robot2.mcap``) on one detection topic number their tracks alike
(every tracker counts from 0 or 1), so track 3 of one robot and track 3 of the other are two
people. Differenced as one track, each gets headings from steps between both (garbled), and
id-less detections of both robots at one time would be linked as one sensor's frame.

The rule (:func:`tracks_apart`, as :mod:`aion_cli.tf_trees` decides whose TF tree): on a
detection topic, a recording (a path given; the storage files of one rosbag2 bag are one
recording) whose messages of that topic span a time that another recording's messages of it
overlap has its tracks to itself -- its own heading estimator for the source's track ids and
its own linker for id-less rows (:func:`owners_of`, :func:`estimate_by_owner`). The other
recordings of the topic (one robot's logs one after the other: ``rosbag record --split``
files, days) share the topic's estimator and linker, so a track that goes on across the seam
of two such files goes on as in one file; when no two recordings of a topic overlap, the
map is what it was before the rule.

Overlapping recordings always build in one shard of a parallel build (a shard is a group of
logs that overlap or touch), so a shard keys their tracks as one pass does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.types import DetectionBatch
from aion_cli.formats.raw import recordings_of
from aion_cli.tf_trees import REST, overlapping

if TYPE_CHECKING:
    from collections.abc import Iterable, Sequence

    from aion_cli.engine.heading import HeadingEstimator
    from aion_cli.engine.tracking import LinkerConfig, TrackLinker
    from aion_cli.engine.types import I64
    from aion_cli.formats.raw import RawMessage

__all__ = [
    "REST", "TrackLinkers", "concat_owners", "estimate_by_owner", "owners_of", "tracks_apart"
]

def tracks_apart(logset: Any, topics: Iterable[str]) -> dict[str, frozenset[int]]:
    """Per detection topic of ``topics`` (only those with any): the recordings of ``logset``
    (:meth:`formats.logs.LogSet.recording_times`, by the logs' indexes) whose messages of the
    topic span a time another recording's messages of it overlap."""
    out = {}
    for topic in sorted(topics):
        found = overlapping(logset.recording_times([topic]))
        if found:
            out[topic] = frozenset(found)
    return out


def owners_of(
    messages: Sequence[RawMessage], msg_index: I64, apart: frozenset[int]
) -> I64 | None:
    """Per row (``msg_index``: its message's position in ``messages``), whose tracks its
    track id names: its recording where that is one of ``apart``, else :data:`REST`; None
    when every row is the shared tracks' (a C-level pass over the messages, no Python loop
    per message)."""
    if not apart or len(msg_index) == 0:
        return None
    recording = recordings_of(messages)[msg_index]
    own = np.isin(recording, np.fromiter(apart, np.int64, len(apart)))
    if not own.any():
        return None
    return np.where(own, recording, REST)


def estimate_by_owner(
    shared: HeadingEstimator,
    own: dict[int, HeadingEstimator],
    make: type[HeadingEstimator],
    frames: Any,
    segment: I64,
    owner: I64,
) -> tuple[DetectionBatch, np.ndarray]:
    """Headings of ``frames`` (map-frame rows, ``segment`` per row) with each owner's
    estimator (:data:`REST`: ``shared``; a recording's own in ``own``, made on first use with
    ``make()``), and the source code of each row's heading; rows keep their order. One call
    per owner present, each over its own rows, as one estimator does over disjoint ids."""
    n = len(frames)
    heading, speed = np.full(n, np.nan), np.full(n, np.nan)
    sources = np.zeros(n, np.int8)
    for key in np.unique(owner).tolist():
        rows = np.flatnonzero(owner == key)
        estimator = shared if key == REST else own.get(key)
        if estimator is None:
            estimator = own[key] = make()
        part = estimator.to_batch(frames.select(rows), segment[rows])
        heading[rows], speed[rows], sources[rows] = part.heading, part.speed, estimator.sources
    xyz = np.ascontiguousarray(np.asarray(frames.xyz, np.float64).reshape(n, 3))
    batch = DetectionBatch(np.asarray(frames.t_ns, np.int64), xyz, heading, speed,
                           np.asarray(frames.track_id, np.int64))
    return batch, sources


def concat_owners(owners: list[I64 | None], lengths: list[int]) -> I64 | None:
    """The owners of concatenated parts' rows (:func:`owners_of` per part, ``lengths`` their
    rows); None when every part's rows are all the shared tracks'."""
    if all(o is None for o in owners):
        return None
    return np.concatenate([
        np.full(n, REST, np.int64) if o is None else o
        for o, n in zip(owners, lengths, strict=True)
    ])


class TrackLinkers:
    """The track linkers of a feeder's id-less rows: one per topic (:attr:`shared`: two
    sensors' detections are never joined into one track) and one per topic and recording
    whose tracks are its own (:attr:`own`: nor two robots'), each made on first use."""

    #: linked ids are ``id * STRIDE + linker index``: every linker's tracks in one number
    #: space; the own linkers' indexes start at ``STRIDE // 2``
    STRIDE = 1 << 16

    def __init__(self, config: LinkerConfig) -> None:
        self.config = config
        self.shared: dict[str, TrackLinker] = {}
        self.own: dict[tuple[str, int], TrackLinker] = {}

    def link(
        self, out: I64, topic: str, frames: Any, segment: I64, rows: I64, owner: I64 | None
    ) -> None:
        """Link ``rows`` of ``frames`` (a topic's map-frame rows, ``segment`` and ``owner``
        per row; None: all :data:`REST`) into ``out``, segment by segment, in order, as
        separate calls would link them."""
        if owner is None:
            self._link(out, topic, REST, frames, segment, rows)
            return
        for key in np.unique(owner[rows]).tolist():
            self._link(out, topic, key, frames, segment, rows[owner[rows] == key])

    def _link(
        self, out: I64, topic: str, key: int, frames: Any, segment: I64, rows: I64
    ) -> None:
        from aion_cli.engine.tracking import TrackLinker

        table: dict[Any, TrackLinker] = self.shared if key == REST else self.own
        name = topic if key == REST else (topic, key)
        linker = table.get(name)
        if linker is None:
            linker = table[name] = TrackLinker(self.config)
        ids = np.empty(len(rows), np.int64)
        rseg = segment[rows]
        cuts = np.flatnonzero(rseg[1:] != rseg[:-1]) + 1
        for a, b in zip([0, *cuts.tolist()], [*cuts.tolist(), len(rows)], strict=True):
            part = rows[a:b]
            ids[a:b] = linker.link(frames.t_ns[part], frames.xyz[part, :2])
        index = list(table).index(name) + (0 if key == REST else self.STRIDE // 2)
        out[rows] = np.where(ids >= 0, ids * self.STRIDE + index, -1)
