"""A ready-to-edit TOML mapping (:mod:`.mapping`) for a topic, from its message definition.

``aion info LOG --suggest-mapping TOPIC`` prints :func:`suggest_mapping` of the topic's type as
the log itself defines it. The definition is walked field by field (sub-messages resolved,
sequences other than the array of people not entered) and every field that can play a role is
named as a candidate:

- the **array** of people: a sequence of messages that hold a position (names such as
  ``people``, ``tracks``, ``agents``, ``detections`` first); none: one detection per message;
- **position**: a Point/Vector3-like message (``x, y, z``) or 3 numbers, preferring names such
  as ``position``, ``pos``, ``center`` (and a Pose's position); velocity-, size- or force-like
  names are never positions;
- **velocity**: a vector whose path says ``vel`` (or a Twist's ``linear``);
- **orientation**: a Quaternion-like message (``x, y, z, w``);
- a **planar** pose, when nothing holds three coordinates: a message with numeric ``x, y``
  (``geometry_msgs/Pose2D``) as the position, or the item's own ``x, y`` number fields
  (turtlesim's ``Pose``) as ``position = ["x", "y"]``, and a number named like a yaw
  (``theta``, ``yaw``, ``heading``) as ``yaw``;
- **id**: an integer, string or UUID field named like an id (``track_id``, ``id``, ``uuid``,
  ``object_id``, ``name``, ...), unless the topic's first messages number their elements
  0..k-1 with it (:func:`counts_items`, the build's rule for MarkerArray ids);
- **velocity** as a number per axis: an element's ``vx, vy[, vz]`` (or ``vel_x``, ...) as
  ``velocity = ["vx", "vy"]``, when no vector is named like a velocity;
- **stamp / frame**: the message's ``header`` (the defaults), a per-item ``header``
  (``item_header``), an element's own time and frame fields without a header (``item_stamp``:
  a Time or 64-bit integer named like ``stamp``, ``t_ns``; ``item_frame``: a string named
  ``frame_id`` or ``frame``), or, without any, the log time and a ``frame_override`` to fill in.

The first candidate of each role is filled in; the others are listed in a comment. The text
loads with :func:`~formats.detections.mapping.load_mapping` and passes
:meth:`~formats.detections.mapping.TopicMapping.check` as printed.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from aion_cli.errors import ConfigError
from aion_cli.formats.detections.suggest_fields import (
    ARRAY,
    BASE,
    FLOATS,
    INTS,
    NAME,
    SEQUENCE,
    field_names,
    fields_of,
    has_header,
    number_fields,
    own_frame,
    own_stamp,
    velocity_numbers,
)
from aion_cli.formats.raw import normalize_msgtype

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

_MAX_DEPTH = 5

#: Array names most likely to hold the people, best first.
_ARRAY_NAMES = (
    "people", "persons", "tracks", "agents", "agent_states", "humans", "pedestrians",
    "detections", "objects", "obstacles", "poses", "markers",
)  # fmt: skip
_POSITION_WORDS = ("position", "pos", "center", "centroid", "location", "point", "xyz")
_NOT_POSITION = (
    "vel", "linear", "angular", "twist", "size", "scale", "dimension", "force", "acc",
    "covariance", "extent", "bbox_size", "orientation", "color", "normal",
)  # fmt: skip


def _not_position(path: str) -> bool:
    """Whether ``path`` names a velocity, size, covariance, ... rather than a position. A
    ``pose_with_covariance`` on the way (Autoware's ``kinematics.pose_with_covariance.pose.
    position``) is a pose, not a covariance."""
    words = path.lower().replace("_with_covariance", "")
    return any(w in words for w in _NOT_POSITION)


#: Id field names, best first.
_ID_NAMES = (
    "track_id", "tracking_id", "id", "uuid", "object_id", "agent_id", "person_id",
    "instance_id", "label_id", "name",
)  # fmt: skip


@dataclass
class _Candidates:
    """Candidate paths per role, in the order found (relative to one item)."""

    vec3: list[str] = field(default_factory=list)
    quat: list[str] = field(default_factory=list)
    ids: list[str] = field(default_factory=list)
    vec2: list[str] = field(default_factory=list)  # numeric x, y only (or 2 numbers)


def _is_vector(store: Typestore, typename: str, names: str) -> bool:
    fields = field_names(store, typename)
    if set(fields) != set(names) and not (names == "xyz" and set("xyz") <= set(fields)):
        return False
    if names == "xyz" and "w" in fields:
        return False
    return all(fields[c][0] == BASE and fields[c][1][0] in FLOATS for c in names)


def _is_planar(store: Typestore, typename: str) -> bool:
    """A planar point or pose: numeric ``x`` and ``y``, no ``z`` or ``w``."""
    numbers = number_fields(store, typename)
    names = set(field_names(store, typename))
    return {"x", "y"} <= numbers and not names & {"z", "w"}


#: yaw field names, best first
_YAW_NAMES = ("yaw", "theta", "heading", "angle", "phi")


def _yaws(store: Typestore, typename: str, prefix: str = "") -> list[str]:
    floats = {
        name
        for name, node in fields_of(store, typename)
        if node[0] == BASE and node[1][0] in FLOATS
    }
    return [prefix + n for n in _YAW_NAMES if n in floats]


def _planar(store: Typestore, item: str, found: _Candidates) -> tuple[str | list[str], list[str]]:
    """A planar position (a path to an ``x, y`` message, or the item's own ``x, y`` fields)
    and the yaw candidates beside it; ``("", [])`` when there is none."""
    usable = [p for p in found.vec2 if not _not_position(p)]
    if usable:
        path = sorted(usable, key=_position_rank)[0]
        if path.endswith("]"):  # two numbers (``pos[0..1]``): a yaw would be beside them
            return path, _yaws(store, item)
        node = _walk_to(store, item, path)
        return path, _yaws(store, node, path + ".") if node else []
    numbers = number_fields(store, item)
    if {"x", "y"} <= numbers:
        return ["x", "y", "z"] if "z" in numbers else ["x", "y"], _yaws(store, item)
    return "", []


def _walk_to(store: Typestore, typename: str, path: str) -> str | None:
    """The message type at a dotted ``path`` of plain field names (None otherwise)."""
    for step in path.split("."):
        node = field_names(store, typename).get(step)
        if node is None or node[0] != NAME:
            return None
        typename = str(node[1])
    return typename


def _is_uuid(store: Typestore, node: tuple[int, Any]) -> bool:
    """unique_identifier_msgs/UUID (``uint8[16] uuid``) or a bare ``uint8[16]``."""
    if node[0] == NAME:
        fields = fields_of(store, node[1])
        return len(fields) == 1 and _is_uuid(store, fields[0][1])
    if node[0] == ARRAY:
        elem, length = node[1]
        return int(elem[0]) == BASE and elem[1][0] in ("uint8", "byte") and length == 16
    return False


def _walk(
    store: Typestore, typename: str, prefix: str, depth: int = 0
) -> Iterator[tuple[str, str]]:
    """``(path, kind)`` of every field of ``typename`` that can play a role: kinds ``vec3``,
    ``quat``, ``id`` (scalars, strings, UUIDs). Headers and sequences are not entered."""
    if depth > _MAX_DEPTH:
        return
    for name, node in fields_of(store, typename):
        path = f"{prefix}{name}"
        kind, detail = node
        if kind == NAME:
            sub = str(detail)
            if sub.endswith("/Header"):
                continue
            if _is_vector(store, sub, "xyzw"):
                yield path, "quat"
            elif _is_vector(store, sub, "xyz"):
                yield path, "vec3"
            elif _is_planar(store, sub):
                yield path, "vec2"
            elif _is_uuid(store, node):
                yield path, "id"
            else:
                yield from _walk(store, sub, path + ".", depth + 1)
        elif kind == BASE:
            base = detail[0]
            if base in INTS or base == "string":
                yield path, "id"
        elif kind == ARRAY:
            elem, length = detail
            if int(elem[0]) == BASE and elem[1][0] in FLOATS and length in (2, 3, 4):
                if length == 2:
                    yield f"{path}[0..1]", "vec2"
                elif length == 3:
                    yield f"{path}[0..2]", "vec3"
                elif any(w in name.lower() for w in ("orient", "quat", "rot")):
                    yield f"{path}[0..3]", "quat"
            elif _is_uuid(store, node):
                yield path, "id"


def _collect(store: Typestore, typename: str, prefix: str = "") -> _Candidates:
    out = _Candidates()
    for path, kind in _walk(store, typename, prefix):
        {"vec3": out.vec3, "quat": out.quat, "id": out.ids, "vec2": out.vec2}[kind].append(path)
    return out


def _last(path: str) -> str:
    return path.split(".")[-1].split("[")[0].lower()


def _position_rank(path: str) -> tuple[int, int]:
    last = _last(path)
    words = path.lower()
    named = 0 if last in _POSITION_WORDS else 1 if any(w in last for w in _POSITION_WORDS) else 2
    return (named + (1 if "pose" not in words and named else 0), path.count("."))


def _positions(vec3: list[str]) -> list[str]:
    usable = [p for p in vec3 if not _not_position(p)]
    return sorted(usable, key=_position_rank)


def _velocities(vec3: list[str]) -> list[str]:
    vel = [p for p in vec3 if "vel" in p.lower()]
    twist = [p for p in vec3 if "twist" in p.lower() and _last(p) == "linear"]
    return [*vel, *(p for p in twist if p not in vel)]


def _ids(ids: list[str]) -> list[str]:
    ranked = [((_ID_NAMES.index(_last(p)), p.count(".")), p) for p in ids if _last(p) in _ID_NAMES]
    return [p for _, p in sorted(ranked)]


def _arrays(store: Typestore, typename: str) -> list[str]:
    """Sequences (or fixed arrays) of messages that hold a position, best first."""
    found = []
    for name, (kind, detail) in fields_of(store, typename):
        if kind not in (SEQUENCE, ARRAY) or int(detail[0][0]) != NAME:
            continue
        element = str(detail[0][1])
        found_in = _collect(store, element)
        if _positions(found_in.vec3) or _planar(store, element, found_in)[0]:
            found.append(name)
    rank = {n: i for i, n in enumerate(_ARRAY_NAMES)}
    return sorted(found, key=lambda n: rank.get(n.lower(), len(rank)))


def _element(store: Typestore, typename: str, array: str) -> str:
    detail = field_names(store, typename)[array][1]
    return str(detail[0][1])


def _toml_string(value: str) -> str:
    """A TOML basic string of ``value``: quotes, backslashes and control characters escaped
    (a topic name from a log may hold any of them; raw, they would break the file or reach
    the terminal as escape sequences)."""
    out = value.replace("\\", "\\\\").replace('"', '\\"')
    return '"' + _CONTROL.sub(lambda m: f"\\u{ord(m.group()):04x}", out) + '"'


def _build_command(map_frame: str | None) -> list[str]:
    """The suggestion's comment lines naming the build that reads it: with ``--map-frame``
    when the positions' frame is a TF root that joins no frame ``map`` (without it, the build
    stops with "unknown frame 'map'")."""
    if map_frame is None:
        return ["#   aion build LOG --detections-mapping THIS_FILE"]
    import shlex

    frame = _comment(map_frame)
    return [
        f"#   aion build LOG --detections-mapping THIS_FILE --map-frame {shlex.quote(frame)}",
        f"#     (the log's TF joins {frame} to no frame 'map', the map's frame by default)",
    ]


def _comment(text: str) -> str:
    """``text`` fit for a TOML comment: control characters (newlines included) escaped."""
    return _CONTROL.sub(lambda m: f"\\u{ord(m.group()):04x}", text)


#: C0 controls, DEL, C1 controls and the bidirectional overrides / isolates
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def _line(key: str, value: str, comment: str = "") -> str:
    text = f"{key} = {_toml_string(value)}"
    return f"{text:<40} # {_comment(comment)}" if comment else text


def _others(chosen: str, all_: list[str]) -> str:
    rest = [p for p in all_ if p != chosen]
    return ("other candidates: " + ", ".join(rest)) if rest else ""


def refuse_service_events(topic: str, msgtype: str) -> None:
    """:class:`ConfigError` for a service-introspection topic (``pkg/srv/Name_Event``): the log
    defines it as the service (request ``---`` response), which is no message definition a
    mapping could read (rosbags called it malformed)."""
    from aion_cli.formats.detections.registry import SERVICE_EVENTS, unreadable_kind

    if unreadable_kind(msgtype) == SERVICE_EVENTS:
        raise ConfigError(
            f"{topic}: {normalize_msgtype(msgtype)} records the calls of a service, not people: "
            "no mapping reads it",
            hint="choose a topic whose messages carry where people are (`aion info LOG` lists "
            "the topics and types)",
        )


def counts_items(sample: list[Any], array: str, id_path: str) -> bool:
    """Whether ``id_path`` of the ``array`` elements counts them, 0, 1, ..., k-1 in each
    message, rather than naming people, as the build's Marker reader judges it from a
    sample (per ``ns`` when the elements have one: :func:`.markers.ids_verdict`): every
    namespace of ``sample`` counts (some message with ids 0..k-1, k >= 2, none with a gap;
    the one id 0 in every message is one person's id). False without such a namespace, or
    when a path does not read."""
    from aion_cli.formats.detections.markers import ids_verdict
    from aion_cli.formats.detections.paths import FieldPath

    get = FieldPath.parse(id_path).get
    groups: dict[str, list[list[int]]] = {}
    for msg in sample:
        per_ns: dict[str, list[int]] = {}
        try:
            for item in getattr(msg, array):
                value = get(item)
                if not isinstance(value, int):
                    return False
                per_ns.setdefault(str(getattr(item, "ns", "")), []).append(value)
        except (ConfigError, AttributeError, TypeError):
            return False
        for ns, ids in per_ns.items():
            groups.setdefault(ns, []).append(ids)
    return bool(groups) and all(ids_verdict(g) == "counts" for g in groups.values())


def suggest_mapping(
    topic: str,
    msgtype: str,
    store: Typestore,
    sample: list[Any] | None = None,
    frame: str = "map",
    map_frame: str | None = None,
) -> str:
    """A TOML mapping for ``topic`` carrying ``msgtype`` as ``store`` defines it (see the
    module docstring); :class:`ConfigError` when the type holds nothing usable as a
    position. ``sample``: a few decoded messages of the topic; when the chosen id numbers
    the elements of each (:func:`counts_items`), no id is suggested. ``frame``: the
    ``frame_override`` suggested (the log's TF root where it has one). ``map_frame``: the
    ``--map-frame`` the build command it names needs when the positions are in ``frame``
    (a TF root that joins no frame ``map``: turtlesim's ``world``)."""
    name = normalize_msgtype(msgtype)
    if name not in store.fielddefs:
        raise ConfigError(f"{topic}: the log has no definition of {name}")
    arrays = _arrays(store, name)
    array = arrays[0] if arrays else None
    item = _element(store, name, array) if array else name
    found = _collect(store, item)
    positions = _positions(found.vec3)
    planar, yaws = ("", []) if positions else _planar(store, item, found)
    if not positions and not planar:
        from aion_cli.formats.detections.registry import RAW_SENSOR_HINT, RAW_SENSOR_TYPES

        if name in RAW_SENSOR_TYPES:
            raise ConfigError(
                f"{topic}: {name} is raw sensor data: it holds no positions of people for a "
                "mapping to read",
                hint=RAW_SENSOR_HINT,
            )
        fields = ", ".join(n for n, _ in fields_of(store, name))
        raise ConfigError(
            f"{topic}: {name} has no field aion can read as a position (a Point/Vector3-like "
            "message, 3 numbers, or numeric x and y, directly or in an array of messages); its "
            f"fields: {fields}",
            hint="a mapping reads positions: choose a topic whose messages carry where people "
            "are (`aion info LOG` lists the topics and types)",
        )
    velocities = _velocities(found.vec3)
    numbers = [] if velocities else velocity_numbers(store, item)
    ids = _ids(found.ids)
    header = has_header(store, name)
    item_header = array is not None and has_header(store, item)
    own = array is not None and not item_header
    item_stamp = own_stamp(store, item) if own else None
    item_frame = own_frame(store, item) if own else None
    overridden = not header and not item_header and not item_frame  # frame_override needed
    lines = [
        f"# aion detections mapping for {_comment(topic)} ({name}),",
        "# suggested from the log's own definition of the type. Check the fields, then:",
        *_build_command(map_frame if overridden and map_frame == frame else None),
        '# Format: README, "People detections"; paths are relative to one element of `array`.',
        "",
        "[[topic]]",
        _line("topic", topic),
        _line("msgtype", name),
    ]
    if array:
        lines.append(_line("array", array, _others(array, arrays) or "the people"))
    else:
        lines.append("# no array of people found: one detection per message")
    if positions:
        lines.append(_line("position", positions[0], _others(positions[0], positions)))
    elif isinstance(planar, list):
        names = ", ".join(_toml_string(p) for p in planar)
        lines.append(f"{'position = [' + names + ']':<40} # planar: z is 0 unless given")
    else:
        lines.append(_line("position", planar, "planar (x, y): z is 0"))
    if velocities:
        lines.append(_line("velocity", velocities[0], _others(velocities[0], velocities)))
    elif numbers:
        axes = ", ".join(_toml_string(p) for p in numbers)
        lines.append(f"{'velocity = [' + axes + ']':<40} # a number per axis")
    else:
        lines.append("# velocity: no candidate (headings come from tracks, or from linking)")
    if not found.quat and yaws:
        lines.append(_line("yaw", yaws[0], _others(yaws[0], yaws) or "radians about z"))
    elif found.quat:
        comment = "a pose yaw counts only when the quaternion is set"
        other = _others(found.quat[0], found.quat)
        comment = f"{comment}; {other}" if other else comment
        lines.append(_line("orientation", found.quat[0], comment))
    else:
        lines.append("# orientation: no candidate")
    if ids and array and sample and counts_items(sample, array, ids[0]):
        lines.append(
            f"# id: none ({_comment(ids[0])!s} numbers each message's {_comment(array)} "
            "0..k-1: no track id; detections are linked into tracks)"
        )
    elif ids:
        lines.append(_line("id", ids[0], _others(ids[0], ids) or "track id"))
    else:
        lines.append("# id: no candidate (detections are linked into tracks)")
    if header:
        lines.append('# stamp = "header.stamp", frame = "header.frame_id" (the defaults)')
    if item_header:
        lines.append(_line("item_header", "header", "each element's own stamp and frame"))
    if item_stamp:
        lines.append(_line("item_stamp", item_stamp, "each element's own time"))
    if item_frame:
        lines.append(_line("item_frame", item_frame, "each element's own frame"))
    if overridden:
        if not item_stamp:
            lines.append("# no header: detections take their message's log time")
        lines.append(
            _line("frame_override", frame, "REQUIRED here: the frame the positions are in")
        )
    elif not header:
        override = f"# frame_override = {_toml_string(frame)}"
        lines.append(f"{override:<40} # optional: replaces their frames")
    return "\n".join(lines) + "\n"
