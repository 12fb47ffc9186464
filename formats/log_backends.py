"""The container libraries behind :class:`formats.writers.LogWriter`: one backend per kind of
log (MCAP through the ``mcap`` library, ROS 1 bags and rosbag2 folders through ``rosbags``),
each registering channels, writing serialized messages and metadata, and finishing the file.
SQLite's full-disk error is raised as the ``OSError`` (ENOSPC) the other containers raise.
"""

from __future__ import annotations

import contextlib
import errno
import os
import sqlite3
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any, BinaryIO

from aion_cli.formats import msgdefs
from aion_cli.formats.log_target import AION_CALLERID, AION_ROSBAG2_MARK


class Backend:
    """One container library behind :class:`LogWriter`."""

    def channel(self, topic: str, msgtype: str) -> Any:
        """Register ``topic`` with ``msgtype``; returns the library's connection handle."""
        raise NotImplementedError

    def write(self, channel: Any, t_ns: int, data: bytes | memoryview, sequence: int) -> None:
        """Write one serialized message."""
        raise NotImplementedError

    def close(self) -> None:
        """Finish the file (indexes, summary, metadata)."""
        raise NotImplementedError

    def metadata(self, name: str, data: Mapping[str, str]) -> bool:
        """Store a metadata record; False for a container without such records."""
        return False


class _McapBackend(Backend):
    """Raw MCAP writer with ``ros2msg``/``cdr`` or ``ros1msg``/``ros1`` schemas and channels."""

    def __init__(self, path: Path, ros_version: int, chunk_size: int | None = None) -> None:
        from mcap.writer import CompressionType, Writer

        self.ros_version = ros_version
        self.file: BinaryIO = path.open("wb")
        self.writer = Writer(
            self.file,
            compression=CompressionType.ZSTD,
            chunk_size=1024 * 1024 if chunk_size is None else chunk_size,  # mcap's default
        )
        self.writer.start(profile="ros1" if ros_version == 1 else "ros2", library="aion")
        self.schemas: dict[str, int] = {}

    def channel(self, topic: str, msgtype: str) -> int:
        schema = self.schemas.get(msgtype)
        if schema is None:
            text = msgdefs.definition(msgtype, self.ros_version)
            if self.ros_version == 1:
                name, encoding = msgtype.replace("/msg/", "/"), "ros1msg"
            else:
                name, encoding = msgtype, "ros2msg"
            schema = self.writer.register_schema(name, encoding, text.encode())
            self.schemas[msgtype] = schema
        encoding = "ros1" if self.ros_version == 1 else "cdr"
        return int(self.writer.register_channel(topic, encoding, schema))

    def write(self, channel: Any, t_ns: int, data: bytes | memoryview, sequence: int) -> None:
        self.writer.add_message(channel, t_ns, bytes(data), t_ns, sequence)

    def metadata(self, name: str, data: Mapping[str, str]) -> bool:
        self.writer.add_metadata(name, dict(data))
        return True

    def close(self) -> None:
        try:
            self.writer.finish()
        finally:
            self.file.close()


class _Rosbag1Backend(Backend):
    """``rosbags.rosbag1.Writer``; ``/tf_static`` is written as a latched connection."""

    def __init__(self, path: Path, chunk_size: int | None = None) -> None:
        from rosbags.rosbag1 import Writer

        self.writer = Writer(path)
        if chunk_size is not None:
            self.writer.chunk_threshold = chunk_size
        self.writer.open()

        self._records: list[tuple[Any, bytes]] = []  # written at the first message's time

    def channel(self, topic: str, msgtype: str, latched: bool = False) -> Any:
        latching = 1 if latched or topic.endswith("tf_static") else None
        return self.writer.add_connection(  # the caller id marks the bag as aion's
            topic, msgtype, typestore=msgdefs.typestore(1), latching=latching,
            callerid=AION_CALLERID,
        )

    def write(self, channel: Any, t_ns: int, data: bytes | memoryview, sequence: int) -> None:
        if self._records:  # before the first message, at its time: the bag's span unchanged
            self._write_records(t_ns)
        self.writer.write(channel, t_ns, bytes(data))

    def _write_records(self, t_ns: int) -> None:
        for connection, text in self._records:
            self.writer.write(connection, t_ns, text)
        self._records.clear()

    def metadata(self, name: str, data: Mapping[str, str]) -> bool:
        """A ROS 1 bag has no metadata records: each pair is one latched ``std_msgs/String``
        message on ``/<name>/<key>`` (:func:`formats.log_zone.metadata_topic`)."""
        from aion_cli.formats.log_zone import STRING, metadata_topic, ros1_string

        for key, value in data.items():
            connection = self.channel(metadata_topic(name, key), STRING, latched=True)
            self._records.append((connection, ros1_string(value)))
        return True

    def close(self) -> None:
        self._write_records(0)  # a bag of no other message: they have no time but 0
        self.writer.close()


_SQLITE_FULL = 13
"""SQLite's result code for "database or disk is full" (``sqlite3.OperationalError``)."""


@contextlib.contextmanager
def _full_disk_as_oserror(path: Path) -> Iterator[None]:
    """SQLite reports a full disk (or quota) as ``OperationalError: database or disk is full``:
    raise it as the ``OSError`` (ENOSPC) the other containers raise, which the command line
    reports as the machine's limit (exit 2) and not as a fault of aion."""
    try:
        yield
    except sqlite3.OperationalError as exc:
        full = _as_full_disk(exc, path)
        if full is None:
            raise
        raise full from exc


def _as_full_disk(exc: sqlite3.OperationalError, path: Path) -> OSError | None:
    """The ``OSError`` (ENOSPC) for SQLite's full-disk error; None for any other."""
    code = getattr(exc, "sqlite_errorcode", None)
    if code != _SQLITE_FULL and "database or disk is full" not in str(exc):
        return None
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


class _Rosbag2Backend(Backend):
    """``rosbags.rosbag2.Writer`` (bag version 9) with sqlite3 or mcap storage."""

    def __init__(self, path: Path, storage: str) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self.path = path
        self.writer = Writer(path, version=9, storage_plugin=plugin)
        self.writer.set_custom_data(*AION_ROSBAG2_MARK)  # marks the folder as aion's
        with _full_disk_as_oserror(path):
            self.writer.open()

    def channel(self, topic: str, msgtype: str) -> Any:
        with _full_disk_as_oserror(self.path):
            return self.writer.add_connection(topic, msgtype, typestore=msgdefs.typestore(2))

    def write(self, channel: Any, t_ns: int, data: bytes | memoryview, sequence: int) -> None:
        try:  # per message: a try costs nothing, a context manager a generator each time
            self.writer.write(channel, t_ns, data)
        except sqlite3.OperationalError as exc:
            full = _as_full_disk(exc, self.path)
            if full is None:
                raise
            raise full from exc

    def metadata(self, name: str, data: Mapping[str, str]) -> bool:
        """Each pair as ``custom_data`` of metadata.yaml, its key ``<name>.<key>``."""
        for key, value in data.items():
            self.writer.set_custom_data(f"{name}.{key}", value)
        return True

    def close(self) -> None:
        with _full_disk_as_oserror(self.path):
            self.writer.close()


def open_backend(path: Path, container: str, ros_version: int, chunk_size: int | None) -> Backend:
    """The backend writing ``container`` (one of :data:`formats.writers.CONTAINERS`) at ``path``."""
    if container in ("mcap", "mcap-ros1"):
        return _McapBackend(path, ros_version, chunk_size)
    if container == "bag":
        return _Rosbag1Backend(path, chunk_size)
    return _Rosbag2Backend(path, container.removeprefix("rosbag2-"))
