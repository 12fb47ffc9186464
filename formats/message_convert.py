"""Plain message dicts (ROS 2 field naming) -> rosbags message objects: a converter generated
once per type from the typestore's field definitions (missing fields become zero values),
cached per ROS version (:func:`to_message`); :func:`stamp` gives a header stamp dict.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.errors import InputError
from aion_cli.formats import msgdefs
from aion_cli.formats.raw import normalize_msgtype

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

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


class MessageEncodeError(InputError):
    """A message dict does not fit its type (unknown field, wrong value type)."""


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


def stamp(t_ns: int) -> dict[str, int]:
    """``{"sec", "nanosec"}`` of a nanosecond time, for message headers."""
    sec, nanosec = divmod(int(t_ns), 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}
