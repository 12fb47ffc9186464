"""Field paths into deserialized (rosbags) messages: ``pose.pose.position``,
``results[0].hypothesis.class_id``, ``position[0..2]`` (an inclusive index range).

Used by the generic adapters and by the user's TOML mapping, so a bad path is reported with
the path and the fields that do exist (:class:`ConfigError`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, fields, is_dataclass
from typing import Any

import numpy as np

from aion_cli.errors import ConfigError

_STEP = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+(?:\.\.\d+)?\])*)")
_DOT = re.compile(r"\.(?![^\[]*\])")  # a dot outside [..] brackets
_INDEX = re.compile(r"\[(\d+)(?:\.\.(\d+))?\]")


@dataclass(frozen=True)
class FieldPath:
    """A parsed path: a tuple of steps, each a field name, an index ``int`` or an inclusive
    range ``(first, last)``."""

    text: str
    steps: tuple[str | int | tuple[int, int], ...]

    @classmethod
    def parse(cls, text: str) -> FieldPath:
        steps: list[str | int | tuple[int, int]] = []
        if not text or not text.strip():
            raise ConfigError("empty field path")
        for part in _DOT.split(text.strip()):
            m = _STEP.fullmatch(part)
            if m is None:
                raise ConfigError(
                    f"bad field path {text!r}: cannot parse {part!r}",
                    hint="use dotted field names with optional [i] or [i..j], e.g. "
                    "'tracks' or 'pose.pose.position' or 'position[0..2]'",
                )
            steps.append(m.group(1))
            for im in _INDEX.finditer(m.group(2)):
                a = int(im.group(1))
                if im.group(2) is None:
                    steps.append(a)
                else:
                    b = int(im.group(2))
                    if b < a:
                        raise ConfigError(f"bad field path {text!r}: range [{a}..{b}] is empty")
                    steps.append((a, b))
        return cls(text, tuple(steps))

    def get(self, obj: Any) -> Any:
        """The value at this path in ``obj``; :class:`ConfigError` naming the missing field
        and the available ones."""
        cur = obj
        for i, step in enumerate(self.steps):
            where = self._prefix(i)
            if isinstance(step, str):
                if not hasattr(cur, step) or step.startswith("_"):
                    raise ConfigError(
                        f"field path {self.text!r}: {where or 'the message'} has no field "
                        f"{step!r}; available: {', '.join(field_names(cur)) or '(none)'}"
                    )
                cur = getattr(cur, step)
            else:
                try:
                    size = len(cur)
                except TypeError:
                    raise ConfigError(
                        f"field path {self.text!r}: {where} is not an array"
                    ) from None
                a, b = (step, step) if isinstance(step, int) else step
                if b >= size:
                    raise ShortArrayError(
                        f"field path {self.text!r}: index {b} out of range for {where} "
                        f"(length {size})"
                    )
                cur = cur[a] if isinstance(step, int) else cur[a : b + 1]
        return cur

    def _prefix(self, i: int) -> str:
        out = ""
        for s in self.steps[:i]:
            if isinstance(s, str):
                out = f"{out}.{s}" if out else s
            elif isinstance(s, int):
                out += f"[{s}]"
            else:
                out += f"[{s[0]}..{s[1]}]"
        return out


class ShortArrayError(ConfigError):
    """An index beyond the end of the array a message holds: a sequence (``float64[] pos``)
    that one item leaves shorter than the mapping's ``pos[0..1]``. The data's, not the
    mapping's, fault (the check refuses such an index into a fixed-size array): the item is
    dropped, not the build stopped."""


def field_names(obj: Any) -> list[str]:
    """Field names of a message object (rosbags dataclasses; other objects: public attrs)."""
    if is_dataclass(obj) and not isinstance(obj, type):
        return [f.name for f in fields(obj)]
    slots = getattr(obj, "__slots__", None)
    if slots:
        return [s for s in slots if not s.startswith("_")]
    return []


def vec3(value: Any, what: str) -> tuple[float, float, float]:
    """x, y, z from a Point/Vector3-like object or a 3-element numeric array; a planar one
    (``x, y`` only: a Pose2D, turtlesim's Pose; or 2 numbers) has z = 0."""
    if hasattr(value, "x") and hasattr(value, "y"):
        z = float(value.z) if hasattr(value, "z") else 0.0
        return float(value.x), float(value.y), z
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.shape == (2,):
        return float(arr[0]), float(arr[1]), 0.0
    if arr.shape != (3,):
        raise ConfigError(
            f"{what} must point to a Point/Vector3, x and y, or 2 or 3 numbers, got "
            f"{type(value).__name__} of {arr.size} values"
        )
    return float(arr[0]), float(arr[1]), float(arr[2])


def scalar(value: Any, what: str) -> float:
    """One number (a float or integer field)."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{what} must point to a number, got {type(value).__name__}") from None


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """The rotation by ``yaw`` radians about z, as (x, y, z, w)."""
    half = 0.5 * yaw
    return 0.0, 0.0, math.sin(half), math.cos(half)


def quat4(value: Any, what: str) -> tuple[float, float, float, float]:
    """x, y, z, w from a Quaternion-like object or 4 numbers in (x, y, z, w) order."""
    if all(hasattr(value, k) for k in "xyzw"):
        return float(value.x), float(value.y), float(value.z), float(value.w)
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.shape != (4,):
        raise ConfigError(f"{what} must point to a Quaternion or 4 numbers (x, y, z, w)")
    return float(arr[0]), float(arr[1]), float(arr[2]), float(arr[3])


def stamp_ns(value: Any) -> int:
    """Nanoseconds of a Time object (``sec``/``nanosec`` or ``secs``/``nsecs``) or an int."""
    if hasattr(value, "sec"):
        return int(value.sec) * 1_000_000_000 + int(value.nanosec)
    if hasattr(value, "secs"):
        return int(value.secs) * 1_000_000_000 + int(value.nsecs)
    if isinstance(value, (int, np.integer)):
        return int(value)
    raise ConfigError(f"not a time stamp: {type(value).__name__}")
