"""The Python API's arguments checked where they come in: a wrong type or value is an
:class:`~aion_cli.errors.InputError` naming the argument, never a ``TypeError`` or
``AttributeError`` from deep inside, and a plausible slip is read as meant (one node id as a
string, not its characters; a ``ZoneInfo`` as its name; ``(x, y)`` as a point).

Why a module of its own: :mod:`aion_cli.api` and :mod:`aion_cli.api_make` take the same kinds
of arguments (zones, node lists, counts, spans, times: :func:`to_ns`, which :mod:`aion_cli.api`
re-exports); one place reads them alike.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Iterable, Mapping, Sequence
from datetime import date, datetime, timedelta, tzinfo
from typing import TYPE_CHECKING, Any

# the API's argument types live in api_typing; importable from here as before (explicitly)
from aion_cli.api_typing import CountLike as CountLike
from aion_cli.api_typing import NodesLike as NodesLike
from aion_cli.api_typing import PairOf as PairOf
from aion_cli.api_typing import PlaceLike as PlaceLike
from aion_cli.api_typing import PointLike as PointLike
from aion_cli.api_typing import SpansLike as SpansLike
from aion_cli.api_typing import StepLike as StepLike
from aion_cli.api_typing import TimeLike as TimeLike
from aion_cli.api_typing import ZoneLike as ZoneLike
from aion_cli.errors import InputError

if TYPE_CHECKING:
    from typing_extensions import TypeIs  # typing's from Python 3.13


SECONDS_LIKE_NS = 10**16
"""Integer times are nanoseconds: below this (1970-04-26) one is far more likely UNIX seconds,
milliseconds or microseconds than a time of 1970's first months."""


def whole(value: object) -> TypeIs[numbers.Integral]:
    """Whether ``value`` is a whole number (Python's or numpy's, not a ``bool``): numpy
    registers its ``timedelta64`` with ``numbers.Integral`` too, which ``int()`` then refuses
    or reads as its count of units (a duration is no count, node id or time)."""
    return (
        isinstance(value, numbers.Integral)
        and not isinstance(value, bool)
        and type(value).__name__ != "timedelta64"
    )


def zone_name(tz: object, what: str = "tz") -> str | None:
    """``tz`` as a zone name: None, a name (``"Europe/London"``, ``"UTC+02:00"``), a
    ``zoneinfo.ZoneInfo`` (its key) or ``datetime.timezone.utc``."""
    if tz is None or isinstance(tz, str):
        return tz
    key = getattr(tz, "key", None)
    if isinstance(key, str):  # zoneinfo.ZoneInfo
        return key
    if isinstance(tz, tzinfo):
        offset = tz.utcoffset(None)
        if offset is not None and tz.dst(None) in (None, offset - offset):
            minutes = int(offset.total_seconds() // 60)
            if minutes == 0:
                return "UTC"
            sign = "+" if minutes > 0 else "-"
            return f"UTC{sign}{abs(minutes) // 60:02d}:{abs(minutes) % 60:02d}"
    raise InputError(
        f"{what} must be a zone name or a ZoneInfo, got {tz!r}",
        hint='e.g. "Europe/London", "UTC" or zoneinfo.ZoneInfo("Europe/London")',
    )


def node_list(nodes: object, what: str = "nodes") -> list[str | int]:
    """Node ids as a list: a single id (a string or an integer) is one node, not its
    characters; None is none."""
    if nodes is None:
        return []
    if isinstance(nodes, bytes | bytearray):  # not a list of integer node ids
        raise InputError(
            f"{what} must be node ids (text), got bytes {nodes!r}",
            hint=f"decode it: {what}={bytes(nodes).decode(errors='replace')!r}",
        )
    if isinstance(nodes, str) or whole(nodes):
        nodes = [nodes]
    if not hasattr(nodes, "__iter__"):
        raise InputError(
            f"{what} must be node ids (a list of them, or one), got {nodes!r}",
            hint=f'e.g. {what}="p12" or {what}=["p12", "kitchen"]',
        )
    out: list[str | int] = []
    for node in nodes:
        if not (isinstance(node, str) or whole(node)):
            raise InputError(
                f"{what}: {node!r} is not a node id",
                hint='node ids are strings such as "p12", "R2", "kitchen" or cell ids "c<key>"',
            )
        out.append(node if isinstance(node, str) else int(node))
    return out


def count(value: object, what: str, minimum: int = 1) -> int | None:
    """An optional whole number at least ``minimum`` (``top``, ``workers``)."""
    if value is None:
        return None
    if not whole(value):
        raise InputError(
            f"{what} must be a whole number, got {value!r}",
            hint=f"e.g. {what}={max(minimum, 2)} (an int, not a float or a string)",
        )
    if int(value) < minimum:
        raise InputError(
            f"{what} must be at least {minimum}, got {value}", hint=f"e.g. {what}={minimum}"
        )
    return int(value)


def real(value: object, what: str) -> float:
    """A finite real number."""
    if (
        isinstance(value, bool)
        or not isinstance(value, numbers.Real)
        or type(value).__name__ == "timedelta64"  # numpy's: an Integral to numbers, no float
    ):
        given = "a string" if isinstance(value, str) else f"a {type(value).__name__}"
        raise InputError(  # the hint had said "not a string" of True, None or a list too
            f"{what} must be a number, got {value!r}", hint=f"an int or a float, not {given}"
        )
    out = float(value)
    if not math.isfinite(out):
        raise InputError(f"{what} must be finite, got {value!r}", hint="no nan or inf")
    return out


def point(at: object, what: str = "at") -> str | None:
    """A point as the ``"x,y[,z]"`` text the CLI reads: text that is one, or 2 or 3 numbers."""
    from aion_cli.engine.node_ids import parse_point

    if at is None:
        return None
    if isinstance(at, str):  # checked here, to be named as the API names it (not --at)
        if parse_point(at) is None:
            raise _not_a_point(at, what)
        return at
    try:
        items = list(at)  # type: ignore[call-overload]
    except TypeError:
        items = []
    if len(items) not in (2, 3) or not all(isinstance(v, numbers.Real) for v in items):
        # not 2 or 3 numbers: an (n, 2) array of points, a pair of pairs
        raise _not_a_point(at, what)
    return ",".join(repr(real(v, what)) for v in items)


def _not_a_point(at: object, what: str) -> InputError:
    shape = getattr(at, "shape", None)
    got = f"an array of shape {shape}" if isinstance(shape, tuple) else repr(at)
    return InputError(
        f"{what} must be a point: \"x,y\" or 2 or 3 numbers, got {got}", hint=_point_hint(what)
    )


def _point_hint(what: str) -> str:
    """An example of a point given as ``what`` (``at``, a plan's ``start`` / ``goal``, one end
    of an export's or a picture's ``path``), in that argument's own form."""
    if what == "path":  # path=(start, goal): the point is one of the two
        return 'e.g. path=((3.5, -1.0), "p2") or path=("3.5,-1.0", "p2")'
    return f'e.g. {what}=(3.5, -1.0) or {what}="3.5,-1.0"'


def pair(value: object, what: str, names: str) -> tuple[Any, Any]:
    """Exactly two items (``leave=(earliest, latest)``, ``path=(start, goal)``)."""
    if isinstance(value, str) or not isinstance(value, Sequence) or len(value) != 2:
        raise InputError(
            f"{what} must be two items ({names}), got {value!r}",
            hint=f"a tuple or a list of two: ({names})",
        )
    return value[0], value[1]


def spans(observed: object, what: str = "observed") -> list[tuple[Any, Any]]:
    """``(start, end)`` pairs: a list of them (or any iterable of them, a generator
    included), one pair, or a numpy array of shape ``(2,)`` or ``(n, 2)`` (rows as pairs:
    ``datetime64`` times, nanoseconds or text, as the times themselves)."""
    if observed is None:
        return []
    import numpy as np

    if isinstance(observed, np.ndarray):
        if observed.ndim not in (1, 2) or observed.shape[-1] != 2:
            raise InputError(
                f"{what} as an array must be of shape (2,) or (n, 2): (start, end) rows, "
                f"got shape {observed.shape}",
                hint='e.g. observed=np.array([["2026-01-06 08:00", "2026-01-06 18:00"]])',
            )
        rows = list(observed) if observed.ndim == 2 else [observed]
        observed = [tuple(row.tolist() if row.dtype.kind in "iuU" else row) for row in rows]
    elif isinstance(observed, Iterable) and not isinstance(observed, str | bytes | Sequence
                                                            | set | frozenset | Mapping):
        observed = list(observed)  # a generator or another one-pass iterable: read once
    if isinstance(observed, str) or not isinstance(observed, Sequence):
        raise InputError(
            f"{what} must be (start, end) pairs, got {observed!r}",
            hint='e.g. observed=[("2026-01-06 08:00", "2026-01-06 18:00")]',
        )
    if len(observed) == 2 and not any(isinstance(v, Sequence | set) and not isinstance(
        v, str) for v in observed):
        observed = [observed]  # one span given alone
    return [pair(span, f"{what} span", "start, end") for span in observed]


def time_value(time: object) -> object:
    """A time argument checked for what :func:`to_ns` cannot read or would read
    wrongly: integers are nanoseconds, so one below :data:`SECONDS_LIKE_NS` is refused."""
    if isinstance(time, bool):
        raise InputError(
            f"not a time: {time!r}",
            hint='a string ("2026-01-12 08:30", "now"), a datetime or UNIX nanoseconds',
        )
    if isinstance(time, timedelta) or type(time).__name__ == "timedelta64":
        # a duration, not a time (numpy's is an Integral to numbers, which int() refuses)
        raise InputError(
            f"not a time: {time!r} (a duration)",
            hint='a time relative to now is text: "+2h", "-30m"',
        )
    if isinstance(time, numbers.Integral):
        value = int(time)
        if -SECONDS_LIKE_NS < value < SECONDS_LIKE_NS:
            raise InputError(
                f"{value} is read as nanoseconds since 1970, i.e. within 1970's first "
                "four months",
                hint=f"UNIX seconds: give {value} * 10**9, or the string \"{value}\"",
            )
        return value
    if isinstance(time, numbers.Real) and math.isfinite(time):
        number = float(time)
        if abs(number) >= SECONDS_LIKE_NS:  # nanoseconds as a float (a column's mean ...)
            hint = f"nanoseconds as a float: give round({number!r}), an int"
        else:  # time.time(): UNIX seconds
            hint = (
                f"UNIX seconds: give datetime.fromtimestamp({number!r}, timezone.utc), "
                f"or round({number!r} * 10**9) nanoseconds"
            )
        raise InputError(
            f"not a time: {time!r} (a float; integer times are nanoseconds)", hint=hint
        )
    if isinstance(time, datetime) and time != time:  # pandas' NaT, a datetime equal to nothing
        raise InputError(f"not a time: {time!r}", hint="NaT marks a missing time")
    if isinstance(time, str | datetime):
        return time
    if isinstance(time, date):  # a day alone: its midnight in the zone, as "2026-01-12" reads
        return time.isoformat()
    raise InputError(
        f"not a time: {time!r}",
        hint="a time string, a datetime, a numpy.datetime64 or integer nanoseconds",
    )


def path_text(value: object, what: str) -> str:
    """A path argument's text: ``str`` or ``os.PathLike``, not empty (an ``aion.Map`` given
    for its file is refused with the way to its file)."""
    if not isinstance(value, str | os.PathLike):
        from aion_cli.api import Map
        from aion_cli.api_results import MEMORY

        if isinstance(value, Map):  # aion.merge([m1, m2], ...): the maps' files are meant
            given = f"the aion.Map {value.path or MEMORY}"  # (its repr reads its state)
            hint = (
                "give the map's file: its .path" if value.path is not None
                else "a map in memory has no file: save it first (.save(path) returns the file)"
            )
        else:
            given, hint = repr(value), 'e.g. "office.aion" or pathlib.Path("office.aion")'
        raise InputError(f"{what} must be a path (str or pathlib.Path), got {given}", hint=hint)
    text = os.fspath(value)
    if isinstance(text, bytes):
        raise InputError(
            f"{what} must be a text path, got bytes {value!r}",
            hint=f"decode it: {os.fsdecode(text)!r}",
        )
    return text


def path_list(value: object, what: str, one: bool = True) -> list[object]:
    """A list of paths (``logs``, the maps of a merge): a list, tuple or other iterable of
    them, or one path alone when ``one``; not bytes (their items are numbers) or None. The
    items are checked where they are read (:func:`path_text`)."""
    if one and isinstance(value, str | os.PathLike):
        return [value]
    if (
        value is None
        or isinstance(value, str | bytes | bytearray | os.PathLike)
        or not hasattr(value, "__iter__")
    ):
        noun = "a path or a list of paths" if one else "a list of paths"
        raise InputError(
            f"{what} must be {noun}, got {value!r}",
            hint=f'e.g. {what}=["monday.aion", "wednesday.aion"]'
            if not one
            else f'e.g. {what}="monday.mcap" or {what}=["monday.mcap", "tuesday.mcap"]',
        )
    return list(value)


def selection(
    nodes: object, at: object, top: object
) -> tuple[list[str | int], str | None, int | None]:
    """``nodes``, ``at`` and ``top`` of a query, checked (one node id given alone is one
    node; ``at`` as text or numbers); nodes and a point at once are refused (the point would
    be ignored), and so is an empty list of nodes (None is every entry)."""
    wanted = node_list(nodes)
    if nodes is not None and not wanted:  # a filtered list that came out empty, not "all"
        raise InputError(
            "nodes is empty: it names no entry",
            hint="leave nodes out (or None) for every entry",
        )
    where = point(at)
    if wanted and where is not None:
        raise InputError(
            "choose nodes or at, not both",
            hint="at=(x, y) gives the entry nearest the point; nodes= names entries",
        )
    return wanted, where, count(top, "top")


def step(value: object, what: str = "step") -> str | float:
    """A series step (or another duration, ``what``: ``graph_period``): text (``"10m"``),
    seconds or a ``timedelta`` or ``numpy.timedelta64`` (its seconds)."""
    if isinstance(value, str):
        return value
    if isinstance(value, timedelta):
        return value.total_seconds()
    if type(value).__name__ == "timedelta64":  # numpy's: an Integral to numbers, not a float
        import numpy as np

        try:
            return real(float(value / np.timedelta64(1, "s")), what)  # type: ignore[operator]
        except (TypeError, ValueError) as exc:  # months and years have no length in seconds
            raise InputError(
                f"{what} must be a duration, got {value!r}",
                hint=f'a unit of weeks or shorter, e.g. {what}=np.timedelta64(30, "m")'
                + (', or "1w"' if what == "step" else ""),
            ) from exc
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(
            f"{what} must be a duration, got {value!r}",
            hint=f'e.g. {what}="30m", "1h", '
            + ('"1d", ' if what == "step" else "")
            + "600 (seconds) or datetime.timedelta(minutes=30)",
        )
    return real(value, what)


def historical(time: object, value: object) -> bool:
    """``historical=`` of a query, refused beside a ``time`` (which it would ignore)."""
    wanted = flag(value, "historical")
    if wanted and time is not None:
        raise InputError(
            "choose time or historical=True, not both",
            hint="historical=True is what was observed, at no time: leave out time",
        )
    return wanted


def text(value: object, what: str) -> str | None:
    """An optional name (a frame, a topic, a log format, an address): None or a string; a
    layer key given as an integer (``nav_layer=3``) is its text."""
    if value is None or isinstance(value, str):
        return value
    if what == "nav_layer" and whole(value):
        return str(int(value))
    raise InputError(
        f"{what} must be a string, got {value!r}", hint=f'e.g. {what}="{_EXAMPLES.get(what, "")}"'
    )


_EXAMPLES = {
    "map_frame": "map", "base_frame": "base_link", "graph_topic": "/hydra/backend/dsg",
    "log_format": "mcap", "nav_layer": "PLACES", "scheduler": "tcp://10.0.0.5:8786",
}  # fmt: skip


def flag(value: object, what: str) -> bool:
    """A yes or no: ``True`` / ``False`` (numpy's too), not any value Python finds true (a
    string "no" would be)."""
    if isinstance(value, bool):
        return value
    if type(value).__module__ == "numpy":  # numpy.bool (numpy 2's name; bool_ before)
        import numpy as np

        if isinstance(value, np.bool_):
            return bool(value)
    raise InputError(f"{what} must be True or False, got {value!r}", hint=f"e.g. {what}=True")


def endpoint(node: object, what: str) -> str | int:
    """A plan's end: a node id, room or name, or ``"x,y"`` (numbers: a point)."""
    if isinstance(node, str):
        return node
    if isinstance(node, bool) or node is None:
        raise InputError(
            f"{what} must be a node id, a room name or a point, got {node!r}",
            hint='e.g. "p12", "kitchen", "3.5,-1.0" or (3.5, -1.0)',
        )
    if whole(node):
        if not 0 <= int(node) < 1 << 64:  # node ids are uint64
            raise InputError(
                f"{what} must be a node id (0 .. 2**64 - 1), a room name or a point, "
                f"got {node!r}",
                hint=f'a place\'s id ("p12") or NodeSymbol value; a point: {_point_hint(what)}',
            )
        return int(node)
    where = point(node, what)
    assert where is not None
    return where
