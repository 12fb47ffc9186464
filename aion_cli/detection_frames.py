"""Detection rows into the map frame (:class:`MapFrameMover`): positions, velocities and pose
yaws turned by the TF buffer's transform at each row's time; rows without a transform are
counted as ``no_transform`` and dropped; a frame with no TF at all is an error naming
``--map-frame``. Rows that name no frame (an empty ``frame_id``: Hydra's ROS 1 sender, some
trackers) are taken as in the map frame, and the build says so once per topic. With the TF
trees of several robots recording at once (:class:`aion_cli.tf_trees.TfTrees`) each row is
moved with its own log's tree where that tree joins its frame to the map frame."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.errors import TransformError

if TYPE_CHECKING:
    from aion_cli.detection_counts import DetectionCounts
    from aion_cli.formats.raw import RawMessage
    from aion_cli.formats.tf import TfBuffer
    from aion_cli.tf_trees import TfTrees


@dataclasses.dataclass
class MapFrameMover:
    """One detection topic's move into ``map_frame`` (spelt as ``formats.raw.normalize_frame``
    spells frames) with ``tf`` (None: the logs have none); drops counted in ``counts``.
    ``map_frame_seen``: rows were given in the map frame itself (a second frame without TF is
    then an error of two frames); ``unframed``: some rows named no frame. ``trees``: the
    build's TF trees (``tf`` is their shared one), which say whose tree moves each row."""

    tf: TfBuffer | None
    map_frame: str
    counts: DetectionCounts
    map_frame_seen: bool = False
    unframed: bool = False
    trees: TfTrees | None = None

    def move(self, frames: Any, messages: list[RawMessage] | None = None) -> Any:
        """Rows moved into the map frame; rows without a transform are counted and dropped.
        ``messages``: those ``frames`` were decoded from (``frames.msg_index``), whose
        recordings choose the tree of each row (:meth:`aion_cli.tf_trees.TfTrees.groups`)."""
        from aion_cli.formats.quaternions import rotated_yaw

        if len(frames) == 0:
            return frames
        target = self.map_frame
        if "" in frames.frames and target and np.any(frames.frame_id == frames.frames.index("")):
            self.unframed = True  # said once per topic (build_report)
        if all(name in ("", target) for name in frames.frames):  # nothing to move
            self.map_frame_seen = True
            if frames.frames == (target,):
                return frames
            return dataclasses.replace(
                frames, frame_id=np.zeros(len(frames), np.int64), frames=(target,)
            )
        xyz = frames.xyz.copy()
        vel = frames.velocity.copy()
        yaw = frames.yaw.copy()
        ok = np.ones(len(frames), dtype=bool)
        trees = self.trees if messages is not None else None
        of_message = None if trees is None else trees.recordings_of(messages or [])
        for index, name in enumerate(frames.frames):
            if name in ("", target):
                continue  # Hydra's ROS 1 sender leaves frame ids empty: taken as the map frame
            rows = np.flatnonzero(frames.frame_id == index)
            if len(rows) == 0:
                continue
            if self.tf is None:
                if self.map_frame_seen or target in frames.frames:
                    raise TransformError(
                        f"the detections are in two frames, {target!r} and {name!r}, and the "
                        "logs have no TF between them",
                        hint="build the logs of each frame into a map of its own (--map-frame "
                        "names the frame)",
                    )
                raise TransformError(
                    f"detections are in frame {name!r} but the log has no TF to {target!r}",
                    hint=f"if {name!r} is a fixed frame, give --map-frame {name} (the frame "
                    "the map is in)",
                )
            recording = None if of_message is None else of_message[frames.msg_index[rows]]
            for tf, part in self._trees(target, name, recording):
                at = rows if part is None else rows[part]
                R, t, good = tf.lookup(target, name, frames.t_ns[at])
                xyz[at] = np.einsum("nij,nj->ni", R, frames.xyz[at]) + t
                vel[at] = np.einsum("nij,nj->ni", R, frames.velocity[at])
                yaw[at] = rotated_yaw(R, yaw[at])
                ok[at] = good
                if self.counts.no_transform_why is None and not good.all():
                    first = int(frames.t_ns[at[np.argmin(good)]])
                    self.counts.no_transform_why = clock_mismatch(tf, target, name, first)
        n_bad = int((~ok).sum())
        if n_bad:
            self.counts.dropped["no_transform"] += n_bad
        moved = dataclasses.replace(
            frames,
            xyz=xyz,
            velocity=vel,
            yaw=yaw,
            frame_id=np.zeros(len(frames), np.int64),
            frames=(target,),
        )
        return moved.select(ok) if n_bad else moved

    def _trees(self, target: str, name: str, recording: np.ndarray | None) -> Any:
        """The buffers moving rows of frame ``name``, with the positions of their rows."""
        if self.trees is None or recording is None:
            assert self.tf is not None
            return ((self.tf, None),)
        return self.trees.groups(target, name, recording)


#: how far outside TF's stamps a detection may lie before TF is said to be on another clock
#: (tf2's cache length: transforms are not extrapolated further either)
CLOCK_SLACK_NS = 10 * 1_000_000_000


def clock_mismatch(tf: TfBuffer, target: str, source: str, t_ns: int) -> str | None:
    """Why a detection of frame ``source`` stamped ``t_ns`` has no transform to ``target``
    when the stamp lies outside the stamps of the chain's ``/tf`` links by more than
    :data:`CLOCK_SLACK_NS` (TF and the detections on different clocks: a simulation's, a
    machine's); None when it lies within them (a gap, localisation lost) or the chain is
    static."""
    from aion_cli.engine.time_text import utc_ends, utc_text

    span = tf.chain_range(target, source)
    if span is None:
        return None
    lo, hi = span
    if lo - CLOCK_SLACK_NS <= t_ns <= hi + CLOCK_SLACK_NS:
        return None
    first, last = utc_ends(lo, hi)
    return (
        f"the first detection in {source!r} without a transform is stamped {utc_text(t_ns)}, "
        f"but TF has {target}->{source} only from {first} to {last}: TF and the "
        "detections are stamped on different clocks (a simulation's, another machine's)"
    )
