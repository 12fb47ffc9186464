"""Whose TF a build resolves each detection and robot pose with: robots recording at the same
time in one build (``aion build robot1.mcap robot2.mcap``) publish the same frames
(``map -> base_link``), and one buffer of all their ``/tf`` would interpolate each robot's
detections between both robots' poses (or, at equal stamps, keep one robot's).

The rule (:class:`TfTrees`): a recording (a path given; the storage files of one rosbag2 bag
are one recording) holding ``/tf`` messages of its own over a time that another such
recording's overlaps has its own TF tree: its own ``/tf`` with every log's ``/tf_static`` (a
robot's static transforms are often recorded once, in a log of their own). A detection of
such a recording is moved into the map frame with its own tree when that tree joins the map
frame to the detection's frame, else with the shared tree (every log's TF, as a build of one
log reads it); the robot poses are those of the own trees and those of the other
recordings' ``/tf`` together. A recording without ``/tf`` of its own (a recording split by
topic: the detections in one bag, ``/tf`` in another, over the same time) and one whose
``/tf`` overlaps no other's (one robot's logs one after the other: ``rosbag record --split``
files, days) use the shared tree, which interpolates across the seam of two such files as
one file's tree would: when no two recordings' ``/tf`` overlap, the map is what it was
before the rule.

Overlapping recordings always build in one shard of a parallel build (a shard is a group of
logs that overlap or touch), so a shard makes the same trees for them as one pass.

Why apart from :mod:`aion_cli.tf_feed` (reading TF) and :mod:`aion_cli.detection_frames`
(moving rows with a tree): which tree answers is a rule of its own, which the detections and
the observation (:mod:`aion_cli.tf_trajectory`) share.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.types import Trajectory
from aion_cli.formats import raw

if TYPE_CHECKING:
    from aion_cli.engine.types import I64
    from aion_cli.formats.raw import RawMessage
    from aion_cli.formats.tf import TfBuffer
    from aion_cli.topics import TopicPlan

__all__ = ["REST", "TfTrees", "overlap_groups", "overlapping", "own_tf_buffers"]

REST = -1
"""The key of the tree of the ``/tf`` of every recording without a tree of its own (they
overlap no other; their robot poses, beside the own trees')."""

def own_tf_buffers(logset: Any, plan: TopicPlan) -> dict[int, TfBuffer]:
    """An empty buffer per recording of ``logset`` (:meth:`formats.logs.LogSet.
    recording_times`) holding ``/tf`` messages over a time that another such recording's
    overlaps (by the logs' indexes), and one (:data:`REST`) for the ``/tf`` of the others,
    for :func:`aion_cli.tf_feed.read_tf_and_times` to fill; none when no two overlap (one
    robot's logs of other times: the shared tree is every recording's own)."""
    from aion_cli.formats.tf import TfBuffer

    tf_topics = plan.names("tf") if plan.tf else set()
    dynamic = {t for t in tf_topics if not t.endswith("_static")}
    spans = logset.recording_times(dynamic) if dynamic else {}
    found = overlapping(spans)
    return {recording: TfBuffer() for recording in [*found, REST]} if found else {}


def overlapping(spans: dict[int, tuple[int, int]]) -> list[int]:
    """The keys of ``spans`` (first and last message time) whose span overlaps another's
    (each starts before the other ends), sorted: those whose group of
    :func:`overlap_groups` holds another."""
    groups = overlap_groups(spans)
    if len(groups) < 2:
        return []
    sizes = np.bincount(np.array(list(groups.values()), np.int64))
    return sorted(key for key, group in groups.items() if sizes[group] > 1)


def overlap_groups(spans: dict[int, tuple[int, int]]) -> dict[int, int]:
    """Per key of ``spans`` (first and last message time), its group's index in time order:
    spans that overlap (each starts before the other ends: they share more than an instant,
    or one is a single instant strictly inside the other, a recording of one message while
    another records; spans that only touch do not) directly or through others are one
    group, a span that overlaps none a group of its own (equal one-instant spans are each
    their own, numbered in the order given). Sorted by start, a span starts a group when
    it starts at or after the latest end before it (a span overlaps an earlier
    one when it starts before that end, and a later one when the next start comes before
    its end). Python integers, one step per recording: log times are MCAP's uint64, and one
    past 2^63 (a damaged or far-future time, which the build drops and names) must not
    overflow here first."""
    groups: dict[int, int] = {}
    group = -1
    reach: int | None = None  # the latest end so far
    for key, (lo, hi) in sorted(spans.items(), key=lambda item: item[1]):
        if reach is None or lo >= reach:
            group += 1
        reach = hi if reach is None else max(reach, hi)
        groups[key] = group
    return groups


@dataclass
class TfTrees:
    """The shared TF buffer of a build and, per recording with ``/tf`` of its own over a time
    another's overlaps, that recording's own tree, and the tree of the other recordings'
    ``/tf`` (:data:`REST`; module docstring). ``own`` is empty when no recording needs one:
    then every lookup is the shared buffer's, as before the rule."""

    shared: TfBuffer | None
    own: dict[int, TfBuffer] = field(default_factory=dict)
    #: per (recording, target frame, source frame): whether the own tree joins them
    _joins: dict[tuple[int, str, str], bool] = field(default_factory=dict, repr=False)

    @property
    def split(self) -> bool:
        """Whether recordings resolve with trees of their own."""
        return bool(self.own) and self.shared is not None

    def with_static(self) -> TfTrees:
        """Every own tree given the shared buffer's static transforms (every log's
        ``/tf_static``, a shard's from all the build's logs), after its own (none: own trees
        hold ``/tf`` only)."""
        from aion_cli.tf_feed import with_static_tf

        if not self.split:
            return self
        assert self.shared is not None
        static = tuple(
            (p, c, stamp, tuple(tr.tolist()), tuple(q.tolist()))
            for p, c, stamp, tr, q in self.shared.static_transforms()
        )
        for buffer in self.own.values():
            with_static_tf(buffer, static)
        self._joins.clear()
        return self

    def recordings_of(self, messages: list[RawMessage]) -> I64 | None:
        """Per message, the recording it came from (a C-level pass, no Python loop per
        message); None when the trees are not split."""
        if not self.split:
            return None
        return raw.recordings_of(messages)

    def groups(
        self, target: str, source: str, recording: I64 | None
    ) -> Iterator[tuple[TfBuffer, I64 | None]]:
        """The buffers that move rows of frame ``source`` into ``target``, each with the
        positions (in ``recording``, per row) of the rows it moves (None: all of them): a
        recording's own tree where it joins the two frames, the shared buffer for the rest."""
        assert self.shared is not None
        if recording is None or not self.split:
            yield self.shared, None
            return
        rest = np.ones(len(recording), bool)
        for rec in np.unique(recording).tolist():
            own = self.own.get(rec)
            if own is None or not self._own_joins(rec, own, target, source):
                continue
            rows = recording == rec
            rest &= ~rows
            yield own, np.flatnonzero(rows)
        if rest.all():
            yield self.shared, None
        elif rest.any():
            yield self.shared, np.flatnonzero(rest)

    def _own_joins(self, rec: int, own: TfBuffer, target: str, source: str) -> bool:
        key = (rec, target, source)
        joins = self._joins.get(key)
        if joins is None:
            joins = self._joins[key] = source in own.connected(target)
        return joins

    def poses(self, map_frame: str, base_frame: str) -> Trajectory | None:
        """The robot poses of the recordings' own trees and of the other recordings' ``/tf``
        (:data:`REST`), all of them in time order (ties by position, so the order the logs
        were given does not matter), where at least one tree has a ``map_frame ->
        base_frame`` trajectory; None otherwise (the shared buffer's trajectory then stands,
        as before the rule)."""
        from aion_cli.errors import TransformError

        if not self.split:
            return None
        found = []
        for buffer in self.own.values():
            try:
                traj = buffer.trajectory(map_frame, base_frame)
            except TransformError:
                continue
            if len(traj):
                found.append(traj)
        if not found:
            return None
        t = np.concatenate([np.asarray(p.t_ns, np.int64) for p in found])
        xyz = np.concatenate([np.asarray(p.xyz, np.float64).reshape(-1, 3) for p in found])
        order = np.lexsort((xyz[:, 2], xyz[:, 1], xyz[:, 0], t))
        return Trajectory(t[order], np.ascontiguousarray(xyz[order]))
