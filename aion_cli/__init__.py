"""aion: 4D scene graphs (3D scene graphs with temporal flow dynamics) from robot logs.

The Python API (docs/API.md)::

    import aion_cli as aion
    m = aion.build(["run.mcap"], output="office.aion")
    table = m.predict("2026-11-23 08:30")
    plan = m.plan("p12", "p87", time="2026-11-23 08:30")
    week = aion.merge(["monday.aion", "wednesday.aion"], "week.aion")
    report = aion.info(["run.mcap"])   # aion info LOG --format json, before a map is made
"""

__version__ = "0.1.0"

from typing import TYPE_CHECKING, Any

from aion_cli.api import Map, Plan, Table, build, compact, merge, to_ns
from aion_cli.api_info import info
from aion_cli.errors import AionError, AionWarning, InputError

if TYPE_CHECKING:
    from aion_cli.build_report import BuildReport
    from aion_cli.evaluation.holdout import HoldoutResult
    from aion_cli.manifest import Manifest
    from aion_cli.merge_report import MergeReport
    from aion_cli.prediction_series import SeriesTable
    from aion_cli.query_only import CompactReport

_LAZY = {
    "BuildReport": "aion_cli.build_report",
    "CompactReport": "aion_cli.query_only",
    "HoldoutResult": "aion_cli.evaluation.holdout",
    "Manifest": "aion_cli.manifest",
    "MergeReport": "aion_cli.merge_report",
    "SeriesTable": "aion_cli.prediction_series",
}
"""The API's other result types, each by the name its ``repr`` gives it (``<aion.BuildReport
...>``), to annotate with (``report: aion.BuildReport = aion.build(...).report``) and test
with ``isinstance``: ``Map.predict_series``' :class:`SeriesTable`, ``Map.report``'s
:class:`BuildReport`, :class:`MergeReport` and :class:`CompactReport`, ``Map.holdout``'s
:class:`HoldoutResult` and ``Map.manifest``'s :class:`Manifest`."""


def __getattr__(name: str) -> Any:
    """The names of :data:`_LAZY`, imported when first asked for: their modules bring numpy
    (and more), which ``import aion_cli`` does not need."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    """The package's names with those of :data:`_LAZY`, which ``dir(aion)`` and a notebook's
    tab completion (which calls it) would otherwise not offer until first used."""
    return sorted({*globals(), *_LAZY} - {"Any", "TYPE_CHECKING"})


__all__ = [
    "AionError",
    "AionWarning",
    "BuildReport",
    "CompactReport",
    "HoldoutResult",
    "InputError",
    "Manifest",
    "Map",
    "MergeReport",
    "Plan",
    "SeriesTable",
    "Table",
    "__version__",
    "build",
    "compact",
    "info",
    "merge",
    "to_ns",
]
