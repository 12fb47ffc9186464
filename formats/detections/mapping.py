"""A small TOML mapping that lets aion read people from any other message type.

Example (one ``[[topic]]`` table per topic)::

    [[topic]]
    topic = "/tracker/people"
    msgtype = "my_tracker/msg/Tracks"       # pkg/Type or pkg/msg/Type
    array = "tracks"                        # the sequence of people; omit: one per message
    position = "pose.pose.position"         # Point-like, or 3 numbers: "position[0..2]"
                                            # planar: "pose2d" (x, y), ["x", "y"] or 2 numbers
    velocity = "twist.twist.linear"         # optional; or a number per axis: ["vx", "vy"]
    orientation = "pose.pose.orientation"   # optional (x, y, z, w)
    id = "track_id"                         # optional: integer, string or UUID bytes
    stamp = "header.stamp"                  # default, relative to the message; "" = log time
    frame = "header.frame_id"               # default, relative to the message; "" = none
    item_header = "header"                  # optional per-item header (overrides when set)
    # item_stamp = "t"                      # or a per-item stamp / frame alone (no header)
    # item_frame = "frame"
    frame_override = "map"                  # optional: ignore the message's frame
    filter = { field = "label", equals = ["person", "pedestrian"] }   # optional, per item
    # yaw = "theta"                         # instead of orientation: radians about z

A planar tracker (turtlesim's ``x, y, theta``, ``geometry_msgs/Pose2D``) maps with
``position = ["x", "y"]`` (a path per coordinate, each a number; a third is z) or a path to a
message with ``x`` and ``y``, and ``yaw = "theta"``: z is 0 and the yaw is the pose's
orientation about z.

A velocity given as separate numbers (``vx, vy`` fields) maps the same way, ``velocity =
["vx", "vy"]`` (vz = 0 without a third).

Paths are dotted field names with ``[i]`` indices and inclusive ``[i..j]`` ranges. Item paths
(position, velocity, orientation, id, item_header, item_stamp, item_frame, filter.field) are
relative to one element of ``array``. ``item_stamp`` (a Time or integer nanoseconds) and
``item_frame`` (a string) are an element's own time and frame where it has no header (each
overrides the message's where set; ``item_header = "h"`` is ``item_stamp = "h.stamp"`` with
``item_frame = "h.frame_id"``). :meth:`TopicMapping.check` validates every path against a
typestore's definition before any message is read, and names the path and the fields that
exist when one is wrong.

A message type without a header (``leg_tracker/msg/Person``: ``geometry_msgs/Pose pose``,
``uint32 id``) needs neither ``stamp`` nor ``frame``: when the type has no ``header`` and the
mapping does not say otherwise, detections take their message's log time, and their frame is
``frame_override`` (which such a mapping must then give: aion never guesses a frame).
:func:`formats.detections.suggest.suggest_mapping` writes a mapping from a type's definition.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aion_cli.errors import ConfigError
from aion_cli.formats.detections.adapter import DetectionAdapter
from aion_cli.formats.detections.generic import ItemSpec, Keep, dropped_with
from aion_cli.formats.detections.paths import FieldPath
from aion_cli.formats.raw import normalize_msgtype
from aion_cli.formats.toml_files import read_toml_text

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

_KEYS = {
    "topic", "msgtype", "array", "position", "velocity", "orientation", "yaw", "id", "stamp",
    "frame", "item_header", "item_stamp", "item_frame", "frame_override", "filter",
}
# keys that take a path per coordinate as well as one path
_VECTOR_KEYS = ("position", "velocity")
# rosbags field-definition node types.
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4


@dataclass(frozen=True)
class TopicMapping:
    """One topic's mapping: where its detections live (an :class:`ItemSpec`)."""

    topic: str
    msgtype: str
    spec: ItemSpec
    raw: dict[str, Any]

    def adapter(self, typestore: Typestore | None = None) -> DetectionAdapter:
        """A generic adapter decoding this topic's messages with the mapping; missing fields
        at decode time raise :class:`ConfigError` naming the path."""
        adapter = DetectionAdapter(
            self.msgtype, self.spec.extract, None, typestore, strict_fields=True
        )
        adapter.stamped = not self.uses_log_time
        return adapter

    def check(self, typestore: Typestore) -> TopicMapping:
        """Validate every path against ``typestore``'s definition of ``msgtype``; returns the
        mapping to decode with: the same, or -- for a type without the default
        ``header.stamp`` / ``header.frame_id`` that the mapping left unset -- one reading log
        times and ``frame_override``."""
        if self.msgtype not in typestore.fielddefs:
            raise ConfigError(
                f"mapping for {self.topic!r}: message type {self.msgtype!r} is not known",
                hint="use the type name the log lists (aion info LOG), e.g. pkg/msg/Type",
            )
        resolved = self._headerless(typestore)
        if resolved is not self:
            return resolved.check(typestore)
        root = (_NAME, self.msgtype)
        item = root
        r = self.raw
        if "array" in r:
            item = _element(typestore, _walk(typestore, root, r["array"], "array"), r["array"])
        for key in _VECTOR_KEYS:
            if key not in r:
                continue
            if isinstance(r[key], list):
                for path in r[key]:
                    _number(_walk(typestore, item, path, key), path, key)
            else:
                _vector(typestore, _walk(typestore, item, r[key], key), 3, key)
        if "orientation" in r:
            node = _walk(typestore, item, r["orientation"], "orientation")
            _vector(typestore, node, 4, "orientation")
        if "yaw" in r:
            _number(_walk(typestore, item, r["yaw"], "yaw"), r["yaw"], "yaw")
        if "id" in r:
            _identity(typestore, _walk(typestore, item, r["id"], "id"), r["id"])
        for key, default in (("stamp", "header.stamp"), ("frame", "header.frame_id")):
            if path := r.get(key, default):
                check = _stamp if key == "stamp" else _text
                check(typestore, _walk(typestore, root, path, key), path, key)
        if "item_header" in r:
            for sub, check in ((".stamp", _stamp), (".frame_id", _text)):
                path = r["item_header"] + sub
                check(typestore, _walk(typestore, item, path, "item_header"), path, "item_header")
        for key, check in (("item_stamp", _stamp), ("item_frame", _text)):
            if key in r:
                check(typestore, _walk(typestore, item, r[key], key), r[key], key)
        if "filter" in r:
            field = r["filter"]["field"]
            _comparable(_walk(typestore, item, field, "filter.field"), field, r["filter"]["equals"])
        return self

    def _headerless(self, typestore: Typestore) -> TopicMapping:
        """Without a ``header`` field, the default stamp and frame paths cannot apply: unset
        ones become "log time" and "frame_override" (which must then be given)."""
        r = self.raw
        names = {name for name, _ in _fields(typestore, self.msgtype)}
        if "header" in names or ("stamp" in r and "frame" in r):
            return self
        spec = self.spec
        raw = dict(r)
        if "stamp" not in r:
            spec, raw["stamp"] = replace(spec, stamp=None), ""
        if "frame" not in r:
            if not {"frame_override", "item_header", "item_frame"} & set(r):
                raise ConfigError(
                    f"mapping for {self.topic!r}: {self.msgtype} has no header, so the frame "
                    "of its positions is unknown",
                    hint='add frame_override = "FRAME" (the frame the positions are in, e.g. '
                    'the --map-frame, "map") or item_frame = "PATH" (each element\'s frame) '
                    "to its [[topic]] table",
                )
            spec, raw["frame"] = replace(spec, frame=None), ""
        return TopicMapping(self.topic, self.msgtype, spec, raw)

    @property
    def uses_log_time(self) -> bool:
        """Whether detections take their message's log time (no stamp path at all)."""
        return self.spec.stamp is None and self.spec.item_stamp is None


def load_mapping(source: str | Path) -> list[TopicMapping]:
    """Parse a mapping file (a path) or TOML text; :class:`ConfigError` on any problem."""
    if isinstance(source, Path):
        text = read_toml_text(
            source,
            "mapping file",
            hint="check the path; `aion info LOG --suggest-mapping TOPIC > FILE` writes one",
        )
        where = str(source)
    else:
        text, where = source, "mapping"
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(
            f"{where} is not valid TOML: {exc}",
            hint="fix the line named (README, People detections: the mapping's keys); "
            "`aion info LOG --suggest-mapping TOPIC` prints a valid one to start from",
        ) from exc
    tables = doc.get("topic")
    if not isinstance(tables, list) or not tables:
        raise ConfigError(
            f"{where} has no [[topic]] tables", hint="start each mapping with [[topic]]"
        )
    unknown_top = set(doc) - {"topic"}
    if unknown_top:
        raise ConfigError(f"{where}: unknown top-level keys {sorted(unknown_top)}")
    return [_parse_topic(t, f"{where} [[topic]] #{i + 1}") for i, t in enumerate(tables)]


def _parse_topic(t: dict[str, Any], where: str) -> TopicMapping:
    unknown = set(t) - _KEYS
    if unknown:
        raise ConfigError(f"{where}: unknown keys {sorted(unknown)}; known: {sorted(_KEYS)}")
    for key in _VECTOR_KEYS:
        value: Any = t.get(key)
        if isinstance(value, list) and not (
            2 <= len(value) <= 3 and all(isinstance(p, str) and p for p in value)
        ):
            raise ConfigError(
                f"{where}: {key!r} as a list names 2 or 3 number fields (x, y[, z]), got "
                f"{value!r}",
                hint=f'e.g. {key} = ["{"x" if key == "position" else "vx"}", '
                f'"{"y" if key == "position" else "vy"}"] for a planar one',
            )
    planar = isinstance(t.get("position"), list)
    for key in ("topic", "msgtype", "position"):
        if key == "position" and planar:
            continue
        if not isinstance(t.get(key), str) or not t[key]:
            raise ConfigError(f"{where}: {key!r} is required (a string)")
    for key in _KEYS - {"filter", *_VECTOR_KEYS}:
        if key in t and not isinstance(t[key], str):
            raise ConfigError(f"{where}: {key!r} must be a string")
    if "velocity" in t and not isinstance(t["velocity"], (str, list)):
        raise ConfigError(f"{where}: 'velocity' must be a string or a list of 2 or 3 strings")
    if "item_header" in t and {"item_stamp", "item_frame"} & set(t):
        raise ConfigError(
            f"{where}: give 'item_header' (its stamp and frame_id) or 'item_stamp' / "
            "'item_frame', not both"
        )
    if "yaw" in t and "orientation" in t:
        raise ConfigError(
            f"{where}: give 'orientation' (a quaternion) or 'yaw' (radians), not both"
        )
    keep = _filter(t["filter"], where) if "filter" in t else None
    spec = ItemSpec.of(
        t.get("array"), t["position"], t.get("velocity"), t.get("orientation"), t.get("id"),
        t.get("stamp", "header.stamp") or None, t.get("frame", "header.frame_id") or None,
        t.get("item_header"), keep,
    )
    if "item_stamp" in t:
        spec = replace(spec, item_stamp=FieldPath.parse(t["item_stamp"]))
    if "item_frame" in t:
        spec = replace(spec, item_frame=FieldPath.parse(t["item_frame"]))
    if "frame_override" in t:
        spec = replace(spec, fixed_frame=t["frame_override"])
    if "yaw" in t:
        spec = replace(spec, yaw=FieldPath.parse(t["yaw"]))
    return TopicMapping(t["topic"], normalize_msgtype(t["msgtype"]), spec, dict(t))


def _filter(f: Any, where: str) -> Keep:
    if not isinstance(f, dict) or set(f) != {"field", "equals"}:
        raise ConfigError(f"{where}: filter must be {{ field = \"...\", equals = ... }}")
    path = FieldPath.parse(f["field"])
    raw = f["equals"]
    wanted = tuple(raw) if isinstance(raw, list) else (raw,)

    def keep(item: Any) -> str | None:
        value = path.get(item)
        return None if value in wanted else dropped_with("filter", path.text, value)

    return keep


# --- static path checks against rosbags field definitions -----------------------------------

Node = tuple[int, Any]


def _fields(store: Typestore, typename: str) -> list[tuple[str, Node]]:
    return list(store.fielddefs[typename][1])


def _walk(store: Typestore, node: Node, text: str, what: str) -> Node:
    """The definition node at ``text`` from ``node``; ConfigError naming the missing field."""
    path = FieldPath.parse(text)
    cur = node
    for step in path.steps:
        kind, detail = cur[0], cur[1]
        if isinstance(step, str):
            if kind != _NAME:
                raise ConfigError(f"{what} path {text!r}: cannot take field {step!r} of a "
                                  f"{_describe(cur)}")
            fields = dict(_fields(store, detail))
            if step not in fields:
                raise ConfigError(
                    f"{what} path {text!r}: {detail} has no field {step!r}; available: "
                    f"{', '.join(fields)}"
                )
            cur = fields[step]
            cur = (int(cur[0]), cur[1])
        else:
            if kind not in (_ARRAY, _SEQUENCE):
                raise ConfigError(f"{what} path {text!r}: {_describe(cur)} is not an array")
            last = step if isinstance(step, int) else step[1]
            length = detail[1]
            if kind == _ARRAY and last >= length:
                raise ConfigError(
                    f"{what} path {text!r}: index {last} out of range (length {length})"
                )
            if isinstance(step, int):
                cur = (int(detail[0][0]), detail[0][1])
            else:
                cur = (_ARRAY, (detail[0], step[1] - step[0] + 1))
    return cur


def _element(store: Typestore, node: Node, text: str) -> Node:
    if node[0] not in (_ARRAY, _SEQUENCE):
        raise ConfigError(f"array path {text!r} is a {_describe(node)}, not an array")
    elem = node[1][0]
    return (int(elem[0]), elem[1])


def _vector(store: Typestore, node: Node, size: int, what: str) -> None:
    """A Point/Vector3-like message or 3 numbers (a planar one too: ``x, y`` or 2 numbers),
    or for ``size`` 4 a Quaternion-like message or 4 numbers."""
    names = "xy" if size == 3 else "xyzw"
    hint = 'a path per coordinate reads number fields: position = ["x", "y"]' if size == 3 else None
    if node[0] == _NAME:
        fields = dict(_fields(store, node[1]))
        if all(c in fields for c in names):
            return
        raise ConfigError(
            f"{what} must be a {'Point/Vector3' if size == 3 else 'Quaternion'}; {node[1]} has "
            f"fields {', '.join(fields)}",
            hint=hint,
        )
    sizes = (2, 3) if size == 3 else (size,)
    if node[0] in (_ARRAY, _SEQUENCE) and node[1][0][0] == _BASE and node[1][1] in sizes:
        return
    raise ConfigError(
        f"{what} must point to {size} numbers or a message, not a {_describe(node)}", hint=hint
    )


_NUMBERS = frozenset({
    "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
    "uint64",
})  # fmt: skip


def _number(node: Node, path: str, what: str) -> None:
    """``path`` must lead to one number (a position coordinate or a yaw)."""
    if node[0] == _BASE and node[1][0] in _NUMBERS:
        return
    raise ConfigError(f"{what} path {path!r} must lead to a number, not a {_describe(node)}")


def _identity(store: Typestore, node: Node, path: str) -> None:
    """``path`` must lead to a track id: an integer, a string, an array of bytes (a UUID's
    ``uint8[16]``) or a message holding one as ``uuid`` (``unique_identifier_msgs/UUID``)."""
    kind, detail = node
    if kind == _BASE and detail[0] in (_NUMBERS - {"float32", "float64"}) | {"string", "byte"}:
        return
    if kind in (_ARRAY, _SEQUENCE) and detail[0][0] == _BASE and detail[0][1][0] in (
        "uint8", "int8", "byte", "char",
    ):
        return
    if kind == _NAME and "uuid" in dict(_fields(store, detail)):
        return
    raise ConfigError(
        f"id path {path!r} must lead to an integer, a string or a UUID, not {_a(node)}",
        hint="a track id names one person across messages; without one, leave id out "
        "(detections are linked into tracks)",
    )


def _stamp(store: Typestore, node: Node, path: str, what: str) -> None:
    """``path`` must lead to a time stamp: a Time message (``sec``/``nanosec`` or
    ``secs``/``nsecs``) or an integer of nanoseconds."""
    if node[0] == _NAME:
        names = {name for name, _ in _fields(store, node[1])}
        if {"sec", "nanosec"} <= names or {"secs", "nsecs"} <= names:
            return
    elif node[0] == _BASE and node[1][0] in _NUMBERS - {"float32", "float64"}:
        return
    raise ConfigError(
        f"{what} path {path!r} must lead to a time stamp (a Time message or integer "
        f"nanoseconds), not {_a(node)}",
        hint='a header\'s stamp is "header.stamp"; "" takes the log time',
    )


def _text(store: Typestore, node: Node, path: str, what: str) -> None:
    """``path`` must lead to a frame name (a string)."""
    if node[0] == _BASE and node[1][0] == "string":
        return
    raise ConfigError(
        f"{what} path {path!r} must lead to a frame name (a string), not {_a(node)}",
        hint='a header\'s frame is "header.frame_id"; or give frame_override = "FRAME"',
    )


def _comparable(node: Node, path: str, equals: Any) -> None:
    """The filter's ``equals`` values must be of its field's kind (strings for a string, whole
    numbers for an integer, ...): a value of another kind never equals a field's value, and
    the filter would drop every item of the topic."""
    values = equals if isinstance(equals, list) else [equals]
    base = node[1][0] if node[0] == _BASE else None
    if base == "string":
        kind, fits = "strings", all(isinstance(v, str) for v in values)
    elif base == "bool":
        kind, fits = "true or false", all(isinstance(v, bool) for v in values)
    elif base in (_NUMBERS - {"float32", "float64"}) | {"byte", "char"}:
        kind = "whole numbers"
        fits = all(isinstance(v, int) and not isinstance(v, bool) for v in values)
    elif base in ("float32", "float64"):
        kind = "numbers"
        fits = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    else:
        raise ConfigError(
            f"filter.field path {path!r} must lead to a string, number or bool to compare, "
            f"not {_a(node)}"
        )
    if not fits or not values:
        raise ConfigError(
            f"filter on {path!r} ({_describe(node)}): equals must list {kind}, got {equals!r}; "
            "no item would pass",
            hint=f'e.g. filter = {{ field = "{path}", equals = '
            + ('["person"] }' if base == "string" else "[1] }"),
        )


def _a(node: Node) -> str:
    """``a string value``, ``a message pkg/msg/T``, ``an array``."""
    text = _describe(node)
    return f"an {text}" if text == "array" else f"a {text}"


def _describe(node: Node) -> str:
    kind, detail = node
    if kind == _NAME:
        return f"message {detail}"
    if kind == _BASE:
        return f"{detail[0]} value"
    return "array"
