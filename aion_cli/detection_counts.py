"""What became of a build's detections: :class:`DetectionCounts` (read, used, dropped by
reason, stamp fallbacks, headings by source), its per-topic :class:`TopicCounts`, and
:class:`MapperTally` (what the Mapper accepted and dropped, per topic).

Filled by :class:`aion_cli.detection_feed.DetectionFeeder` while it decodes, read by the build
summary (:mod:`aion_cli.build_report`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.row_masks import all_columns
from aion_cli.engine.types import I64

#: Heading sources counted by :class:`DetectionCounts` (the build summary's order).
HEADING_SOURCES: tuple[str, ...] = ("velocity", "track", "linked", "pose_yaw", "none")


FAR_STAMP_NS = 86_400 * 1_000_000_000
"""A header stamp more than a day from its message's log time follows another clock than the
recording (a simulation's, from 0): the gap of ``aion_cli.log_times.STRAY_GAP_NS``."""

DECODE_FAILURE = "undecodable"
"""The reason a decoder gives for a message it could not decode (per message)."""
UNDECODABLE_MESSAGES = "undecodable_messages"
"""The build's drop reason for those messages (:meth:`DetectionCounts.add_decoded`)."""
OFF_STAMP_NS = 60 * 1_000_000_000
"""A header stamp more than a minute (but at most a day) from its message's log time is off:
a tracker's latency is seconds; minutes or hours are another machine's or zone's clock. When
a topic's detections are off, they fall into other windows than the log recorded."""


@dataclass
class TopicCounts:
    """One detection topic: messages decoded, messages that could not be decoded, and the
    first decode failure (its message)."""

    messages: int = 0
    undecodable: int = 0
    first_error: str | None = None
    first_hint: str | None = None
    stamps_far: int = 0
    far_example: tuple[int, int] | None = None
    """Detections whose header stamp lies more than :data:`FAR_STAMP_NS` from their message's
    log time, and the first one's (stamp, log time): :meth:`count_far_stamps`."""
    stamped: int = 0
    stamps_off: int = 0
    off_example: tuple[int, int] | None = None
    """Detections with a header stamp, those of them stamped more than :data:`OFF_STAMP_NS`
    but at most :data:`FAR_STAMP_NS` from their log time, and the first such (stamp, log
    time)."""

    def add_stamps(self, other: TopicCounts) -> None:
        """Add the stamp counts of ``other`` (a later part of the same topic): the sums, and
        the first example of each kind."""
        self.stamps_far += other.stamps_far
        self.far_example = self.far_example or other.far_example
        self.stamped += other.stamped
        self.stamps_off += other.stamps_off
        self.off_example = self.off_example or other.off_example

    def count_far_stamps(self, t_ns: I64, messages: Sequence[Any], message: I64) -> None:
        """Count the detections (times ``t_ns``, from ``messages[message]``) stamped more
        than :data:`FAR_STAMP_NS` from their message's log time; keep the first."""
        from aion_cli.formats.detections.adapter import message_log_times

        log = message_log_times(messages)[message]
        away = np.abs(t_ns.astype(np.float64) - log)  # int64 could overflow
        far = away > FAR_STAMP_NS
        off = (away > OFF_STAMP_NS) & ~far

        def first(mask: npt.NDArray[np.bool_]) -> tuple[int, int] | None:
            """The (stamp, log time) of the first detection of ``mask``; None for none."""
            if not mask.any():
                return None
            i = int(np.argmax(mask))
            return int(t_ns[i]), int(log[i])

        self.stamps_far += int(np.count_nonzero(far))
        self.far_example = self.far_example or first(far)
        self.stamped += len(t_ns)
        self.stamps_off += int(np.count_nonzero(off))
        self.off_example = self.off_example or first(off)


@dataclass
class DetectionCounts:
    """Detections decoded (``read``), accepted by the Mapper (``used``), dropped by reason, how
    many had a zero header stamp and took their message's log time (``stamp_fallbacks``), how
    many came from header-less messages and took it by design (``log_times``), headings by
    source (:data:`HEADING_SOURCES`), the sum and number of the speeds found with them
    (``speed_micro``: µm/s, an integer, so the sum is the same however the detections were
    batched; ``speed_n``) and per-topic message counts."""

    read: int = 0
    used: int = 0
    dropped: Counter[str] = field(default_factory=Counter)
    stamp_fallbacks: int = 0
    log_times: int = 0
    headings: Counter[str] = field(default_factory=Counter)
    speed_micro: int = 0
    speed_n: int = 0
    topics: dict[str, TopicCounts] = field(default_factory=dict)
    no_transform_why: str | None = None
    """Why the first detection dropped as ``no_transform`` had none, when TF's clock is the
    reason (:func:`aion_cli.detection_frames.clock_mismatch`)."""
    empty_messages: int = 0
    """Messages that decoded and held no detection (at least: see :meth:`count_empty`): a
    tracker that publishes them is not silent when nobody is there."""
    filter_seen: Counter[str] = field(default_factory=Counter)
    """Items a mapping's filter dropped, by the value its field held (``kind = "robot"``;
    a few values only): what the error of a build that kept none names."""

    def count_empty(self, frames: Any) -> None:
        """Count the messages of decoded ``frames`` that held no detection: those without a
        row, less the undecodable ones and less one per item a filter left out (it may have
        been a message's only item), so the count never takes a message of people for empty."""
        rows = np.bincount(frames.msg_index, minlength=frames.n_messages)
        without = int(np.count_nonzero(rows[: frames.n_messages] == 0))
        from aion_cli.formats.detections.generic import SEEN

        left_out = sum(  # undecodable: per message; a value seen is its reason's again
            int(n) for k, n in frames.filtered.items() if not k.startswith(SEEN)
        )
        self.empty_messages += max(0, without - left_out)

    def topic(self, name: str) -> TopicCounts:
        got = self.topics.get(name)
        if got is None:
            got = self.topics[name] = TopicCounts()
        return got

    def add_decoded(self, topic: TopicCounts, filtered: dict[str, int]) -> None:
        """Count what a decoder left out of one topic's messages (``filtered``: its frames'
        reasons). The one split of decoded drops, which :meth:`passed_filters` reads back:
        a damaged payload (``undecodable``) is counted per message, its detections unknown
        (dropped as ``undecodable_messages``, not read); items a filter left out (``class``,
        ``filter``, ``marker_*``, ``short_array``) were read (read = used + dropped) and are
        dropped by their reason; a value a filter met (:data:`~aion_cli.formats.detections.
        generic.SEEN`) is counted in ``filter_seen``, not again."""
        from aion_cli.formats.detections.generic import SEEN

        for reason, n in filtered.items():
            if reason.startswith(SEEN):
                self.see(reason.removeprefix(SEEN), n)
            elif reason == DECODE_FAILURE:
                self.dropped[UNDECODABLE_MESSAGES] += n
                topic.undecodable += n
            else:
                self.read += n
                self.dropped[reason] += n

    def see(self, value: str, n: int) -> None:
        """Count ``n`` items a filter dropped with ``value`` (only the first
        :data:`~aion_cli.formats.detections.generic.SEEN_VALUES` values)."""
        from aion_cli.formats.detections.generic import SEEN_VALUES

        if value in self.filter_seen or len(self.filter_seen) < SEEN_VALUES:
            self.filter_seen[value] += n

    def passed_filters(self) -> int:
        """The detections read that the decoders' filters kept: ``read`` less the drops
        :meth:`add_decoded` counted as read (every reason but the messages it could not
        decode and what the feeder and the Mapper dropped later, which is among these)."""
        from aion_cli.engine.state import DROP_REASONS  # the Mapper's

        later = {"no_transform", UNDECODABLE_MESSAGES, *DROP_REASONS}
        return self.read - sum(n for r, n in self.dropped.items() if r not in later)

    def placeable(self, frames: Any, cell_size: float | None = None) -> Any:
        """The rows of decoded ``frames`` the Mapper can place; the others are counted as it
        would count them and go no further: ``nan`` for a NaN or infinite position (a
        tracker's lost track) and, given the map's ``cell_size``, ``out_of_range`` for a
        finite one beyond the spatial hash's range (1e300 m). Linked or differenced, such a
        row gave the rows beside it NaN or absurd speeds and headings (numpy warnings, "people
        move at 25,000 m/s"), and a heading source of its own."""
        if cell_size is None:
            finite = in_range = all_columns(np.isfinite(frames.xyz))
        else:
            from aion_cli.engine.spatial_hash import hashable_indices

            _, finite, in_range = hashable_indices(frames.xyz, cell_size)
        n_bad = len(frames) - int(np.count_nonzero(in_range))
        if not n_bad:
            return frames
        n_nan = len(frames) - int(np.count_nonzero(finite))
        if n_nan:
            self.dropped["nan"] += n_nan
        if n_bad > n_nan:
            self.dropped["out_of_range"] += n_bad - n_nan
        return frames.select(in_range)


#: speeds are summed in µm/s as integers, each clipped to this (m/s) so no sum can overflow
SPEED_CLIP_M_S = 1e5


def speed_micro(speed: npt.NDArray[np.float64]) -> tuple[int, int]:
    """The sum of the finite ``speed`` values in whole µm/s (each clipped to
    :data:`SPEED_CLIP_M_S`) and their number: an integer sum is exact, so it does not depend
    on how the detections were batched."""
    finite = speed[np.isfinite(speed)]
    micro = np.rint(np.minimum(np.abs(finite), SPEED_CLIP_M_S) * 1e6).astype(np.int64)
    return int(micro.sum()), int(finite.size)


class MapperTally:
    """Per detection topic (by index), the detections the Mapper accepted (``used``) and those
    it dropped per reason (``drops``, topics × ``DROP_REASONS``), from the per-row codes
    :meth:`aion_cli.engine.mapper.Mapper.add_detections` gives."""

    def __init__(self, topics: int) -> None:
        from aion_cli.engine.state import DROP_REASONS

        self.reasons = len(DROP_REASONS)
        self.used = np.zeros(topics, np.int64)
        self.drops = np.zeros((topics, self.reasons), np.int64)

    def add(self, topics: npt.NDArray[np.int64], codes: npt.NDArray[np.int8]) -> None:
        """One batch: each row's topic index and the Mapper's code for it."""
        from aion_cli.engine.mapper import ACCEPTED

        n = len(self.used)
        self.used += np.bincount(topics[codes == ACCEPTED], minlength=n)
        dropped = codes != ACCEPTED
        if dropped.any():
            self.drops += np.bincount(
                topics[dropped] * self.reasons + codes[dropped], minlength=n * self.reasons
            ).reshape(n, self.reasons)
