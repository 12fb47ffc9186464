"""Raw log records shared by the log readers and the message adapters, and the check every
input path goes through before anything reads it (:func:`check_regular_input`)."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from operator import attrgetter
from pathlib import Path
from typing import ClassVar, Literal

import numpy as np
import numpy.typing as npt

from aion_cli.errors import InputError, LogFormatError

Encoding = Literal["cdr", "ros1"]
Payload = bytes | memoryview
"""A message's payload: ``bytes``, or a read-only view of a reader's decompressed chunk where
the caller asked for views (:attr:`UnreadHint.views`)."""


def normalize_msgtype(msgtype: str) -> str:
    """``pkg/msg/Type`` for every spelling (``pkg/Type``, ``pkg/msg/Type``)."""
    parts = msgtype.strip().strip("/").split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return "/".join(parts)


def normalize_frame(frame_id: str) -> str:
    """Frame ids without the leading slash ROS 1 tools sometimes add (and surrounding
    whitespace): the one spelling TF, the detections' frames and ``--map-frame`` compare."""
    return frame_id.strip().lstrip("/")


def topic_spelling_hint(name: str, topics: Iterable[str]) -> str | None:
    """What a hint says when ``name`` is not a topic of the log but one of ``topics`` is the
    same name with (or without) a leading slash: rosbag2 and ROS 1 record ``/my/topic``, and
    a ROS 2 user may well type ``my/topic``. None when no topic is spelled so."""
    bare = name.strip().strip("/")
    for topic in topics:
        if topic != name and topic.strip("/") == bare:
            slash = "with" if topic.startswith("/") else "without"
            return f"the log calls it {topic} ({slash} a leading '/')"
    return None


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a log: normalised type, message count, wire encoding, definition text."""

    topic: str
    msgtype: str
    count: int
    encoding: Encoding
    definition: str = ""
    source: str = ""


@dataclass(frozen=True)
class RawMessage:
    """One serialized message. ``data`` is the wire payload: CDR with its 4-byte encapsulation
    header for ROS 2, plain ROS 1 serialization for ROS 1; ``bytes``, or a read-only
    ``memoryview`` only on the topics of an :class:`UnreadHint` that asked for views.

    ``recording``: which recording of a :class:`~formats.logs.LogSet` the message came from
    (the position of the path it was opened from; the storage files of one rosbag2 bag share
    it), set by the merge of several logs (:func:`from_recording`); 0 in a set of one log.
    Not a field: equality, hashing and ``repr`` stay those of the five fields."""

    topic: str
    msgtype: str
    log_time_ns: int
    data: Payload
    encoding: Encoding
    recording: ClassVar[int] = 0


_new_object = object.__new__


def raw_message(
    topic: str, msgtype: str, log_time_ns: int, data: Payload, encoding: Encoding
) -> RawMessage:
    """``RawMessage(topic, msgtype, log_time_ns, data, encoding)``, the same instance (equal,
    same hash and repr), made without the frozen dataclass's ``__init__``, which sets each
    of the five fields through ``object.__setattr__``: the fields go straight into the new
    instance's ``__dict__`` (a frozen dataclass refuses attribute assignment, not its
    ``__dict__``). For readers' per-message loops (issue 15: about a third of the time of
    ``RawMessage(...)``, ~1 µs less per message of a build)."""
    msg: RawMessage = _new_object(RawMessage)
    fields = msg.__dict__
    fields["topic"] = topic
    fields["msgtype"] = msgtype
    fields["log_time_ns"] = log_time_ns
    fields["data"] = data
    fields["encoding"] = encoding
    return msg


def from_recording(msg: RawMessage, recording: int) -> RawMessage:
    """``msg`` marked as a message of ``recording`` (:attr:`RawMessage.recording`), in place:
    the merge of several logs marks each message as it yields it (a dict write, as
    :func:`raw_message` makes them), so that a build can tell whose ``/tf`` a detection
    should be resolved with (:mod:`aion_cli.tf_trees`)."""
    msg.__dict__["recording"] = recording
    return msg


def recordings_of(messages: Sequence[RawMessage]) -> npt.NDArray[np.int64]:
    """Per message of ``messages``, the recording it came from (:attr:`RawMessage.recording`;
    0 outside a merge of several logs), read in one C-level pass, no Python loop per message
    (:mod:`aion_cli.tf_trees`, :mod:`aion_cli.track_owners`, :mod:`aion_cli.tf_feed`)."""
    return np.fromiter(map(_RECORDING, messages), np.int64, len(messages))


_RECORDING = attrgetter("recording")


class Unread(bytes):
    """The payload of a message a reader yielded without reading it (:data:`UNREAD`)."""


UNREAD = Unread()
"""``RawMessage.data`` of a message an :class:`UnreadHint` said the caller drops unread: a
reader may yield it with this instead of its bytes (and so skip decompressing them). Test
with ``isinstance(data, Unread)``: it equals ``b""``."""


@dataclass(frozen=True)
class UnreadHint:
    """Messages the caller will drop without looking at their payloads: those on ``topics``
    logged at one of ``times`` (sorted, unique, log time ns). A reader may yield them with
    :data:`UNREAD` as their data, in their place in the stream, where that saves reading
    them (an MCAP chunk's tail, :mod:`formats.mcap_partial`); it may also yield them read.

    ``views``: the caller also takes the payloads it gets on ``topics`` as read-only
    ``memoryview`` s (it neither changes them nor needs ``bytes`` methods). A reader may then
    give a large payload as a view of the chunk it decompressed instead of a copy
    (:func:`formats.mcap_records.chunk_messages`: one at least half of its chunk, so a view
    keeps at most twice its own bytes alive; the chunk is a fresh ``bytes`` per read, never
    reused, so the view stays valid as long as the caller keeps it)."""

    topics: frozenset[str]
    times: npt.NDArray[np.int64]
    views: bool = False


_SPECIAL_INPUTS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def check_regular_input(
    path: Path | str,
    what: str = "log",
    error: type[InputError] = LogFormatError,
    hint: str | None = None,
) -> None:
    """Refuse an input that is not a regular file or a folder (a FIFO, a character or block
    device such as ``/dev/zero``, a socket) before anything opens it: reading one can block
    forever (a FIFO without a writer) or never end (``/dev/zero``, ``/dev/urandom``).

    ``what`` names the input in the message (``"log"``, ``"map"``), ``error`` is the
    :class:`InputError` subclass raised (exit code 2). Only ``os.stat`` is called (it follows
    symbolic links and never opens the file); a path that does not exist passes (the caller
    says so in its own words). Call it before hashing, sniffing or reading any input.
    """
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return
    kind = next((name for test, name in _SPECIAL_INPUTS if test(mode)), "not a regular file")
    raise error(
        f"{path} is {kind}, not a regular file: aion does not read a {what} from it",
        hint=hint or f"pass the {what} file itself (a FIFO or device gives no file to read)",
    )
