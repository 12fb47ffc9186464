"""Write ROS logs without ROS: MCAP (ROS 2 or ROS 1 profile), ROS 1 bags and rosbag2 folders.

Tests and the simulator describe messages as plain nested dicts in ROS 2 field naming
(``header.stamp.sec`` / ``nanosec``; arrays as lists or numpy arrays; ``uint8[]`` as bytes).
:class:`LogWriter` converts them into rosbags message objects with a converter generated once per
type from the typestore's field definitions (missing fields become zero values), serializes them
with the typestore of :mod:`formats.msgdefs` (CDR for ROS 2 containers, ROS 1 serialization for
ROS 1 containers) and writes them with the container's own library. Connections, schemas and
converters are cached, so writing 10^5 small messages takes seconds.

Converting dicts lives in :mod:`formats.message_convert` (:func:`to_message`, :func:`stamp`),
output-path checks in :mod:`formats.log_target` (:func:`check_log_target`,
:func:`is_own_log`); both are re-exported here. The container libraries behind the writer
are in :mod:`formats.log_backends`.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import Any, Literal, get_args

from aion_cli.formats import msgdefs
from aion_cli.formats.log_backends import Backend, open_backend
from aion_cli.formats.log_target import (
    BAG_MAGIC,
    MCAP_MAGIC,
    LogTargetError,
    LogWriteError,
    check_log_target,
    is_own_log,
    is_own_rosbag2,
)
from aion_cli.formats.message_convert import (
    Converter,
    MessageEncodeError,
    _converters_for,
    stamp,
    to_message,
)
from aion_cli.formats.output_lock import output_lock
from aion_cli.formats.outputs import Staged
from aion_cli.formats.raw import normalize_msgtype

Container = Literal["mcap", "mcap-ros1", "bag", "rosbag2-sqlite3", "rosbag2-mcap"]
CONTAINERS: tuple[str, ...] = get_args(Container)

_ROS1_CONTAINERS = frozenset({"mcap-ros1", "bag"})


class LogTimeError(LogWriteError):
    """A message's log time is outside what log containers store (0 .. 2^63 - 1 ns)."""


MAX_LOG_TIME_NS = 2**63 - 1
"""The latest log time a container stores (int64 nanoseconds: 2262-04-11)."""


def max_stamp_ns(container: str) -> int:
    """The latest header stamp the messages of ``container`` hold: ROS 1 ``time`` counts
    seconds in an unsigned 32-bit number (to 2106-02-07), ROS 2 ``builtin_interfaces/Time``
    in a signed one (to 2038-01-19). Messages serialized through rosbags hold the same
    (:func:`formats.msgdefs.base_typestore` gives ROS 1's Time unsigned seconds)."""
    seconds = 2**32 - 1 if container in _ROS1_CONTAINERS else 2**31 - 1
    return seconds * 1_000_000_000 + 999_999_999


def check_stamps(last_ns: int, container: str, what: str) -> None:
    """:class:`LogTimeError` when ``last_ns``, the latest time ``what`` would be stamped
    with, lies beyond what ``container``'s messages hold (:func:`max_stamp_ns`)."""
    limit = max_stamp_ns(container)
    if int(last_ns) > limit:
        from aion_cli.engine.time_text import utc_text

        day = utc_text(limit)
        ros = "ROS 1" if container in _ROS1_CONTAINERS else "ROS 2"
        raise LogTimeError(
            f"{what} reach beyond {day}, the latest header stamp a {ros} message holds "
            f"(container {container})",
            hint="shift the times earlier (--start)"
            if ros == "ROS 1"
            else "write a ROS 1 log (stamps to 2106: a .bag, or an mcap-ros1 container), or "
            "shift the times earlier (--start)",
        )



class _Channel:
    """A written topic: the container's handle, normalised type, converter, next sequence."""

    __slots__ = ("convert", "handle", "msgtype", "seq")

    def __init__(self, handle: Any, msgtype: str, convert: Converter) -> None:
        self.handle = handle
        self.msgtype = msgtype
        self.convert = convert
        self.seq = 0


class LogWriter:
    """Writes one log file (or rosbag2 folder) in ``container`` format; use as a context manager.

    ``container``: ``"mcap"`` (ROS 2 profile, CDR), ``"mcap-ros1"`` (ROS 1 profile),
    ``"bag"`` (ROS 1 bag), ``"rosbag2-sqlite3"`` or ``"rosbag2-mcap"`` (rosbag2 folder).

    The log is written beside ``path`` (a hidden ``.<name>.*.tmp`` folder) and renamed into
    place by :meth:`close`, so it appears complete or not at all: an exception inside the
    ``with`` block (or :meth:`abort`) throws the partial log away and leaves whatever was at
    ``path`` untouched. An existing ``path`` is an error unless ``overwrite`` is set, and even
    then only a log of this container's kind is replaced (:func:`check_log_target`: never a
    folder holding other files, never a device, FIFO or socket). The writer holds the
    output's lock (:func:`formats.output_lock.output_lock`) until the log is closed or
    aborted, so a second writer of the same path is refused at once; ``lock=False``: the
    caller holds it (``simulate`` holds it across the log and its ground truth). Log times
    must lie in ``0 .. 2^63 - 1`` ns (:class:`LogTimeError` otherwise). ``chunk_size``:
    bytes of records per chunk of an MCAP file or ROS 1 bag (the libraries' default, 1 MiB,
    when None; tests use small ones for many chunks).
    """

    def __init__(
        self,
        path: Path | str,
        container: str = "mcap",
        *,
        overwrite: bool = False,
        chunk_size: int | None = None,
        lock: bool = True,
    ):
        if container not in CONTAINERS:
            raise LogWriteError(
                f"unknown log container {container!r}", hint=f"use one of {', '.join(CONTAINERS)}"
            )
        self.path = Path(path)
        self.container = container
        self.overwrite = overwrite
        self.ros_version = 1 if container in _ROS1_CONTAINERS else 2
        self.chunk_size = chunk_size
        self.encoding = "ros1" if self.ros_version == 1 else "cdr"
        check_log_target(self.path, container, overwrite=overwrite)  # before anything is written
        self._lock = contextlib.ExitStack()  # released when the log is closed or aborted
        if lock:
            self._lock.enter_context(output_lock(self.path))
        try:
            self._store = msgdefs.typestore(self.ros_version)
            self._serialize = (
                self._store.serialize_ros1 if self.ros_version == 1 else self._store.serialize_cdr
            )
            self._channels: dict[tuple[str, str], _Channel] = {}
            self._staged = Staged(self.path)
            try:
                self._backend: Backend | None = open_backend(
                    self._staged.path, self.container, self.ros_version, self.chunk_size
                )
            except BaseException:
                self._staged.discard()
                raise
        except BaseException:
            self._lock.close()
            raise
        self.count = 0

    def _channel(self, topic: str, msgtype: str) -> _Channel:
        """The cached channel of ``(topic, msgtype)`` as the caller spells the type."""
        entry = self._channels.get((topic, msgtype))
        if entry is None:
            if self._backend is None:
                raise LogWriteError(f"{self.path} is closed", hint="write inside the with block")
            name = normalize_msgtype(msgtype)
            entry = self._channels.get((topic, name))  # same type, other spelling
            if entry is None:
                convert = _converters_for(self.ros_version).get(name)  # UnknownMessageTypeError
                entry = _Channel(self._backend.channel(topic, name), name, convert)
                self._channels[topic, name] = entry
            self._channels[topic, msgtype] = entry
        return entry

    def message(self, msgtype: str, message: Mapping[str, Any] | Any) -> Any:
        """The rosbags message object for ``message`` (a dict, or already a message object)."""
        return to_message(msgtype, message, self.ros_version)

    def write(self, topic: str, msgtype: str, message: Mapping[str, Any] | Any, t_ns: int) -> None:
        """Write ``message`` (nested dict in ROS 2 naming, or a rosbags message object) on
        ``topic`` at log time ``t_ns``. ROS 1 containers number the headers (``seq``) per topic
        unless the dict gives one."""
        entry = self._channel(topic, msgtype)
        seq = entry.seq
        if self.ros_version == 1 and isinstance(message, Mapping):
            header = message.get("header")
            if isinstance(header, Mapping) and "seq" not in header:
                message = {**message, "header": {**header, "seq": seq}}
        try:
            obj = entry.convert(message)
        except (TypeError, ValueError, KeyError, OverflowError) as exc:
            raise MessageEncodeError(
                f"cannot encode a {entry.msgtype} message: {exc}",
                hint="give fields in ROS 2 naming (header.stamp.sec/nanosec); omit fields to zero",
            ) from exc
        data = self._serialize(obj, entry.msgtype)
        self._write(entry, t_ns, data)

    def add_metadata(self, name: str, data: Mapping[str, str]) -> bool:
        """Store ``data`` as the log's metadata ``name`` (see
        :func:`formats.log_zone.declared_zones`): an MCAP file's metadata record, a rosbag2
        folder's ``custom_data`` ``<name>.<key>``, a ROS 1 bag's latched ``std_msgs/String``
        topics ``/<name>/<key>`` (one message each, at the first message's time: call it
        before the first :meth:`write`). False for a container that stores nothing."""
        if self._backend is None:
            raise LogWriteError(f"{self.path} is closed", hint="write inside the with block")
        return self._backend.metadata(name, data)

    def write_raw(self, topic: str, msgtype: str, data: bytes | memoryview, t_ns: int) -> None:
        """Write an already serialized payload (CDR for ROS 2 containers, ROS 1 serialization for
        ``mcap-ros1`` and ``bag``) on ``topic`` at log time ``t_ns``."""
        self._write(self._channel(topic, msgtype), t_ns, data)

    def _write(self, entry: _Channel, t_ns: int, data: bytes | memoryview) -> None:
        if self._backend is None:
            raise LogWriteError(f"{self.path} is closed", hint="write inside the with block")
        t = int(t_ns)
        if not 0 <= t <= MAX_LOG_TIME_NS:
            raise LogTimeError(
                f"cannot write a message on {self._topic(entry)} at log time "
                f"{t} ns: log times are nanoseconds since 1970 in 0..{MAX_LOG_TIME_NS} "
                "(1970-01-01 to 2262-04-11)",
                hint="the input has times before 1970 or beyond 2262; shift or fix them",
            )
        self._backend.write(entry.handle, t, data, entry.seq)
        entry.seq += 1
        self.count += 1

    def serialize(self, msgtype: str, message: Mapping[str, Any] | Any) -> bytes:
        """The wire bytes ``write`` would store for ``message`` (container encoding)."""
        msgtype = normalize_msgtype(msgtype)
        return bytes(self._serialize(self.message(msgtype, message), msgtype))

    def _topic(self, entry: _Channel) -> str:
        """The topic a channel was registered for (for messages)."""
        return next((topic for (topic, _), e in self._channels.items() if e is entry), "?")

    def close(self) -> None:
        """Finish the log and move it into place (replacing the old one when ``overwrite``
        allowed it); further writes raise :class:`LogWriteError`. Idempotent. If finishing
        fails, nothing is left at the target but what was there before."""
        backend, self._backend = self._backend, None
        if backend is None:
            return
        try:
            try:
                backend.close()
                check_log_target(self.path, self.container, overwrite=self.overwrite)  # unchanged?
            except BaseException:
                self._staged.discard()
                raise
            self._staged.commit()
        finally:
            self._lock.close()

    def abort(self) -> None:
        """Stop writing and throw the partial log away: the target stays as it was (a previous
        log included). Idempotent; ``close`` after ``abort`` does nothing."""
        backend, self._backend = self._backend, None
        try:
            if backend is not None:
                with contextlib.suppress(Exception):
                    backend.close()
        finally:
            self._staged.discard()
            self._lock.close()

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()  # an exception mid-write never leaves a partial log



__all__ = [
    "BAG_MAGIC",
    "CONTAINERS",
    "MAX_LOG_TIME_NS",
    "MCAP_MAGIC",
    "Container",
    "LogTargetError",
    "LogTimeError",
    "LogWriteError",
    "LogWriter",
    "MessageEncodeError",
    "check_log_target",
    "is_own_log",
    "is_own_rosbag2",
    "stamp",
    "to_message",
]
