"""Raw detection messages -> map-frame :class:`DetectionBatch` chunks for the Mapper.

Messages are decoded per topic (and encoding) with the adapter the build chose for it (a
built-in adapter reading the log's own definition, numpy fast path only where that definition
is the layout the fast decoder was written for, or the user's TOML mapping), moved into the
map frame with the TF buffer (rows without a transform are counted as ``no_transform`` and
dropped; a frame with no TF at all is an error naming ``--map-frame``), linked into short
tracks where nothing else can give a heading -- no track id, no velocity, no pose yaw (and a
topic whose orientations never vary has none) -- with one
:class:`~aion_cli.engine.tracking.TrackLinker` per topic, its state carried across chunks, so
such detections get headings from motion; sorted by time and given headings by
:class:`HeadingEstimator` s that keep their per-track state across chunks.
:class:`DetectionCounts` tallies what happened per topic and per heading source.

A build's stream is cut into *pieces* at every scene graph (the Mapper must apply a graph
between the detections before and after it) but decoded in *jobs* of many pieces
(:func:`chunks`, :func:`decoded_chunks`, :meth:`DetectionFeeder.decode_segments`): the fixed
cost of a decode (joining payloads, reading headers, estimating headings) is paid once per few
thousand messages however often graphs come, and the worker thread runs ahead across graphs.
Every stateful step treats each piece as a call of its own would, so the batches are the
same as decoding piece by piece.

This module holds :class:`DetectionFeeder` (one feeder's decode: adapters, uninformative yaws,
TF, track linking, headings); the rest lives beside it: :mod:`aion_cli.detection_frames` (the
move into the map frame, :class:`MapFrameMover`), and, re-exported here,
:mod:`aion_cli.detection_adapters` (each topic's adapter, built before anything is read:
:func:`log_adapters`), :mod:`aion_cli.detection_counts` (:class:`DetectionCounts`,
:class:`TopicCounts`, :data:`HEADING_SOURCES`), :mod:`aion_cli.detection_jobs` (the segment
bookkeeping of a decode job, :class:`TopicFeeders`) and :mod:`aion_cli.detection_chunks`
(:class:`Chunk`, :func:`chunks`, :func:`decoded_chunks`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from operator import attrgetter
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.detection_adapters import AdapterFactory, default_factory, log_adapters
from aion_cli.detection_chunks import MAX_CHUNK_BYTES, Chunk, chunks, decoded_chunks
from aion_cli.detection_counts import HEADING_SOURCES, DetectionCounts, TopicCounts, speed_micro
from aion_cli.detection_frames import MapFrameMover
from aion_cli.detection_jobs import (
    TopicFeeders,
    _first_in_segment,
    _flatten,
    _groups,
    _split,
    _time_order,
)
from aion_cli.engine.heading_hold import LookAhead
from aion_cli.engine.row_masks import all_columns
from aion_cli.engine.types import I64, DetectionBatch
from aion_cli.track_owners import TrackLinkers, concat_owners, estimate_by_owner, owners_of

if TYPE_CHECKING:
    from aion_cli.engine.tracking import LinkerConfig
    from aion_cli.formats.detections import DetectionAdapter
    from aion_cli.formats.raw import RawMessage
    from aion_cli.formats.tf import TfBuffer
    from aion_cli.tf_trees import TfTrees

_VARIES = float("nan")
_SAME_YAW = 1e-9  # rad: yaws closer than this are one orientation

def yaw_rule_blocker(
    before: Mapping[str, float],
    rule: Mapping[str, tuple[float, float]],
    assumed: Mapping[str, float] | None = None,
) -> str | None:
    """Why a stream judged by the orientation rule (``rule``: :meth:`DetectionFeeder.yaw_rule`
    of a shard of a parallel build) would not equal its judgement in one pass, continuing
    from the state ``before`` it (per topic: the one yaw seen so far, or NaN once they
    varied); None when it would. The shard started from ``assumed`` (topics whose
    orientations the plan found varied before it, :mod:`aion_cli.shard_yaws`), else from
    scratch. It differs where that assumption was wrong, and where the shard set aside the
    yaws of its first message while one pass had seen other yaws before (one pass keeps
    them)."""
    assumed = assumed or {}
    for topic, (first, _) in sorted(rule.items()):
        prev = before.get(topic)
        if topic in assumed:
            if prev is None or not np.isnan(prev):
                return (
                    f"these logs were started as if the pose orientations on {topic} had "
                    "varied before them, and in one pass they had not (the build's rules "
                    "drop or cannot decode the messages where the plan saw them vary)"
                )
            continue
        if prev is None or np.isnan(first):
            continue
        if np.isnan(prev) or abs(prev - first) > _SAME_YAW:
            return (
                f"the pose orientations on {topic} were all alike at the start of these logs, "
                "and one pass judges them against the orientations before them (it sets aside "
                "orientations that have never varied)"
            )
    return None


class DetectionFeeder:
    """Decodes chunks of raw detection messages into map-frame DetectionBatches.

    ``adapters``: the adapter per ``(topic, msgtype, encoding)`` (from
    :func:`aion_cli.pipeline`'s topic choice); ``factory`` builds the missing ones on first
    sight (default: the built-in adapter with shipped definitions). ``linker``: the track
    linker's parameters for id-less detections, None to leave them unlinked. ``trees``: the
    build's TF trees, ``tf`` their shared buffer (:mod:`aion_cli.tf_trees`). ``apart``: the
    recordings whose tracks are their own (:mod:`aion_cli.track_owners`)."""

    def __init__(
        self,
        tf: TfBuffer | None,
        map_frame: str,
        counts: DetectionCounts,
        adapters: Mapping[tuple[str, str, str], DetectionAdapter] | None = None,
        factory: AdapterFactory | None = None,
        linker: LinkerConfig | bool | None = True,
        yaw_seen: Mapping[str, float] | None = None,
        cell_size: float | None = None,
        trees: TfTrees | None = None,
        apart: frozenset[int] = frozenset(),
    ) -> None:
        from aion_cli.engine.heading import HeadingEstimator
        from aion_cli.engine.tracking import LinkerConfig
        from aion_cli.formats.raw import normalize_frame

        # into the map frame, spelt as the detections' frames are
        self.frames = MapFrameMover(tf, normalize_frame(map_frame), counts, trees=trees)
        self.counts = counts
        self.cell_size = cell_size  # the map's: rows it cannot place stop before linking
        self.adapters: dict[tuple[str, str, str], DetectionAdapter] = dict(adapters or {})
        self.factory = factory or default_factory
        self.headings = HeadingEstimator()
        self.apart = apart
        self._own_headings: dict[int, HeadingEstimator] = {}  # per recording in ``apart``
        if linker is True:
            linker = LinkerConfig()
        self.linker_config: LinkerConfig | None = linker or None
        cfg = self.linker_config
        # Linked tracks are differenced like the linker's own rule: displacements of at least
        # min_step, looking back at most heading_span_s (ids of their own number space).
        # A linked track's first rows (and those after its reference lapsed) wait for its
        # first displacement (look_ahead: :attr:`look`, for the build's HeadingHold).
        self.linked_headings = HeadingEstimator(
            min_displacement=cfg.min_step if cfg else 0.3,
            max_gap_s=cfg.heading_span_s if cfg else 5.0,
            look_ahead=True,
        )
        #: Per row of the last batch decoded: which rows wait for a later heading and which
        #: give it (:class:`aion_cli.engine.heading_hold.LookAhead`).
        self.look = LookAhead.none(0)
        self._linkers = TrackLinkers(cfg or LinkerConfig())  # per topic (and owner)
        # per topic: the one yaw its messages have shown so far (float), or _VARIES; a build
        # that continues another's stream (a shard learnt in sequence) starts from its state
        self._yaw_seen: dict[str, float] = dict(yaw_seen or {})
        # per topic: what its first judged message here gave (the yaw it unset, or _VARIES)
        self._yaw_first: dict[str, float] = {}

    def adapter(self, topic: str, msgtype: str, encoding: str) -> DetectionAdapter:
        """The adapter of ``topic`` (built on first use)."""
        key = (topic, msgtype, encoding)
        got = self.adapters.get(key)
        if got is None:
            got = self.adapters[key] = self.factory(topic, msgtype, encoding)
        return got

    def decode(self, messages: list[RawMessage]) -> DetectionBatch:
        """Decode, transform, link and give headings to ``messages`` (any detection topics)."""
        return self.decode_rows(messages)[0]

    def decode_segments(self, chunks: Sequence[list[RawMessage]]) -> list[DetectionBatch | None]:
        """:meth:`decode` of every chunk, in one go: the batches (None for an empty chunk) are
        what decoding the chunks one after the other gives (see :meth:`decode_rows`)."""
        messages, segment = _flatten(chunks)
        batch, rows_segment = self.decode_rows(messages, segment)
        return _split(batch, rows_segment, chunks)

    def decode_rows(
        self, messages: list[RawMessage], segment: I64 | None = None
    ) -> tuple[DetectionBatch, I64]:
        """Decode, transform, link and give headings to ``messages``; with ``segment`` (per
        message, non-decreasing: the scene-graph interval it lies in) every step acts as if
        each segment were decoded by a call of its own, in order -- rows sorted by time within
        their segment, headings and links carried from one segment to the next, a topic's
        orientations judged per segment -- while the byte decoding, the transforms and the
        heading estimation run once over all of them. Returns the batch (rows in (segment,
        time) order) and each row's segment."""
        from aion_cli.formats.detections.frame import FrameDetections

        if segment is None:
            segment = np.zeros(len(messages), np.int64)
        groups = _groups(messages, attrgetter("topic", "msgtype", "encoding"))
        if len(groups) > 1 and len(segment) and segment[0] != segment[-1]:
            # Several types or encodings (a topic recorded by both ROS versions): their yaw
            # judgement and their linker are the topic's, shared in the order of each
            # segment's messages, so such a job is decoded segment by segment (rare).
            return self._by_segment(messages, segment)
        parts = []
        linked = []
        row_segs = []
        firsts = []
        owners: list[I64 | None] = []
        for (topic, msgtype, encoding), index in groups.items():
            adapter = self.adapter(topic, msgtype, encoding)
            msgs = messages if len(groups) == 1 else [messages[i] for i in index]
            seg = segment if len(groups) == 1 else segment[np.asarray(index, np.int64)]
            frames = adapter.decode(msgs, on_error="skip")  # damaged messages: counted
            self._count(topic, adapter, frames, msgs)
            frames, _ = self._informative_yaws(topic, frames, frames.msg_index)
            frames = self.counts.placeable(self.frames.move(frames, msgs), self.cell_size)
            rseg = seg[frames.msg_index]
            owner = owners_of(msgs, frames.msg_index, self.apart)
            parts.append(frames)
            row_segs.append(rseg)
            owners.append(owner)
            linked.append(self._link(topic, frames, rseg, owner))
            firsts.append(_first_in_segment(np.asarray(index, np.int64), seg))
        if not parts:
            self.look = LookAhead.none(0)
            return DetectionBatch.empty(), np.zeros(0, np.int64)
        merged = parts[0] if len(parts) == 1 else FrameDetections.concat(parts)
        link_ids = linked[0] if len(linked) == 1 else np.concatenate(linked)
        rows_segment = row_segs[0] if len(row_segs) == 1 else np.concatenate(row_segs)
        owner = concat_owners(owners, [len(p) for p in parts])
        order = _time_order(merged.t_ns, rows_segment, row_segs, firsts)
        if order is not None:
            merged, link_ids, rows_segment = (
                merged.select(order), link_ids[order], rows_segment[order]
            )
            owner = None if owner is None else owner[order]
        return self._headings(merged, link_ids, rows_segment, owner), rows_segment

    # --- internals ---------------------------------------------------------------------------
    def _by_segment(
        self, messages: list[RawMessage], segment: I64
    ) -> tuple[DetectionBatch, I64]:
        """:meth:`decode_rows` one segment at a time (segments are contiguous runs)."""
        cuts = (np.flatnonzero(segment[1:] != segment[:-1]) + 1).tolist()
        batches, segs, looks = [], [], []
        for a, b in zip([0, *cuts], [*cuts, len(messages)], strict=True):
            batch, _ = self.decode_rows(messages[a:b])
            batches.append(batch)
            segs.append(np.full(len(batch), segment[a], np.int64))
            looks.append(self.look)
        self.look = LookAhead.concat(looks)
        return DetectionBatch.concat(batches), np.concatenate(segs)

    def _count(self, topic: str, adapter: DetectionAdapter, frames: Any, msgs: list[Any]) -> None:
        c, per_topic = self.counts, self.counts.topic(topic)
        c.read += len(frames)
        if adapter.stamped:
            c.stamp_fallbacks += int(frames.stamp_fallbacks)
            per_topic.count_far_stamps(frames.t_ns, msgs, frames.msg_index)
        else:
            c.log_times += int(frames.stamp_fallbacks)
        per_topic.messages += len(msgs)
        c.count_empty(frames)
        c.add_decoded(per_topic, frames.filtered)
        error = adapter.first_error
        if error is not None and per_topic.first_error is None:
            per_topic.first_error, per_topic.first_hint = error.message, error.hint

    def _informative_yaws(self, topic: str, frames: Any, message: I64) -> tuple[Any, int | None]:
        """``frames`` with its yaws unset while its topic's orientations have never varied
        (checked in the message frame, before TF turns them with the robot): a publisher
        that leaves every orientation at zero or at identity says nothing about where people
        walk, and a yaw of 0 for everyone would pose as a heading.

        Judged message by message (``message`` per row, non-decreasing), in log order: a
        message's yaws are unset while they and all before agree; from the first message that
        differs on, yaws are kept. So the judgement depends on the messages only, never on
        how the stream was cut into chunks or shards (a parallel build's join compares a
        shard's first judgement with the state before it: :func:`yaw_rule_blocker`).

        Also returns the message (``message``'s value) at which the topic's orientations
        first varied, if that happened here (None otherwise)."""
        y = frames.yaw
        finite = np.flatnonzero(np.isfinite(y))
        if finite.size == 0:
            return frames, None
        seen = self._yaw_seen.get(topic)
        if seen is not None and np.isnan(seen):
            self._yaw_first.setdefault(topic, _VARIES)
            return frames, None  # the topic's orientations vary: they are real
        fmsg = message[finite]
        starts = np.flatnonzero(np.r_[True, fmsg[1:] != fmsg[:-1]])
        vals = y[finite]
        lows = np.minimum.reduceat(vals, starts)
        highs = np.maximum.reduceat(vals, starts)
        before = np.r_[lows[0] if seen is None else seen, lows[:-1]]  # each one's previous
        differs = (highs - lows > _SAME_YAW) | (np.abs(lows - before) > _SAME_YAW)
        alike = int(np.argmax(differs)) if differs.any() else len(starts)  # messages unset
        varied = None
        if alike < len(starts):
            self._yaw_seen[topic] = _VARIES
            varied = int(fmsg[starts[alike]])
        else:
            self._yaw_seen[topic] = float(lows[-1])
        self._yaw_first.setdefault(topic, float(lows[0]) if alike else _VARIES)
        if alike == 0:
            return frames, varied
        if alike == len(starts) and message[0] == message[-1]:
            return dataclasses.replace(frames, yaw=np.full(len(frames), np.nan)), varied
        # the messages judged alike lose their yaws, every row of them
        gone = np.isin(message, fmsg[starts[:alike]])
        return dataclasses.replace(frames, yaw=np.where(gone, np.nan, y)), varied

    def judge_orientations(self, messages: list[RawMessage]) -> dict[str, int]:
        """Judge ``messages`` (in log order) by the orientation rule alone -- decoded, not
        transformed, linked or counted -- and return the topics whose orientations first
        varied among them, with the log time of the message where they did (a parallel
        build's plan: :mod:`aion_cli.shard_yaws`)."""
        out = {}
        for (topic, msgtype, encoding), index in _groups(
            messages, attrgetter("topic", "msgtype", "encoding")
        ).items():
            adapter = self.adapter(topic, msgtype, encoding)
            frames = adapter.decode([messages[i] for i in index], on_error="skip")
            _, varied = self._informative_yaws(topic, frames, frames.msg_index)
            if varied is not None:
                out[topic] = messages[index[varied]].log_time_ns
        return out

    def yaw_rule(self) -> dict[str, tuple[float, float]]:
        """Per topic with a finite pose yaw: ``(first, last)``, what the orientation rule of
        :meth:`_informative_yaws` made of the topic's first judged message here and where it
        ended (the one yaw seen so far, or NaN once they varied). A parallel build compares
        a shard's ``first`` with the state before it (``aion_cli.shard_fold.fold``)."""
        return {t: (first, self._yaw_seen[t]) for t, first in self._yaw_first.items()}

    def _link(
        self, topic: str, frames: Any, segment: I64, owner: I64 | None = None
    ) -> np.ndarray:
        """Linked track ids (-1 elsewhere) of the rows that have no other heading source: no
        track id, no velocity, no (informative) pose yaw. One linker per topic and owner
        (``owner`` per row, None: all :data:`~aion_cli.track_owners.REST`), so that two
        sensors' or two robots' detections are never joined into one track; rows are linked
        segment by segment (``segment`` per row), in order, as separate calls would link them."""
        out = np.full(len(frames), -1, np.int64)
        if self.linker_config is None or len(frames) == 0:
            return out
        v = frames.velocity
        moving = all_columns(np.isfinite(v[:, :2])) & ((v[:, 0] != 0) | (v[:, 1] != 0))
        rows = np.flatnonzero((frames.track_id < 0) & ~moving & np.isnan(frames.yaw))
        if rows.size == 0:
            return out
        self._linkers.link(out, topic, frames, segment, rows, owner)
        return out

    def _headings(
        self, merged: Any, link_ids: np.ndarray, segment: I64, owner: I64 | None = None
    ) -> DetectionBatch:
        """Headings of every row: the main estimator for rows with the source's ids (or none;
        a recording's own for the rows whose tracks are its own, ``owner`` per row), the
        linked estimator for linked rows; both tallied by source. Rows are differenced in
        (segment, time) order (``segment`` per row)."""
        from aion_cli.engine.heading import SOURCES, HeadingEstimator

        if owner is None:
            batch = self.headings.to_batch(merged, segment)
            sources = self.headings.sources
        else:
            batch, sources = estimate_by_owner(
                self.headings, self._own_headings, HeadingEstimator, merged, segment, owner
            )
        is_linked = link_ids >= 0
        self.look = LookAhead.none(len(batch))
        if is_linked.any():
            rows = np.flatnonzero(is_linked)
            lb = self.linked_headings.estimate(
                merged.t_ns[rows], merged.xyz[rows], merged.velocity[rows], merged.yaw[rows],
                link_ids[rows], segment[rows],
            )
            batch.heading[rows], batch.speed[rows] = lb.heading, lb.speed
            self.look.put(rows, self.linked_headings.look)
            lsrc = self.linked_headings.sources
            self._tally(lsrc, SOURCES, linked=True)
            sources = sources[~is_linked]
        self._tally(sources, SOURCES, linked=False)
        micro, n = speed_micro(batch.speed)
        self.counts.speed_micro += micro
        self.counts.speed_n += n
        return batch

    def _tally(self, codes: np.ndarray, names: tuple[str, ...], linked: bool) -> None:
        tally = np.bincount(codes, minlength=len(names))
        for name, n in zip(names, tally.tolist(), strict=True):
            if n:
                key = "linked" if linked and name == "track" else name
                self.counts.headings[key] += int(n)


__all__ = [
    "HEADING_SOURCES",
    "MAX_CHUNK_BYTES",
    "AdapterFactory",
    "Chunk",
    "DetectionCounts",
    "DetectionFeeder",
    "TopicCounts",
    "TopicFeeders",
    "chunks",
    "decoded_chunks",
    "log_adapters",
]

