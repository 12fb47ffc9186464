"""The Python API's types: what its arguments may be (:data:`TimeLike`, :data:`ZoneLike`,
:data:`NodesLike` ..., read by :mod:`aion_cli.api_checks`) and the type variable of
:class:`aion_cli.api.Map`: what made a map (its ``report``), so a type checker knows
``aion.build(...).report`` is a ``BuildReport``, ``aion.merge(...)``'s a ``MergeReport``,
``aion.compact(...)``'s a ``CompactReport`` and ``Map.load(...)``'s None.

Why a module of its own: :mod:`aion_cli.api` holds the map and its queries and
:mod:`aion_cli.api_checks` reads the arguments; these are only types (``typing_extensions``
for the type checker alone: ``TypeVar``'s default, PEP 696).
"""

from __future__ import annotations

import typing
from collections.abc import Iterable, Sequence
from datetime import date, datetime, timedelta, tzinfo
from typing import TYPE_CHECKING, Any, Union

if TYPE_CHECKING:
    import numpy as np

_T = typing.TypeVar("_T")

TimeLike = Union[str, int, datetime, date, "np.datetime64", "np.integer[Any]"]
"""A time argument: an aion time string, a ``datetime``, a ``date`` (its midnight, as the text
``"2026-01-12"``), a ``numpy.datetime64`` (its wall-clock time, as a naive ``datetime``) or
integer UNIX nanoseconds, Python's or numpy's (:func:`aion_cli.api_time.to_ns` reads it)."""

StepLike = Union[str, float, timedelta, "np.timedelta64"]
"""A series or departure step: ``"30m"``, ``"1d"``, seconds, a ``timedelta`` or a
``numpy.timedelta64`` (:func:`aion_cli.api_checks.step` reads it)."""

ZoneLike = str | tzinfo
"""A zone argument (``tz``): a name (``"Europe/London"``, ``"UTC+02:00"``), a
``zoneinfo.ZoneInfo`` or a fixed-offset ``datetime.timezone``
(:func:`aion_cli.api_checks.zone_name` reads it)."""

PointLike = Union[str, Sequence[float], "np.ndarray[Any, Any]"]
"""A point (``at=``): ``"x,y[,z]"``, or 2 or 3 numbers in a sequence or a numpy array (a pose's
``[:2]``)."""

PlaceLike = Union[str, int, Sequence[float], "np.ndarray[Any, Any]"]
"""A plan's start or goal (``Map.plan``, ``path=``): a node id (``"p12"``, its integer
NodeSymbol), a room or building by id or name, or a point (``"x,y[,z]"`` or 2 or 3 numbers,
a numpy array too)."""

PairOf = tuple[_T, _T] | list[_T]
"""Two items (``leave=(earliest, latest)``, ``path=(start, goal)``, an ``observed`` span): a
tuple or a list of two (:func:`aion_cli.api_checks.pair` reads it)."""

NodesLike = str | int | Iterable[str | int]
"""Entries asked for (``nodes=``): one id or name, or any iterable of them (a list, a set, a
numpy array of ids, a generator; :func:`aion_cli.api_checks.node_list` reads it)."""

CountLike = Union[int, "np.integer[Any]"]
"""A whole number (``top``, ``workers``, ``batch_size``): Python's or numpy's
(:func:`aion_cli.api_checks.count`)."""

SpansLike = Sequence[PairOf[TimeLike]] | tuple[TimeLike, TimeLike] | Iterable[PairOf[TimeLike]]
"""``observed`` spans: ``(start, end)`` pairs (any iterable of them, or a numpy array of shape
``(n, 2)`` or ``(2,)``), or one ``(start, end)`` alone (:func:`aion_cli.api_checks.spans`
reads it, a list of two too; typed as a tuple so that a list of lists stays a list of
spans)."""

if TYPE_CHECKING:  # typing_extensions only for the type checker (TypeVar's default, PEP 696)
    from typing_extensions import TypeVar

    from aion_cli.build_report import BuildReport
    from aion_cli.merging import MergeReport
    from aion_cli.query_only import CompactReport

    Report = TypeVar(
        "Report",
        bound="BuildReport | MergeReport | CompactReport | None",
        default="BuildReport | MergeReport | CompactReport | None",
        covariant=True,
    )
else:
    from typing import TypeVar

    Report = TypeVar("Report", covariant=True)

Made = TypeVar("Made", bound="BuildReport | MergeReport | CompactReport | None")
"""What made a map read by :func:`aion_cli.api.read_map`: a report, or None."""
