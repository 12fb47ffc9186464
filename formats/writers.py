"""Write ROS logs without ROS: MCAP (ROS 2 or ROS 1 profile), ROS 1 bags and rosbag2 folders.

Tests and the simulator describe messages as plain nested dicts in ROS 2 field naming
(``header.stamp.sec`` / ``nanosec``; arrays as lists or numpy arrays; ``uint8[]`` as bytes).
:class:`LogWriter` converts them into rosbags message objects with a converter generated once per
type from the typestore's field definitions (missing fields become zero values), serializes them
with the typestore of :mod:`formats.msgdefs` (CDR for ROS 2 containers, ROS 1 serialization for
ROS 1 containers) and writes them with the container's own library. Connections, schemas and
converters are cached, so writing 10^5 small messages takes seconds.
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Callable, Mapping
from functools import cache
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, BinaryIO, Literal, get_args

import numpy as np

from aion_cli.errors import InputError, LogFormatError
from aion_cli.formats import msgdefs
from aion_cli.formats.outputs import (
    OutputPathError,
    Staged,
    check_output,
    file_starts_with,
    folder_entries,
)
from aion_cli.formats.raw import normalize_msgtype

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

Container = Literal["mcap", "mcap-ros1", "bag", "rosbag2-sqlite3", "rosbag2-mcap"]
CONTAINERS: tuple[str, ...] = get_args(Container)

_ROS1_CONTAINERS = frozenset({"mcap-ros1", "bag"})

# rosbags field-definition node types (rosbags.typesys.base.Nodetype).
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4

_DTYPES: dict[str, type[np.generic]] = {
    "bool": np.bool_,
    "byte": np.uint8,
    "char": np.uint8,
    "int8": np.int8,
    "uint8": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
}

Converter = Callable[[Any], Any]


class LogWriteError(LogFormatError):
    """A log cannot be created (existing path, unknown container)."""


class MessageEncodeError(InputError):
    """A message dict does not fit its type (unknown field, wrong value type)."""


class LogTargetError(LogWriteError, OutputPathError):
    """The output path is refused: special file, current folder, exists, or not aion's log."""


class LogTimeError(LogWriteError):
    """A message's log time is outside what log containers store (0 .. 2^63 - 1 ns)."""


MAX_LOG_TIME_NS = 2**63 - 1
"""The latest log time a container stores (int64 nanoseconds: 2262-04-11)."""

MCAP_MAGIC = b"\x89MCAP0\r\n"
BAG_MAGIC = b"#ROSBAG V2.0\n"
_MAX_METADATA_BYTES = 16 * 1024**2


def is_own_log(path: Path, container: str) -> bool:
    """True when ``path`` is a log of ``container``'s kind that ``--force`` may replace: an MCAP
    file (magic bytes) for ``mcap`` / ``mcap-ros1``, a ROS 1 bag (its version line) for
    ``bag``, and for the rosbag2 containers a folder holding only ``metadata.yaml`` and the
    storage files it names (no other file, no subfolder), as :class:`LogWriter` writes it."""
    if container in ("mcap", "mcap-ros1"):
        return file_starts_with(path, MCAP_MAGIC)
    if container == "bag":
        return file_starts_with(path, BAG_MAGIC)
    return is_own_rosbag2(path)


def is_own_rosbag2(path: Path) -> bool:
    """A rosbag2 folder of ``metadata.yaml`` plus exactly the storage files it names (see
    :func:`is_own_log`); anything else in it (a CSV, a subfolder, a symlink) says no."""
    names = folder_entries(path)
    if names is None or "metadata.yaml" not in names:
        return False
    meta = path / "metadata.yaml"
    try:
        st = os.lstat(meta)
        if not stat.S_ISREG(st.st_mode) or st.st_size > _MAX_METADATA_BYTES:
            return False
        from ruamel.yaml import YAML  # rosbags' own YAML library

        doc = YAML(typ="safe").load(meta.read_text(encoding="utf-8"))
        files = doc["rosbag2_bagfile_information"]["relative_file_paths"]
    except Exception:  # unreadable, not YAML, not rosbag2 metadata: not ours
        return False
    if not isinstance(files, list) or not all(isinstance(f, str) and f for f in files):
        return False
    allowed = {"metadata.yaml", *files}
    if any("/" in f or f in (".", "..") for f in files) or set(names) - allowed:
        return False
    for name in names:
        try:
            if not stat.S_ISREG(os.lstat(path / name).st_mode):
                return False
        except OSError:
            return False
    return True


def _log_kind(container: str) -> str:
    if container in ("mcap", "mcap-ros1"):
        return "an MCAP log"
    if container == "bag":
        return "a ROS 1 bag"
    return "a rosbag2 folder"


def check_log_target(path: str | os.PathLike[str], container: str, *, overwrite: bool) -> bool:
    """Refuse an output path before anything is written (see :mod:`formats.outputs`): a device,
    FIFO or socket, the current folder, an existing path without ``overwrite``, or an existing
    path that is not a log of ``container``'s kind (:func:`is_own_log`). Returns whether an
    existing log will be replaced. Raises :class:`LogTargetError` (exit 2)."""
    try:
        return check_output(
            path,
            overwrite=overwrite,
            recognise=lambda p: is_own_log(p, container),
            what=_log_kind(container),
            folder=container.startswith("rosbag2"),
        )
    except OutputPathError as exc:
        raise LogTargetError(exc.message, exc.hint) from None


# --- dict -> rosbags message conversion -----------------------------------------------------


def _scalar_converter(basetype: str) -> tuple[Converter, Any]:
    """Converter and zero value of one primitive field."""
    if basetype.startswith("string"):
        return (lambda v: "" if v is None else str(v)), ""
    if basetype == "bool":
        return (lambda v: False if v is None else bool(v)), False
    if basetype.startswith("float"):
        return (lambda v: 0.0 if v is None else float(v)), 0.0
    return (lambda v: 0 if v is None else int(v)), 0


def _primitive_array_converter(basetype: str, length: int) -> Converter:
    """Converter of a numeric array (fixed ``length`` > 0) or sequence (``length`` 0)."""
    dtype = np.dtype(_DTYPES[basetype])
    empty = np.zeros(length, dtype=dtype)

    def convert(value: Any) -> Any:
        if value is None:
            return empty
        if isinstance(value, bytes | bytearray | memoryview):
            arr = np.frombuffer(value, dtype=np.uint8).view(dtype)
        else:
            arr = np.asarray(value, dtype=dtype)
        if arr.ndim != 1 or (length and arr.shape[0] != length):
            want = f"{length} values" if length else "a 1-D sequence"
            raise ValueError(f"expected {want} of {basetype}, got shape {arr.shape}")
        return arr

    return convert


class _Converters:
    """Per-typestore cache of dict -> message converters, built from the field definitions."""

    def __init__(self, store: Typestore) -> None:
        self.store = store
        self.cache: dict[str, Converter] = {}

    def get(self, msgtype: str) -> Converter:
        """The converter of ``msgtype`` (normalised name), building it on first use."""
        conv = self.cache.get(msgtype)
        if conv is None:
            conv = self._build(msgtype)
            self.cache[msgtype] = conv
        return conv

    def _field(self, desc: tuple[int, Any]) -> Converter:
        nodetype, args = desc
        if nodetype == _BASE:
            return _scalar_converter(args[0])[0]
        if nodetype == _NAME:
            return self.get(args)
        (subtype, subargs), length = args
        fixed = length if nodetype == _ARRAY else 0
        if subtype == _BASE and subargs[0] in _DTYPES:
            return _primitive_array_converter(subargs[0], fixed)
        item = _scalar_converter(subargs[0])[0] if subtype == _BASE else self.get(subargs)

        def convert_list(value: Any) -> list[Any]:
            if value is None:
                return [item(None) for _ in range(fixed)]
            out = [item(v) for v in value]
            if fixed and len(out) != fixed:
                raise ValueError(f"expected {fixed} items, got {len(out)}")
            return out

        return convert_list

    def _build(self, msgtype: str) -> Converter:
        if msgtype not in self.store.fielddefs:
            raise msgdefs.UnknownMessageTypeError(
                f"unknown message type {msgtype!r}",
                hint="see formats.msgdefs.SUPPORTED_MSGTYPES for the shipped definitions",
            )
        cls = self.store.types[msgtype]
        fielddefs: list[tuple[str, Any]] = list(self.store.fielddefs[msgtype][1])
        fields = [(name, self._field(desc)) for name, desc in fielddefs]
        names = frozenset(name for name, _ in fields)
        default: list[Any] = []

        def make_default() -> Any:
            if not default:
                default.append(cls(*[c(None) for _, c in fields]))
            return default[0]

        def slow(value: Any) -> Any:
            if isinstance(value, cls):
                return value
            if isinstance(value, Mapping):
                return convert(dict(value))
            raise TypeError(f"{msgtype}: expected a dict, got {type(value).__name__}")

        def unknown(value: dict[str, Any]) -> None:
            extra = sorted(set(value) - names)
            raise KeyError(f"{msgtype} has no field(s) {extra}; fields: {sorted(names)}")

        # One generated function per type: scalar conversions inline, one call per nested
        # field. About twice as fast as looping over per-field closures.
        namespace: dict[str, Any] = {
            "cls": cls,
            "names": names,
            "make_default": make_default,
            "slow": slow,
            "unknown": unknown,
        }
        args = []
        for i, ((name, desc), (_, conv)) in enumerate(zip(fielddefs, fields, strict=True)):
            if desc[0] == _BASE and not desc[1][0].startswith("string"):
                zero, cast = _scalar_source(desc[1][0])
                args.append(f"{zero} if (v := get({name!r})) is None else {cast}(v)")
            else:
                namespace[f"c{i}"] = conv
                args.append(f"c{i}(get({name!r}))")
        source = (
            "def convert(value):\n"
            "    if value is None:\n"
            "        return make_default()\n"
            "    if value.__class__ is not dict:\n"
            "        return slow(value)\n"
            "    if not names.issuperset(value):\n"
            "        unknown(value)\n"
            "    get = value.get\n"
            f"    return cls({', '.join(args)})\n"
        )
        exec(compile(source, f"<aion converter {msgtype}>", "exec"), namespace)
        convert: Converter = namespace["convert"]
        return convert


def _scalar_source(basetype: str) -> tuple[str, str]:
    """Zero literal and cast function name of a numeric or bool field, for generated code."""
    if basetype == "bool":
        return "False", "bool"
    if basetype.startswith("float"):
        return "0.0", "float"
    return "0", "int"


@cache
def _converters_for(ros_version: int) -> _Converters:
    return _Converters(msgdefs.typestore(1 if ros_version == 1 else 2))


def to_message(msgtype: str, message: Mapping[str, Any] | Any, ros_version: int = 2) -> Any:
    """The rosbags message object of the ROS ``ros_version`` typestore for ``message`` (a nested
    dict in ROS 2 naming; missing fields become zero values; message objects pass through)."""
    msgtype = normalize_msgtype(msgtype)
    try:
        return _converters_for(ros_version).get(msgtype)(message)
    except (TypeError, ValueError, KeyError, OverflowError) as exc:
        raise MessageEncodeError(
            f"cannot encode a {msgtype} message: {exc}",
            hint="give fields in ROS 2 naming (header.stamp.sec/nanosec); omit fields to zero",
        ) from exc


# --- containers -----------------------------------------------------------------------------


class _Backend:
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


class _McapBackend(_Backend):
    """Raw MCAP writer with ``ros2msg``/``cdr`` or ``ros1msg``/``ros1`` schemas and channels."""

    def __init__(self, path: Path, ros_version: int) -> None:
        from mcap.writer import CompressionType, Writer

        self.ros_version = ros_version
        self.file: BinaryIO = path.open("wb")
        self.writer = Writer(self.file, compression=CompressionType.ZSTD)
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

    def close(self) -> None:
        try:
            self.writer.finish()
        finally:
            self.file.close()


class _Rosbag1Backend(_Backend):
    """``rosbags.rosbag1.Writer``; ``/tf_static`` is written as a latched connection."""

    def __init__(self, path: Path) -> None:
        from rosbags.rosbag1 import Writer

        self.writer = Writer(path)
        self.writer.open()

    def channel(self, topic: str, msgtype: str) -> Any:
        latching = 1 if topic.endswith("tf_static") else None
        return self.writer.add_connection(
            topic, msgtype, typestore=msgdefs.typestore(1), latching=latching
        )

    def write(self, channel: Any, t_ns: int, data: bytes | memoryview, sequence: int) -> None:
        self.writer.write(channel, t_ns, bytes(data))

    def close(self) -> None:
        self.writer.close()


class _Rosbag2Backend(_Backend):
    """``rosbags.rosbag2.Writer`` (bag version 9) with sqlite3 or mcap storage."""

    def __init__(self, path: Path, storage: str) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self.writer = Writer(path, version=9, storage_plugin=plugin)
        self.writer.open()

    def channel(self, topic: str, msgtype: str) -> Any:
        return self.writer.add_connection(topic, msgtype, typestore=msgdefs.typestore(2))

    def write(self, channel: Any, t_ns: int, data: bytes | memoryview, sequence: int) -> None:
        self.writer.write(channel, t_ns, data)

    def close(self) -> None:
        self.writer.close()


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
    folder holding other files, never a device, FIFO or socket). Log times must lie in
    ``0 .. 2^63 - 1`` ns (:class:`LogTimeError` otherwise).
    """

    def __init__(self, path: Path | str, container: str = "mcap", *, overwrite: bool = False):
        if container not in CONTAINERS:
            raise LogWriteError(
                f"unknown log container {container!r}", hint=f"use one of {', '.join(CONTAINERS)}"
            )
        self.path = Path(path)
        self.container = container
        self.overwrite = overwrite
        self.ros_version = 1 if container in _ROS1_CONTAINERS else 2
        self.encoding = "ros1" if self.ros_version == 1 else "cdr"
        check_log_target(self.path, container, overwrite=overwrite)  # before anything is written
        self._store = msgdefs.typestore(self.ros_version)
        self._serialize = (
            self._store.serialize_ros1 if self.ros_version == 1 else self._store.serialize_cdr
        )
        self._channels: dict[tuple[str, str], _Channel] = {}
        self._staged = Staged(self.path)
        try:
            self._backend: _Backend | None = self._open(self._staged.path)
        except BaseException:
            self._staged.discard()
            raise
        self.count = 0

    def _open(self, path: Path) -> _Backend:
        if self.container in ("mcap", "mcap-ros1"):
            return _McapBackend(path, self.ros_version)
        if self.container == "bag":
            return _Rosbag1Backend(path)
        return _Rosbag2Backend(path, self.container.removeprefix("rosbag2-"))

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
            backend.close()
            check_log_target(self.path, self.container, overwrite=self.overwrite)  # unchanged?
        except BaseException:
            self._staged.discard()
            raise
        self._staged.commit()

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


def stamp(t_ns: int) -> dict[str, int]:
    """``{"sec", "nanosec"}`` of a nanosecond time, for message headers."""
    sec, nanosec = divmod(int(t_ns), 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}
