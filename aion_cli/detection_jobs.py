"""Decode jobs of several pieces and topics: a job's chunks flattened into one message list
with the segment (chunk) of each message, grouped by key, rows put back in (segment, time)
order and split into one batch per chunk (the helpers :class:`DetectionFeeder` and
:class:`TopicFeeders` share), and :class:`TopicFeeders`, one feeder per detection topic with
the rows merged as one feeder would give them.

:class:`~aion_cli.detection_feed.DetectionFeeder` itself lives in :mod:`aion_cli.detection_feed`
(imported here for type checking only, so the two modules import no cycle).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from operator import attrgetter
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from aion_cli.detection_counts import DetectionCounts
from aion_cli.engine.heading_hold import LookAhead
from aion_cli.engine.types import I64, DetectionBatch

if TYPE_CHECKING:
    from aion_cli.detection_feed import DetectionFeeder
    from aion_cli.formats.raw import RawMessage

K = TypeVar("K")


def _groups(messages: list[RawMessage], key: Callable[[RawMessage], K]) -> dict[K, list[int]]:
    """Message positions by ``key``, groups in order of first appearance. A job of one topic
    and type (the usual case) is recognised by a C-level pass, without a Python loop over its
    messages (which would hold the GIL the reading thread needs)."""
    keys = list(map(key, messages))
    if len(set(keys)) <= 1:
        return {keys[0]: list(range(len(keys)))} if keys else {}
    groups: dict[K, list[int]] = {}
    for i, k in enumerate(keys):
        groups.setdefault(k, []).append(i)
    return groups


def _flatten(chunks: Sequence[list[RawMessage]]) -> tuple[list[RawMessage], I64]:
    """The messages of ``chunks`` in order, and the chunk (segment) of each."""
    messages = [m for chunk in chunks for m in chunk]
    lengths = np.fromiter(map(len, chunks), np.int64, len(chunks))
    return messages, np.repeat(np.arange(len(chunks), dtype=np.int64), lengths)


def _split(
    batch: DetectionBatch, rows_segment: I64, chunks: Sequence[list[RawMessage]]
) -> list[DetectionBatch | None]:
    """``batch`` (rows in segment order) cut into one batch per chunk (views; None for an empty
    chunk, an empty batch for a chunk without detections)."""
    bounds = np.searchsorted(rows_segment, np.arange(len(chunks) + 1)).tolist()
    out: list[DetectionBatch | None] = []
    for k, chunk in enumerate(chunks):
        a, b = bounds[k], bounds[k + 1]
        out.append(None if not chunk else _rows(batch, a, b))
    return out


def _rows(batch: DetectionBatch, a: int, b: int) -> DetectionBatch:
    """Rows ``a:b`` as a batch of their own (a distinct object per piece, even when empty:
    :meth:`TopicFeeders.topics_of` finds a piece's labels by identity)."""
    if a == 0 and b == len(batch) > 0:
        return batch
    return DetectionBatch(
        batch.t_ns[a:b], batch.xyz[a:b], batch.heading[a:b], batch.speed[a:b],
        batch.track_id[a:b],
    )


def _first_in_segment(index: I64, segment: I64) -> I64:
    """Per segment value (dense, up to the largest), the position of the first of a group's
    messages (``index``: their positions in the job, ``segment``: theirs) in that segment; a
    large value where the group has none. Decoding one segment alone concatenates its groups
    in this order."""
    top = int(segment.max(initial=-1)) + 1
    out = np.full(top, np.iinfo(np.int64).max, np.int64)
    if len(index):
        starts = np.flatnonzero(np.r_[True, segment[1:] != segment[:-1]])
        out[segment[starts]] = index[starts]
    return out


def _time_order(
    t: I64, segment: I64, part_segments: list[I64], firsts: list[I64]
) -> I64 | None:
    """The order that puts concatenated parts' rows as decoding each segment alone would: by
    segment, then time, ties by the part that came first in the segment, then by row (a
    stable sort); None when the rows are in that order already."""
    if len(part_segments) == 1:
        if t.size < 2 or bool(np.all((segment[1:] != segment[:-1]) | (t[1:] >= t[:-1]))):
            return None
        return np.lexsort((t, segment))
    rank = np.concatenate([f[s] for f, s in zip(firsts, part_segments, strict=True)])
    return np.lexsort((rank, t, segment))


class TopicFeeders:
    """One :class:`DetectionFeeder` per detection topic, so the build knows what became of
    each topic's detections (its own counts, its own heading estimator and track linker: the
    track ids of two sensors are unrelated), with the rows merged in time order for the
    Mapper as one feeder would give them.

    :meth:`decode` and :meth:`decode_segments` have the feeder's signatures
    (:func:`decoded_chunks` runs them in its worker thread); :meth:`topics_of` then gives the
    topic index of each row of a returned batch."""

    def __init__(
        self, make: Callable[[str, DetectionCounts], DetectionFeeder], topics: list[str]
    ) -> None:
        self.topics = topics
        self.index = {topic: i for i, topic in enumerate(topics)}
        self.counts = {topic: DetectionCounts() for topic in topics}
        self.feeders = {topic: make(topic, self.counts[topic]) for topic in topics}
        self._labels: dict[int, I64] = {}
        self._looks: dict[int, LookAhead] = {}

    def decode(self, messages: list[RawMessage]) -> DetectionBatch:
        """One chunk (see :meth:`DetectionFeeder.decode`)."""
        got = self._decode_job([messages])[0]
        return DetectionBatch.empty() if got is None else got

    def decode_segments(self, chunks: Sequence[list[RawMessage]]) -> list[DetectionBatch | None]:
        """Every chunk's batch (None for an empty chunk), as decoding the chunks one after
        the other gives them, with one decode per topic for all of them
        (:meth:`DetectionFeeder.decode_rows`)."""
        return self._decode_job(chunks)

    def _decode_job(self, chunks: Sequence[list[RawMessage]]) -> list[DetectionBatch | None]:
        messages, segment = _flatten(chunks)
        groups = _groups(messages, attrgetter("topic"))
        batches, labels, segs, firsts, looks = [], [], [], [], []
        for topic, index in groups.items():
            idx = np.asarray(index, np.int64)
            one = len(groups) == 1
            batch, rseg = self.feeders[topic].decode_rows(
                messages if one else [messages[i] for i in index], segment if one else
                segment[idx],
            )
            batches.append(batch)
            labels.append(np.full(len(batch), self.index[topic], np.int64))
            looks.append(self.feeders[topic].look.rekeyed(labels[-1], len(self.topics)))
            segs.append(rseg)
            firsts.append(_first_in_segment(idx, segment[idx]))
        if not batches:
            return [None if not c else DetectionBatch.empty() for c in chunks]
        if len(batches) == 1:
            batch, label, rows_segment, look = batches[0], labels[0], segs[0], looks[0]
        else:
            batch = DetectionBatch.concat(batches)
            label, rows_segment = np.concatenate(labels), np.concatenate(segs)
            look = LookAhead.concat(looks)
            order = np.lexsort((
                np.concatenate([f[s] for f, s in zip(firsts, segs, strict=True)]),
                batch.t_ns, rows_segment,
            ))
            batch = DetectionBatch(
                batch.t_ns[order], batch.xyz[order], batch.heading[order], batch.speed[order],
                batch.track_id[order],
            )
            label, rows_segment, look = label[order], rows_segment[order], look.select(order)
        out = _split(batch, rows_segment, chunks)
        bounds = np.searchsorted(rows_segment, np.arange(len(chunks) + 1)).tolist()
        for k, piece in enumerate(out):
            if piece is not None:
                self._labels[id(piece)] = label[bounds[k] : bounds[k + 1]]
                self._looks[id(piece)] = look.select(slice(bounds[k], bounds[k + 1]))
        return out

    def look_of(self, batch: DetectionBatch) -> LookAhead:
        """The :class:`LookAhead` of each row of a batch :meth:`decode` or
        :meth:`decode_segments` gave (call before :meth:`topics_of`, by the same rule)."""
        look = self._looks.pop(id(batch), None)
        return LookAhead.none(len(batch)) if look is None else look

    def count_settled(self, settled: dict[int, int]) -> None:
        """Rows a :class:`HeadingHold` gave a heading (per topic index) move from their
        topic's 'none' heading count to its 'linked' one."""
        for index, k in settled.items():
            headings = self.counts[self.topics[index]].headings
            headings["none"] -= k
            headings["linked"] += k

    def topics_of(self, batch: DetectionBatch) -> I64:
        """The topic index (into :attr:`topics`) of each row of a batch :meth:`decode` or
        :meth:`decode_segments` gave (an empty batch, which may be a chunk no topic decoded
        anything from, has no rows to label)."""
        labels = self._labels.pop(id(batch), None)
        if labels is None:
            if len(batch):
                raise KeyError("topics_of: a batch this TopicFeeders did not decode")
            return np.zeros(0, np.int64)
        return labels

    def total(self) -> DetectionCounts:
        """Every topic's counts added up (``used`` is the caller's)."""
        out = DetectionCounts()
        for counts in self.counts.values():
            out.read += counts.read
            out.stamp_fallbacks += counts.stamp_fallbacks
            out.log_times += counts.log_times
            out.dropped.update(counts.dropped)
            out.headings.update(counts.headings)
            out.speed_micro += counts.speed_micro
            out.speed_n += counts.speed_n
            out.empty_messages += counts.empty_messages
            for value, n in counts.filter_seen.items():
                out.see(value, n)
            out.topics.update(counts.topics)
            out.no_transform_why = out.no_transform_why or counts.no_transform_why
        return out
