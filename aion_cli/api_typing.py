"""The type variables of :class:`aion_cli.api.Map`: what made a map (its ``report``), so a
type checker knows ``aion.build(...).report`` is a ``BuildReport``, ``aion.merge(...)``'s a
``MergeReport``, ``aion.compact(...)``'s a ``CompactReport`` and ``Map.load(...)``'s None.

Why a module of its own: :mod:`aion_cli.api` holds the map and its queries; these are only
types (``typing_extensions`` for the type checker alone: ``TypeVar``'s default, PEP 696).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

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
