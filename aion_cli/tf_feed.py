"""The TF feed of a build: one read of ``/tf`` and ``/tf_static`` into a ``TfBuffer``, with
the log times of every other topic the build uses taken in the same pass (and the time-sanity
rules over them, :func:`check_times`); what the buffer's robot trajectory observed is
:mod:`aion_cli.build_observation`'s.

Why a module of its own, beside :mod:`aion_cli.detection_feed` and
:mod:`aion_cli.graph_feed`: TF is read before the stream (the detections need their
transforms, the time-sanity rules need every log time), with its own fast decoder and its own
failure rules (:func:`check_tf`), none of which the build orchestration
(:mod:`aion_cli.pipeline`) needs to know.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import compress
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.mapper import TIME_RANGE_TEXT
from aion_cli.errors import InputError, MessageDecodeError
from aion_cli.formats.raw import recordings_of
from aion_cli.formats.tf_norms import NormTally
from aion_cli.graph_schedule import GraphTimes
from aion_cli.log_times import TimeCheck, TopicTimes
from aion_cli.tf_trees import REST

if TYPE_CHECKING:
    from aion_cli.build_report import BuildReport, ProgressSink
    from aion_cli.formats.raw import RawMessage
    from aion_cli.formats.tf import TfBuffer
    from aion_cli.topics import TopicPlan

__all__ = [
    "TfReader",
    "TfStats",
    "check_tf",
    "check_times",
    "check_unusable",
    "read_static_tf",
    "read_tf_and_times",
    "with_static_tf",
]

StaticTf = tuple[tuple[str, str, int, tuple[float, ...], tuple[float, ...]], ...]
"""Static transforms as ``(parent, child, stamp, translation, quaternion)``
(:meth:`formats.tf.TfBuffer.static_transforms`), small enough to send to every shard."""


@dataclass
class TfStats:
    """TF messages read and skipped as undecodable (with the first failure), ``/tf``
    transforms stamped 0 (unset) that took their message's log time instead, and rotations
    tf2 would refuse as not normalised (``norms``)."""

    messages: int = 0
    undecodable: int = 0
    first_error: MessageDecodeError | None = None
    unstamped: int = 0
    norms: NormTally = dataclasses.field(default_factory=NormTally)


def read_tf_and_times(
    logset: Any,
    plan: TopicPlan,
    timed: set[str],
    progress: ProgressSink,
    graph_topics: set[str] | None = None,
    *,
    use_index: bool = True,
    own: dict[int, TfBuffer] | None = None,
) -> tuple[TfBuffer | None, TopicTimes, TfStats]:
    """One read of the TF topics and of the other topics in ``timed`` (those the build uses):
    every TF message into one buffer, and the log time of every message of ``timed``
    (:class:`aion_cli.log_times.TopicTimes`: what the time-sanity rules are applied to).

    TF messages are decoded with numpy 4096 at a time (:mod:`formats.tf_fast`, ~50x faster
    than rosbags) where the log's definition of the TF type is the layout that decoder reads
    (:func:`formats.tf_fast.layout_matches`); messages of other topics, and a chunk the fast
    decoder rejects (e.g. big-endian CDR, a corrupt payload), are decoded message by message
    with the log's own definitions, and a message that cannot be decoded is skipped and
    counted (like a bad detection or scene-graph message). A TF message whose log time is out
    of the representable range is not decoded. The other topics' payloads are not decoded
    here. Where the logs' indexes give the log times the stream will yield
    (:meth:`formats.logs.LogSet.index_times`, ``use_index``) only the TF topics are read, and
    the other topics' times come as arrays from the index, without a message; otherwise
    every message of those topics is read with TF. With ``graph_topics`` the times are a
    :class:`GraphTimes`, which also keeps those topics' log times in read order (for
    :func:`aion_cli.graph_schedule.graph_schedule`). ``own``: buffers per recording
    (:attr:`formats.raw.RawMessage.recording`) that also receive that recording's own
    ``/tf`` transforms (:mod:`aion_cli.tf_trees`)."""
    import logging

    from aion_cli.formats.tf import TfBuffer

    tf_topics = plan.names("tf") if plan.tf else set()
    times = (
        GraphTimes(timed | tf_topics, graph_topics)
        if graph_topics
        else TopicTimes(timed | tf_topics)
    )
    stats = TfStats()
    topics = tf_topics | timed
    if not topics:
        return None, times, stats
    indexed = logset.index_times(timed - tf_topics) if use_index and timed - tf_topics else None
    if indexed is not None:
        times.add_stream(indexed)
        topics = tf_topics
    progress.start(
        "reading TF and log times" if tf_topics else "reading log times", logset.total(topics)
    )
    reader = TfReader(logset, TfBuffer(), stats, own) if tf_topics else None
    buffer = reader.buffer if reader is not None else None

    def add(chunk: list[RawMessage]) -> None:
        assert reader is not None
        reader.add(chunk)

    pending: list[RawMessage] = []  # TF messages whose times are not recorded yet
    ready: list[RawMessage] = []  # TF messages in range, decoded 4096 at a time
    done = 0
    for msg in logset.messages(topics) if topics else ():
        done += 1
        if done == 4096:
            progress.advance(done)
            done = 0
        if msg.topic not in tf_topics:
            times.add(msg.topic, msg.log_time_ns)
            continue
        pending.append(msg)
        if len(pending) == 4096:
            ready += _in_range(times, pending)
            pending = []
            while len(ready) >= 4096:
                add(ready[:4096])
                ready = ready[4096:]
    ready += _in_range(times, pending)
    for start in range(0, len(ready), 4096):
        add(ready[start : start + 4096])
    progress.advance(done)
    if reader is not None and reader.generic:
        logging.getLogger(__name__).info(
            "TF: %d chunk(s) read by the generic decoder", reader.generic
        )
    return buffer, times, stats


class TfReader:
    """TF messages into ``buffer``, a chunk at a time: decoded with numpy
    (:mod:`formats.tf_fast`) where the log's definition of the TF type is the layout that
    decoder reads, else (and for a chunk it rejects) message by message with the log's own
    definitions, a message that cannot be decoded skipped and counted in ``stats``. Topics
    named ``*_static`` hold static transforms. ``own``: per recording, a buffer that also
    receives the ``/tf`` (not static) transforms of that recording's messages (the one keyed
    :data:`~aion_cli.tf_trees.REST` those of the recordings without a buffer of their own)."""

    def __init__(
        self,
        logset: Any,
        buffer: TfBuffer,
        stats: TfStats,
        own: dict[int, TfBuffer] | None = None,
    ) -> None:
        self.logset = logset
        self.buffer = buffer
        self.stats = stats
        self.own = own or {}
        self.generic = 0  # chunks read by the generic decoder
        self._fast_ok: dict[tuple[str, str, str], bool] = {}

    def _fast(self, key: tuple[str, str, str]) -> bool:
        from aion_cli.formats.tf_fast import layout_matches

        ok = self._fast_ok.get(key)
        if ok is None:
            ok = self._fast_ok[key] = layout_matches(
                key[1], key[2], *self.logset.definition(*key)
            )
        return ok

    def add(self, chunk: list[RawMessage]) -> None:
        from aion_cli.formats.tf_fast import decode_tf_messages

        stats, buffer = self.stats, self.buffer
        stats.messages += len(chunk)
        static = np.fromiter((m.topic.endswith("_static") for m in chunk), bool, len(chunk))
        try:
            if not all(map(self._fast, {(m.topic, m.msgtype, m.encoding) for m in chunk})):
                raise MessageDecodeError("the log defines TF in another layout")
            arrays = decode_tf_messages(chunk)
        except MessageDecodeError:
            self.generic += 1
            for m, st in zip(chunk, static.tolist(), strict=True):
                try:
                    decoded = self.logset.decode(m)
                except MessageDecodeError as exc:
                    stats.undecodable += 1
                    if stats.first_error is None:
                        stats.first_error = exc
                    continue
                if not st:
                    stats.unstamped += _stamp_unset(decoded, m.log_time_ns)
                stats.norms.add_message(m.topic, decoded)
                buffer.add_message(decoded, static=st)
                own = None if st else self.own.get(m.recording, self.own.get(REST))
                if own is not None:
                    own.add_message(decoded)
        else:
            stats.norms.add_arrays(chunk, arrays)
            rows_static = static[arrays.msg_index]
            unset = (arrays.t_ns == 0) & ~rows_static  # like detections: the log time
            if unset.any():
                log = np.fromiter((m.log_time_ns for m in chunk), np.int64, len(chunk))
                t = np.where(unset, log[arrays.msg_index], arrays.t_ns)
                arrays = dataclasses.replace(arrays, t_ns=t)
                stats.unstamped += int(unset.sum())
            for flag in (True, False):  # like TfBuffer's own batches: static rows first
                for parent, child, rows in arrays.select(
                    arrays.usable() & (rows_static == flag)
                ).by_edge():
                    buffer.add_transforms(
                        parent, child, rows.t_ns, rows.translation, rows.quat_xyzw, flag
                    )
            if self.own:
                self._route(chunk, arrays, rows_static)

    def _route(self, chunk: list[RawMessage], arrays: Any, rows_static: np.ndarray) -> None:
        """The decoded ``/tf`` rows of ``chunk`` (``arrays``) also into the buffer of the
        recording each came from (:attr:`own`; :data:`~aion_cli.tf_trees.REST`'s: the
        recordings without one)."""
        of = recordings_of(chunk)[arrays.msg_index]
        of[~np.isin(of, list(self.own))] = REST
        dynamic = arrays.usable() & ~rows_static
        for recording, own in self.own.items():
            for parent, child, rows in arrays.select(dynamic & (of == recording)).by_edge():
                own.add_transforms(
                    parent, child, rows.t_ns, rows.translation, rows.quat_xyzw, False
                )


def read_static_tf(logset: Any, plan: TopicPlan) -> StaticTf:
    """The static transforms (``*_static`` TF topics) of every log of ``logset``, read in
    time order as a build of them all reads them (the last one of an edge and stamp wins).
    A parallel build gives them to each of its shards (:func:`with_static_tf`): a shard reads
    only its own logs, and ``/tf_static`` is often recorded once, in the first log or a log
    of its own."""
    from aion_cli.formats.tf import TfBuffer

    topics = {t for t in plan.names("tf") if t.endswith("_static")} if plan.tf else set()
    if not topics:
        return ()
    reader = TfReader(logset, TfBuffer(), TfStats())
    times = TopicTimes(topics)
    chunk: list[RawMessage] = []
    for msg in logset.messages(topics):
        chunk.append(msg)
        if len(chunk) == 4096:
            reader.add(_in_range(times, chunk))  # (never empty: the times are in range)
            chunk = []
    if chunk:
        reader.add(_in_range(times, chunk))
    return tuple(
        (p, c, stamp, tuple(tr.tolist()), tuple(q.tolist()))
        for p, c, stamp, tr, q in reader.buffer.static_transforms()
    )


def with_static_tf(tf: TfBuffer | None, static: StaticTf) -> TfBuffer | None:
    """``tf`` with the ``static`` transforms of a whole build added after its own (the same
    edges as one read of all the logs: the last one given per stamp wins), a new buffer
    when ``tf`` is None."""
    if not static:
        return tf
    from aion_cli.formats.tf import TfBuffer

    buffer = tf if tf is not None else TfBuffer()
    parents, children, stamps, tr, q = zip(*static, strict=True)
    buffer.add_transforms(list(parents), list(children), stamps, tr, q, static=True)
    return buffer


def _stamp_unset(msg: Any, log_time_ns: int) -> int:
    """A decoded ``/tf`` message's transforms stamped 0 (unset by the publisher) take its log
    time, as detections do (:func:`formats.detections.frame.stamps_or_log_time`): looked up
    at the detections' times, a transform of 1970 is never found. How many were."""
    n = 0
    for tf in msg.transforms:
        stamp = tf.header.stamp
        if getattr(stamp, "sec", None) == 0 and getattr(stamp, "nanosec", None) == 0:
            tf.header.stamp = dataclasses.replace(
                stamp, sec=log_time_ns // 1_000_000_000, nanosec=log_time_ns % 1_000_000_000
            )
            n += 1
    return n


def _in_range(times: TopicTimes, messages: list[RawMessage]) -> list[RawMessage]:
    """Record the log times of ``messages`` (TF, in read order) topic by topic as arrays
    (:meth:`TopicTimes.add_array`); the messages whose times are in range."""
    if not messages:
        return messages
    t = np.array([m.log_time_ns for m in messages])
    if t.dtype.kind not in "iu":  # ints beyond both int64 and uint64: one by one
        return [m for m in messages if times.add(m.topic, m.log_time_ns)]
    topics = [m.topic for m in messages]
    names = set(topics)
    if len(names) == 1:
        ok = times.add_array(topics[0], t)
    else:
        of = np.array(topics)
        ok = np.empty(len(messages), bool)
        for name in sorted(names):
            mine = of == name
            ok[mine] = times.add_array(name, t[mine])
    return messages if ok.all() else list(compress(messages, ok.tolist()))


def check_tf(stats: TfStats, tf_topics: set[str], report: BuildReport) -> None:
    """Undecodable TF messages were skipped: a warning with the count; when none of them
    could be decoded the build stops (without its TF the map would silently change its
    frames and its observation). ``/tf`` transforms without a stamp: a note."""
    if stats.unstamped:
        dynamic = ", ".join(sorted(t for t in tf_topics if not t.endswith("_static")))
        report.notes.append(
            f"{stats.unstamped:,} transform(s) on {dynamic} were stamped 0 (unset by their "
            "publisher): their log time was taken, as for detections"
        )
    if stats.norms.text():
        report.warnings.append(stats.norms.text())
    if stats.undecodable == 0 or stats.first_error is None:
        return
    names = ", ".join(sorted(tf_topics))
    report.tf_undecodable = stats.undecodable
    if stats.undecodable == stats.messages:
        raise MessageDecodeError(
            f"none of the {stats.messages:,} messages on {names} could be decoded: "
            f"{stats.first_error.message}",
            hint=stats.first_error.hint,
        )
    report.warnings.append(
        f"{stats.undecodable:,} of {stats.messages:,} messages on {names} could not be "
        f"decoded and were skipped (first: {stats.first_error.message})"
    )


def check_unusable(tf: TfBuffer | None, report: BuildReport) -> None:
    """TF transforms the buffer dropped as unusable (NaN, zero quaternion): a warning naming
    the edges, since detections and robot poses that needed them are lost with them; and
    frames TF gives two parents (not a tree: which chain joins two frames is a guess)."""
    if tf is None:
        return
    from aion_cli.formats.tf_tree import extra_parents, unusable_text
    from aion_cli.listing import first_few

    if tf.unusable:
        report.warnings.append(
            f"TF transforms ignored: {unusable_text(tf.unusable)}; detections or robot poses "
            "that needed them are dropped (tf2 ignores such transforms too)"
        )
    extra = extra_parents(tf.edges)
    if extra:
        named = [f"{c!r} ({', '.join(ps)})" for c, ps in extra.items()]
        report.warnings.append(
            f"TF gives frames more than one parent: {first_few(named, 5)}; a TF tree has one "
            "parent per frame, so aion joins two frames by the shortest chain, which may not "
            "be the one meant (two localisers publishing the same frame?)"
        )


def check_times(
    times: TopicTimes,
    plan: TopicPlan,
    timed: set[str],
    report: BuildReport,
    recordings: Sequence[tuple[int, int]] = (),
) -> TimeCheck:
    """The time-sanity rules (:mod:`aion_cli.log_times`) over the log times read with TF:
    their warnings and per-topic drops go to the report, and the returned
    :class:`~aion_cli.log_times.TimeCheck` filters the build's later reads. The build's time
    span comes from the topics in ``timed`` (detections, scene graphs) and the dynamic TF
    topics only: unrelated topics, ``/tf_static`` and container summaries have no say. When
    every detection message has an unrepresentable log time the build stops."""
    tf_topics = plan.names("tf") if plan.tf else set()
    span = timed | {t for t in tf_topics if not t.endswith("_static")}
    checked = times.check(span, recordings)
    report.warnings.extend(checked.warnings(decoded=tf_topics))
    report.time_dropped = {
        topic: {
            "out_of_range": int(checked.out_of_range.get(topic, 0)),
            "stray": int(checked.strays[topic].size) if topic in checked.strays else 0,
        }
        for topic in sorted(set(checked.out_of_range) | set(checked.strays))
        if checked.out_of_range.get(topic) or topic in checked.strays
    }
    detection_topics = plan.names("detections")
    dropped = sum(checked.out_of_range.get(t, 0) for t in detection_topics)
    if dropped and not any(checked.kept.get(t, 0) for t in detection_topics):
        raise InputError(
            f"every one of the {dropped:,} detection messages has a log time outside "
            f"{TIME_RANGE_TEXT} ({', '.join(sorted(detection_topics))})",
            hint="log times are nanoseconds since 1970 (UTC); the recorder's clock or the "
            "file is broken; no map was written",
        )
    return checked
