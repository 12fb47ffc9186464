"""Generic detection extraction from deserialized (rosbags) message objects.

One :class:`ItemSpec` describes a message type by field paths: where the array of people is,
and per item where position, velocity, orientation, id, stamp and frame are. The built-in
adapters for the less common types and the user's TOML mapping (:mod:`.mapping`) both use it.
This path loops in Python per item; it is the fallback, the fast path is :mod:`.fast`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aion_cli.errors import ConfigError
from aion_cli.formats.detections.frame import hash_id
from aion_cli.formats.detections.paths import (
    FieldPath,
    ShortArrayError,
    quat4,
    scalar,
    stamp_ns,
    vec3,
    yaw_quaternion,
)

NAN_Q = (math.nan, math.nan, math.nan, math.nan)
NAN_V = (math.nan, math.nan, math.nan)

SEEN = "seen: "
"""The prefix of a ``filtered`` key that counts the items a filter dropped with one value of
its field (``seen: kind = "robot"``), beside the reason's count: what a build that kept none
names in its error (:meth:`aion_cli.detection_counts.DetectionCounts.add_decoded`)."""
SEEN_VALUES = 8
"""The distinct values kept per decode (a filter on an id would see thousands)."""
_SEEN_SEP = "\x1f"


def dropped_with(reason: str, field: str, value: Any) -> str:
    """The drop ``reason`` of a filter that met ``value`` in ``field``: :meth:`Rows.drop`
    counts the reason and, under :data:`SEEN`, the value."""
    if isinstance(value, (bool, np.bool_)):
        shown = "true" if value else "false"
    elif isinstance(value, str):
        shown = json.dumps(value if len(value) <= 40 else value[:40] + "...", ensure_ascii=False)
    else:
        shown = str(value)
    return f"{reason}{_SEEN_SEP}{field} = {shown}"


def track_id_of(value: Any) -> int:
    """An int64 track id (>= 0, or -1 for none) from an id field of any kind: integers are
    masked to 63 bits, strings and byte arrays (UUIDs) hashed with :func:`hash_id`; -1 (a
    detector's "not tracked"), empty strings and all-zero UUIDs mean "no id"."""
    if hasattr(value, "uuid"):
        value = value.uuid
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, (int, np.integer)):
        return -1 if value == -1 else int(value) & 0x7FFF_FFFF_FFFF_FFFF
    if isinstance(value, str):
        return hash_id(value)
    arr = np.asarray(value)
    if arr.dtype.kind in "ui" and arr.ndim == 1:
        raw = arr.astype(np.uint8).tobytes()
        return -1 if not any(raw) else hash_id(raw)
    raise ConfigError(f"cannot use a {type(value).__name__} as a track id")


@dataclass
class Rows:
    """Accumulated rows of the generic path (Python lists, turned into arrays at the end)."""

    owner: list[int] = field(default_factory=list)
    stamp: list[int] = field(default_factory=list)
    frame: list[str] = field(default_factory=list)
    xyz: list[tuple[float, float, float]] = field(default_factory=list)
    vel: list[tuple[float, float, float]] = field(default_factory=list)
    quat: list[tuple[float, float, float, float]] = field(default_factory=list)
    track: list[int] = field(default_factory=list)
    filtered: dict[str, int] = field(default_factory=dict)
    seen_values: int = 0  # the distinct values counted under SEEN in ``filtered``

    def add(
        self,
        owner: int,
        stamp: int,
        frame: str,
        xyz: tuple[float, float, float],
        vel: tuple[float, float, float] = NAN_V,
        quat: tuple[float, float, float, float] = NAN_Q,
        track: int = -1,
    ) -> None:
        self.owner.append(owner)
        self.stamp.append(stamp)
        self.frame.append(frame)
        self.xyz.append(xyz)
        self.vel.append(vel)
        self.quat.append(quat)
        self.track.append(track)

    def drop(self, reason: str, n: int = 1) -> None:
        """Count ``n`` items dropped for ``reason``; one of :func:`dropped_with` also counts
        its value (under :data:`SEEN`, the first :data:`SEEN_VALUES` values only)."""
        reason, _, value = reason.partition(_SEEN_SEP)
        self.filtered[reason] = self.filtered.get(reason, 0) + n
        if value:
            key = SEEN + value
            if key in self.filtered or self.seen_values < SEEN_VALUES:
                self.seen_values += key not in self.filtered
                self.filtered[key] = self.filtered.get(key, 0) + n


Item = Any
#: A filter returns the reason to drop an item, or None to keep it.
Keep = Callable[[Item], str | None]
#: Post-processing of one row: (item, velocity, quaternion) -> (velocity, quaternion).
Adjust = Callable[
    [Item, tuple[float, float, float], tuple[float, float, float, float]],
    tuple[tuple[float, float, float], tuple[float, float, float, float]],
]


def _opt(path: str | None) -> FieldPath | None:
    return None if path is None else FieldPath.parse(path)


@dataclass(frozen=True)
class ItemSpec:
    """Field paths describing where detections live in a message type.

    ``array`` is the sequence of people (None: the message itself is one detection);
    ``position``/``velocity``/``orientation``/``track_id`` are relative to an item; ``stamp``
    and ``frame`` to the message; ``item_stamp``/``item_frame`` (per-item header) override
    them where set (non-zero stamp, non-empty frame); ``fixed_frame`` replaces both.
    ``position`` and ``velocity`` are each one path (a Point-like or planar message, 2 or 3
    numbers) or a path per coordinate (x, y and optionally z: numbers; z = 0 without one);
    ``yaw`` (a number, radians about z) stands for the orientation of a planar pose."""

    array: FieldPath | None
    position: FieldPath | tuple[FieldPath, ...]
    velocity: FieldPath | tuple[FieldPath, ...] | None = None
    orientation: FieldPath | None = None
    track_id: FieldPath | None = None
    stamp: FieldPath | None = field(default_factory=lambda: FieldPath.parse("header.stamp"))
    frame: FieldPath | None = field(default_factory=lambda: FieldPath.parse("header.frame_id"))
    item_stamp: FieldPath | None = None
    item_frame: FieldPath | None = None
    keep: Keep | None = None
    adjust: Adjust | None = None
    fixed_frame: str | None = None
    yaw: FieldPath | None = None

    @classmethod
    def of(
        cls,
        array: str | None,
        position: str | list[str] | tuple[str, ...],
        velocity: str | list[str] | tuple[str, ...] | None = None,
        orientation: str | None = None,
        track_id: str | None = None,
        stamp: str | None = "header.stamp",
        frame: str | None = "header.frame_id",
        item_header: str | None = None,
        keep: Keep | None = None,
        adjust: Adjust | None = None,
    ) -> ItemSpec:
        """Build a spec from path strings (``item_header`` sets both item paths)."""
        return cls(
            _opt(array), _vector_paths(position),
            None if velocity is None else _vector_paths(velocity), _opt(orientation),
            _opt(track_id), _opt(stamp), _opt(frame),
            _opt(f"{item_header}.stamp" if item_header else None),
            _opt(f"{item_header}.frame_id" if item_header else None),
            keep, adjust,
        )

    def extract(self, msg: Any, owner: int, rows: Rows) -> None:
        """Append the detections of one message to ``rows``."""
        stamp = stamp_ns(self.stamp.get(msg)) if self.stamp else 0
        frame = str(self.frame.get(msg)) if self.frame else ""
        if self.fixed_frame is not None:
            frame = self.fixed_frame
        items = self.array.get(msg) if self.array else [msg]
        for it in items:
            try:  # the filter's path too: an empty results[] has no results[0] to compare
                if self.keep is not None and (reason := self.keep(it)) is not None:
                    rows.drop(reason)
                    continue
                self._item(it, owner, stamp, frame, rows)
            except ShortArrayError:  # this item's sequence is too short for the path
                rows.drop("short_array")

    def _item(self, it: Any, owner: int, stamp: int, frame: str, rows: Rows) -> None:
        """Append the detection of one item (after the filter) to ``rows``."""
        t = stamp_ns(self.item_stamp.get(it)) if self.item_stamp else 0
        f = str(self.item_frame.get(it)) if self.item_frame else ""
        if self.fixed_frame is not None:
            f = self.fixed_frame
        vel = _vector(it, self.velocity) if self.velocity is not None else NAN_V
        o = self.orientation
        if self.yaw is not None:
            q = yaw_quaternion(scalar(self.yaw.get(it), self.yaw.text))
        else:
            q = quat4(o.get(it), o.text) if o else NAN_Q
        if self.adjust is not None:
            vel, q = self.adjust(it, vel, q)
        rows.add(
            owner,
            t or stamp,
            f or frame,
            _vector(it, self.position),
            vel,
            q,
            track_id_of(self.track_id.get(it)) if self.track_id else -1,
        )



def _vector_paths(where: str | list[str] | tuple[str, ...]) -> FieldPath | tuple[FieldPath, ...]:
    """One path to a vector, or a path per coordinate."""
    if isinstance(where, str):
        return FieldPath.parse(where)
    return tuple(FieldPath.parse(p) for p in where)


def _vector(item: Any, where: FieldPath | tuple[FieldPath, ...]) -> tuple[float, float, float]:
    """A position or velocity of ``item``: from one path (:func:`vec3`), or from a number
    per coordinate (z = 0 when only x and y are given)."""
    if isinstance(where, FieldPath):
        return vec3(where.get(item), where.text)
    xyz = [scalar(path.get(item), path.text) for path in where]
    return xyz[0], xyz[1], xyz[2] if len(xyz) == 3 else 0.0


Extractor = Callable[[Any, int, Rows], None]
