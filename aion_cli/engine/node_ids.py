"""Node ids as users see them ("p12") and coordinates they type ("3.5,-1,0"): the one place
that formats and parses them (the CLI, the Python API, planning messages and the scene-graph
reader all use it).

Node ids are spark_dsg NodeSymbol values: ``(ord(category) << 56) | index``; the label is
spark_dsg's short form ``NodeSymbol.str()`` (``p12``; its long form is ``p(12)``, which
:func:`parse_node_id` accepts too).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aion_cli.errors import InputError

# p12 or p(12), balanced; ASCII digits only ("p٣" is not p3)
_RE_SYMBOL = re.compile(r"^([A-Za-z])(?:(\d+)|\((\d+)\))$", re.ASCII)
INDEX_BITS = 56
INDEX_MASK = (1 << INDEX_BITS) - 1
MAX_NODE_ID = (1 << 64) - 1
"""Node ids are uint64 (spark_dsg NodeSymbol values)."""


def node_label(node_id: int) -> str:
    """``(ord('p') << 56) | 12`` -> ``"p12"``; ids without a printable category stay numeric."""
    value = int(node_id)
    category = value >> 56
    if 33 <= category < 127:
        return f"{chr(category)}{value & INDEX_MASK}"
    return str(value)


def other_case(node_id: int) -> int | None:
    """``node_id`` with its category letter in the other case (``P103`` -> ``p103``, for a
    "did you mean"); None for an id whose category is no ASCII letter."""
    value = int(node_id)
    letter = chr(value >> INDEX_BITS)
    if not (letter.isascii() and letter.isalpha()):
        return None
    return (ord(letter.swapcase()) << INDEX_BITS) | (value & INDEX_MASK)


def parse_node_id(text: str) -> int:
    """``"p12"`` / ``"p(12)"`` / a raw integer id -> the NodeSymbol value."""
    token = text.strip()
    match = _RE_SYMBOL.match(token)
    if match:
        index = int(match.group(2) or match.group(3))
        if index > INDEX_MASK:
            raise InputError(
                f"node index too large in {text!r} (at most {INDEX_MASK})",
                'node ids look like "p12" (see `aion predict MAP`)',
            )
        return (ord(match.group(1)) << 56) | index
    if token.isascii() and token.isdigit():  # not "²", which isdigit() but int() refuses
        value = int(token)
        if value > MAX_NODE_ID:
            raise InputError(
                f"node id too large in {text!r}: ids are 64-bit (at most {MAX_NODE_ID})",
                'node ids look like "p12" (see `aion predict MAP`)',
            )
        return value
    raise InputError(
        f"not a node id: {text!r}", 'node ids look like "p12" (see `aion predict MAP`)'
    )


def parse_point(text: str) -> tuple[float, float, float] | None:
    """``"x,y"`` or ``"x,y,z"`` -> a point; None if ``text`` is not one. z is NaN when
    omitted: distances from such a point are horizontal (:func:`point_distance`,
    ``nearest.distances_from``), so a typed x,y finds the place above or below it, not the
    one nearest to height 0."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (2, 3):
        return None
    try:
        values = [float(p) for p in parts]
    except ValueError:
        return None
    if not all(math.isfinite(v) for v in values):
        raise InputError(
            f"coordinates must be finite numbers: {text!r}",
            "give metres in the map frame, x,y or x,y,z (e.g. 3.5,-1.2)",
        )
    if len(values) == 2:
        values.append(math.nan)
    return (values[0], values[1], values[2])


def point_distance(xyz: tuple[float, ...], point: tuple[float, float, float]) -> float:
    """Distance from a typed ``point`` to ``xyz``: horizontal when the point has no z."""
    if math.isnan(point[2]):
        return math.dist(xyz[:2], point[:2])
    return math.dist(xyz[:3], point)


def shown_point(point: tuple[float, float, float]) -> list[float]:
    """A typed point as reports show it: [x, y] when no z was given, else [x, y, z]."""
    return list(point[:2]) if math.isnan(point[2]) else list(point)


def point_text(shown: Sequence[float]) -> str:
    """A point as :func:`shown_point` lists it, in the words it is typed in: ``1,2`` for
    ``[1.0, 2.0]``, ``0.1,-3,1.5`` (for notes and errors, not a Python list)."""
    return ",".join(f"{float(v):.15g}" for v in shown)


def require_point(text: str, option: str) -> tuple[float, float, float]:
    """Like :func:`parse_point` but an :class:`InputError` naming ``option`` when invalid."""
    point = parse_point(text)
    if point is None:
        raise InputError(
            f"{option} expects coordinates x,y[,z], got {text!r}", f'e.g. {option} "3.5,-1.0"'
        )
    return point


_NUMBER_RUN = re.compile(r"[\s,;]+")


def refuse_malformed_point(text: str) -> None:
    """:class:`InputError` when ``text``, which :func:`parse_point` did not read, was meant as
    coordinates: it has a comma, or is two or more numbers (``1,2,3,4``, ``(1,2)``, ``1 2``,
    ``[0.0, 0.0]`` as a plan's JSON prints a point); a place id or a name passes. Said as a
    point's error, not as "not a node id", where a place, room or point is accepted."""
    inner = text.strip().strip("()[]")
    parts = [p for p in _NUMBER_RUN.split(inner) if p]
    numbers = 0
    for part in parts:
        try:
            float(part)
        except ValueError:
            break
        numbers += 1
    meant = "," in text or (numbers == len(parts) and numbers >= 2)
    if not meant:
        return
    counted = f" ({numbers} numbers)" if numbers == len(parts) and numbers > 3 else ""
    raise InputError(
        f"not a point x,y or x,y,z{counted}, nor a place or room: {text!r}",
        hint="a point is 2 or 3 numbers in metres joined by commas, without brackets "
        '(e.g. 3.5,-1.2 or 3.5,-1.2,0.8); a place by its id ("p12")',
    )


FAR_POINT_M = 10.0
"""A typed point may lie this far from every entry, or as far as the entries span if that is
more, and still stand for the nearest one; farther, it is refused (a point in another frame or
unit, answered with the nearest entry at the map's edge, would answer a question nobody
asked)."""


def refuse_far_point(
    text: str, distance: float, nearest: str, xyz: npt.ArrayLike, what: str = "place"
) -> None:
    """:class:`InputError` when the point ``text`` lies ``distance`` metres from the nearest
    of the positions ``xyz`` (the ``what`` labelled ``nearest``), farther than
    :data:`FAR_POINT_M` and than the positions span (``plan --from/--to``, ``predict --at``)."""
    points = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    span = float(np.linalg.norm(np.ptp(points, axis=0))) if len(points) else 0.0
    if distance > max(FAR_POINT_M, span):
        # a number of a typo's size reads as one, not as 300 digits
        far = f"{distance:,.0f}" if distance < 1e9 else f"{distance:.3g}"
        # the limit said is the one applied: a map of one entry spans 0 m, and a point 5 m
        # from it is taken, so "farther than ... (0 m)" would misstate why 27 m is not
        limit = (
            f"the whole map spans ({span:,.0f} m)"
            if span >= FAR_POINT_M
            else f"{FAR_POINT_M:,.0f} m, more than the whole map spans ({span:,.0f} m)"
        )
        raise InputError(
            f"the point {text} is {far} m from the nearest {what} ({nearest}), "
            f"farther than {limit}: coordinates in another frame or unit?",
            hint="give map-frame coordinates in metres",
        )


def node_labels(node_ids: npt.ArrayLike) -> npt.NDArray[np.str_]:
    """:func:`node_label` of many ids at once, with numpy (``["p12", "R3", ...]``): one
    string operation per array, not a Python call per id."""
    ids = np.asarray(node_ids, dtype=np.uint64).reshape(-1)
    category = ids >> np.uint64(INDEX_BITS)
    printable = (category >= 33) & (category < 127)
    chars = np.frombuffer(
        np.where(printable, category, ord("?")).astype(np.uint8).tobytes(), dtype="S1"
    ).astype(str)
    index = (ids & np.uint64(INDEX_MASK)).astype(str)
    out: npt.NDArray[np.str_] = np.where(printable, np.char.add(chars, index), ids.astype(str))
    return out
