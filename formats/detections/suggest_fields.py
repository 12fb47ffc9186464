"""The fields of a message definition as a rosbags typestore holds them, for
:mod:`.suggest`: their nodes by name, the numeric ones, a ``header``, and an element's own
velocity numbers (``vx, vy[, vz]``), time (``item_stamp``) and frame (``item_frame``).

Split from :mod:`formats.detections.suggest`, which walks a definition with these."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

BASE, NAME, ARRAY, SEQUENCE = 1, 2, 3, 4
FLOATS = frozenset({"float32", "float64"})
INTS = frozenset(
    {"int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64", "byte", "char"}
)


def fields_of(store: Typestore, typename: str) -> list[tuple[str, tuple[int, Any]]]:
    return [(name, (int(node[0]), node[1])) for name, node in store.fielddefs[typename][1]]


def field_names(store: Typestore, typename: str) -> dict[str, tuple[int, Any]]:
    return dict(fields_of(store, typename))


def number_fields(store: Typestore, typename: str) -> set[str]:
    return {
        name
        for name, node in fields_of(store, typename)
        if node[0] == BASE and (node[1][0] in FLOATS or node[1][0] in INTS)
    }


#: an element's velocity as a number per axis, best first (``velocity = ["vx", "vy"]``)
VELOCITY_NUMBERS = (
    ("vx", "vy", "vz"), ("vel_x", "vel_y", "vel_z"), ("velocity_x", "velocity_y", "velocity_z"),
    ("v_x", "v_y", "v_z"),
)  # fmt: skip
#: an element's own time (a Time message or integer nanoseconds) and frame, best first
STAMP_NAMES = ("stamp", "t_ns", "stamp_ns", "time_ns", "timestamp", "time", "t")
FRAME_NAMES = ("frame_id", "frame", "frame_name")


def velocity_numbers(store: Typestore, typename: str) -> list[str]:
    """The element's velocity as separate numbers (``vx, vy[, vz]``); empty without them."""
    numbers = number_fields(store, typename)
    for names in VELOCITY_NUMBERS:
        if set(names[:2]) <= numbers:
            return list(names if names[2] in numbers else names[:2])
    return []


def own_stamp(store: Typestore, typename: str) -> str | None:
    """A field of the element named like a time that the mapping reads as one (a Time message,
    or a 64-bit integer of nanoseconds: ``item_stamp``); None without one."""
    fields = field_names(store, typename)
    for name in STAMP_NAMES:
        node = fields.get(name)
        if node is None:
            continue
        if node[0] == NAME:
            names = set(field_names(store, str(node[1])))
            if {"sec", "nanosec"} <= names or {"secs", "nsecs"} <= names:
                return name
        elif node[0] == BASE and node[1][0] in ("int64", "uint64"):
            return name
    return None


def own_frame(store: Typestore, typename: str) -> str | None:
    """A string field of the element named like a frame (``item_frame``); None without one."""
    fields = field_names(store, typename)
    for name in FRAME_NAMES:
        node = fields.get(name)
        if node is not None and node[0] == BASE and node[1][0] == "string":
            return name
    return None


def has_header(store: Typestore, typename: str) -> bool:
    node = field_names(store, typename).get("header")
    return node is not None and node[0] == NAME and str(node[1]).endswith("/Header")
