""":class:`DetectionAdapter`: decodes a list of raw messages of one type into
:class:`FrameDetections`, through the fast numpy decoder where there is one and the wire layout
matches, else through rosbags deserialization plus a field extractor.

Messages are grouped by encoding (ROS 2 CDR, ROS 1), each group is decoded in one go, and rows
come back in message order. A fast decode that fails (big-endian CDR, a fork with a different
layout under the same name, a damaged payload) is retried with the generic decoder; if that
fails too the error is a :class:`MessageDecodeError` (or, with ``on_error="skip"``, the bad
messages are dropped one by one and counted).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from operator import attrgetter
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from aion_cli.errors import ConfigError, MessageDecodeError
from aion_cli.formats.detections.fast import Decoded
from aion_cli.formats.detections.frame import (
    FrameDetections,
    FrameTable,
    quat_yaw,
    stamps_or_log_time,
)
from aion_cli.formats.detections.generic import Rows
from aion_cli.formats.detections.wire import Joined, join_payloads
from aion_cli.formats.raw import RawMessage

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

#: Largest payload the generic decoder (rosbags objects, a Python loop per element: about
#: 0.16 µs per byte) reads; a bigger message is a MessageDecodeError (counted as undecodable
#: in a build), so one hostile message cannot cost minutes. The numpy decoders have no such
#: limit.
GENERIC_MAX_PAYLOAD = 4 * 1024**2

FastDecoder = Callable[[Joined], Decoded]
#: Appends the detections of one deserialized message (index ``owner``) to ``rows``.
Extractor = Callable[[Any, int, Rows], None]
OnError = Literal["raise", "skip"]


def default_typestore(ros_version: Literal[1, 2]) -> Typestore:
    """aion's shipped definitions (:func:`formats.msgdefs.typestore`)."""
    from aion_cli.formats import msgdefs

    return msgdefs.typestore(ros_version)


class DetectionAdapter:
    """Decoder for one message type.

    ``fast`` is the numpy decoder (or None); ``extract`` the generic extractor on rosbags
    objects; ``typestore`` a rosbags typestore to deserialize with (e.g. built from a log's
    embedded definitions) -- None uses aion's shipped definitions for the message's ROS
    version. ``strict_fields``: a missing field is a :class:`ConfigError` (user mappings)
    rather than a :class:`MessageDecodeError` (built-in adapters on an unexpected layout).
    """

    def __init__(
        self,
        msgtype: str,
        extract: Extractor,
        fast: FastDecoder | None = None,
        typestore: Typestore | None = None,
        strict_fields: bool = False,
    ) -> None:
        self.msgtype = msgtype
        self.extract = extract
        self.fast = fast
        self.typestore = typestore
        self.strict_fields = strict_fields
        #: The first :class:`MessageDecodeError` met in ``on_error="skip"`` mode (the build
        #: reports it when every message of a topic fails).
        self.first_error: MessageDecodeError | None = None
        #: Set when the log's definition of the type is not the layout of the fast decoder,
        #: which is then not used (:func:`formats.detections.registry.log_adapter`).
        self.layout_differs = False
        #: False when the messages carry no stamp by design (a mapping of a header-less
        #: type): their log times are then the rule, not a fallback.
        self.stamped = True

    def __repr__(self) -> str:
        return f"DetectionAdapter({self.msgtype!r}, {self.kind})"

    @property
    def kind(self) -> str:
        """How this adapter decodes: ``fast`` (numpy over the bytes), ``mapping`` (a user's
        TOML mapping) or ``generic`` (rosbags objects and field paths)."""
        if self.fast is not None:
            return "fast"
        return "mapping" if self.strict_fields else "generic"

    # --- public --------------------------------------------------------------------------------
    def decode(
        self, messages: Sequence[RawMessage], on_error: OnError = "raise"
    ) -> FrameDetections:
        """Detections of ``messages`` (all of this adapter's type), rows in message order."""
        if not messages:
            return FrameDetections.empty()
        groups = _groups(messages)
        if len(groups) == 1:
            ((key, _),) = groups.items()
            out = self._decode_group(list(messages), key, on_error)
            return _with_n_messages(out, len(messages))
        parts = []
        for key, idx in groups.items():
            group = [messages[i] for i in idx]
            part = self._decode_group(group, key, on_error)
            parts.append(_reindex(part, np.asarray(idx, np.int64)))
        out = FrameDetections.concat(parts, offset_messages=False) if len(parts) > 1 else parts[0]
        out = _with_n_messages(out, len(messages))
        if len(parts) > 1:
            out = out.select(np.argsort(out.msg_index, kind="stable"))
        return out

    def decode_generic(self, messages: Sequence[RawMessage]) -> FrameDetections:
        """Decode through rosbags objects only (the reference the fast path is tested
        against, and the fallback)."""
        rows = Rows()
        begin = getattr(self.extract, "begin", None)
        if begin is not None:  # an extractor that reads across messages (lone Markers)
            begin()
        for i, m in enumerate(messages):
            self.extract(self.deserialize(m, i), i, rows)
        flush = getattr(self.extract, "flush", None)
        if flush is not None:
            flush(rows)
        return _from_rows(rows, messages)

    def deserialize(self, m: RawMessage, index: int = 0) -> Any:
        """The rosbags object of one message; :class:`MessageDecodeError` if it fails."""
        store = self.typestore or default_typestore(1 if m.encoding == "ros1" else 2)
        try:
            if m.encoding == "ros1":
                return store.deserialize_ros1(m.data, self.msgtype)
            return store.deserialize_cdr(m.data, self.msgtype)
        except Exception as exc:  # rosbags raises many kinds (struct.error, KeyError, ...)
            raise MessageDecodeError(
                f"cannot decode the {self.msgtype} message on {m.topic!r} at log time "
                f"{m.log_time_ns} ns: "
                f"{type(exc).__name__}: {exc}",
                hint="the payload is truncated or corrupt, or the log's definition differs",
            ) from exc

    # --- internals -----------------------------------------------------------------------------
    def _decode_group(
        self, group: list[RawMessage], key: str, on_error: OnError
    ) -> FrameDetections:
        try:
            return self._decode_once(group, key)
        except MessageDecodeError as exc:
            if on_error == "raise":
                raise
            if len(group) == 1:
                self._remember(exc)
                return _skipped(1)
        # Skip mode: halve the group until the bad messages stand alone, so one bad message
        # in a decode job of thousands costs about two fast decodes of the job (halves
        # that decode are kept whole), not one decode per message; a message alone gets
        # both decoders, as it would one by one.
        # (Without a fast decoder: one by one, each message costing only itself.)
        return self._bisect(group, key)

    def _bisect(self, group: list[RawMessage], key: str) -> FrameDetections:
        fast = self.fast
        if len(group) == 1 or fast is None or key == "other":
            parts = []
            for m in group:
                try:
                    parts.append(self._decode_once([m], key))
                except MessageDecodeError as exc:
                    self._remember(exc)
                    parts.append(_skipped(1))
            return FrameDetections.concat(parts)
        mid = len(group) // 2
        parts = []
        for half in (group[:mid], group[mid:]):
            try:
                parts.append(_from_decoded(fast(join_payloads(half, key == "cdr")), half))
            except MessageDecodeError:
                parts.append(self._bisect(half, key))
        return FrameDetections.concat(parts)

    def _remember(self, exc: MessageDecodeError) -> None:
        if self.first_error is None:
            self.first_error = exc

    def _decode_once(self, group: list[RawMessage], key: str) -> FrameDetections:
        if self.fast is not None and key != "other":
            try:
                return _from_decoded(self.fast(join_payloads(group, key == "cdr")), group)
            except MessageDecodeError as fast_error:
                try:
                    return self._generic(group)
                except MessageDecodeError:
                    raise fast_error from None
        return self._generic(group)

    def _generic(self, group: list[RawMessage]) -> FrameDetections:
        big = next((m for m in group if len(m.data) > GENERIC_MAX_PAYLOAD), None)
        if big is not None:
            raise MessageDecodeError(
                f"the {self.msgtype} message on {big.topic!r} at log time {big.log_time_ns} ns "
                f"is {len(big.data):,} bytes, more than the {GENERIC_MAX_PAYLOAD:,} bytes aion "
                "decodes through rosbags",
                hint="the numpy decoders of the common types have no such limit; is the "
                "payload damaged or of another layout?",
            )
        try:
            return self.decode_generic(group)
        except ConfigError as exc:
            if self.strict_fields:
                raise
            raise MessageDecodeError(
                f"cannot read {self.msgtype}: {exc.message}",
                hint="the log's definition of this type differs from the known layouts",
            ) from exc


def _groups(messages: Sequence[RawMessage]) -> dict[str, list[int]]:
    """Message indices by encoding ("cdr", "ros1"; anything else: "other", generic decoder
    only). Big-endian CDR needs no special case: the fast decoder rejects its header and the
    group falls back to rosbags, which reads both byte orders."""
    encodings = set(map(attrgetter("encoding"), messages))
    if len(encodings) == 1:
        (enc,) = encodings
        return {enc if enc in ("cdr", "ros1") else "other": list(range(len(messages)))}
    groups: dict[str, list[int]] = {}
    for i, m in enumerate(messages):
        key = m.encoding if m.encoding in ("cdr", "ros1") else "other"
        groups.setdefault(key, []).append(i)
    return groups


def _skipped(n: int) -> FrameDetections:
    e = FrameDetections.empty(n)
    return FrameDetections(
        e.t_ns, e.xyz, e.velocity, e.yaw, e.track_id, e.frame_id, e.frames, e.msg_index, n, 0,
        {"undecodable": n},
    )


def _with_n_messages(d: FrameDetections, n: int) -> FrameDetections:
    return FrameDetections(
        d.t_ns, d.xyz, d.velocity, d.yaw, d.track_id, d.frame_id, d.frames, d.msg_index, n,
        d.stamp_fallbacks, d.filtered,
    )


def _reindex(d: FrameDetections, idx: np.ndarray) -> FrameDetections:
    return FrameDetections(
        d.t_ns, d.xyz, d.velocity, d.yaw, d.track_id, d.frame_id, d.frames,
        idx[d.msg_index] if len(d) else d.msg_index, d.n_messages, d.stamp_fallbacks,
        d.filtered,
    )


def message_log_times(messages: Sequence[RawMessage]) -> np.ndarray:
    """The log time (ns) of each message, int64."""
    return np.fromiter(map(attrgetter("log_time_ns"), messages), np.int64, len(messages))


def _from_decoded(d: Decoded, messages: Sequence[RawMessage]) -> FrameDetections:
    t, fallbacks = stamps_or_log_time(d.sec, d.nsec, message_log_times(messages)[d.owner])
    # Name table listing only the frames that rows refer to (O(n), no sort).
    order = np.flatnonzero(np.bincount(d.frame_code, minlength=len(d.frame_names)))
    table = FrameTable()
    remap = np.zeros(len(d.frame_names), np.int64)
    remap[order] = table.indices(d.frame_names[c] for c in order.tolist())
    return FrameDetections(
        t, np.ascontiguousarray(d.xyz, np.float64).reshape(-1, 3),
        np.ascontiguousarray(d.velocity, np.float64).reshape(-1, 3),
        np.asarray(d.yaw, np.float64), np.asarray(d.track_id, np.int64),
        remap[d.frame_code],
        tuple(table.names), np.asarray(d.owner, np.int64), len(messages), fallbacks,
        dict(d.filtered),
    )


def _from_rows(rows: Rows, messages: Sequence[RawMessage]) -> FrameDetections:
    n = len(rows.owner)
    if n == 0:
        e = FrameDetections.empty(len(messages))
        return FrameDetections(
            e.t_ns, e.xyz, e.velocity, e.yaw, e.track_id, e.frame_id, e.frames, e.msg_index,
            len(messages), 0, dict(rows.filtered),
        )
    owner = np.asarray(rows.owner, np.int64)
    stamp = np.asarray(rows.stamp, np.int64)
    t, fallbacks = stamps_or_log_time(
        np.zeros(n, np.int64), stamp, message_log_times(messages)[owner]
    )
    table = FrameTable()
    return FrameDetections(
        t, np.asarray(rows.xyz, np.float64).reshape(n, 3),
        np.asarray(rows.vel, np.float64).reshape(n, 3),
        quat_yaw(np.asarray(rows.quat, np.float64).reshape(n, 4)),
        np.asarray(rows.track, np.int64), table.indices(rows.frame), tuple(table.names), owner,
        len(messages), fallbacks, dict(rows.filtered),
    )
