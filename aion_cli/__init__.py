"""aion: 4D scene graphs (3D scene graphs with temporal flow dynamics) from robot logs.

The Python API (docs/API.md)::

    import aion_cli as aion
    m = aion.build(["run.mcap"], output="office.aion")
    table = m.predict("2026-11-23 08:30")
    plan = m.plan("p12", "p87", time="2026-11-23 08:30")
    week = aion.merge(["monday.aion", "wednesday.aion"], "week.aion")
"""

__version__ = "0.1.0"

from typing import TYPE_CHECKING, Any

from aion_cli.api import Map, Plan, Table, build, compact, merge, to_ns
from aion_cli.errors import AionError, AionWarning, InputError

if TYPE_CHECKING:
    from aion_cli.prediction_series import SeriesTable


def __getattr__(name: str) -> Any:
    """``aion.SeriesTable`` (what ``Map.predict_series`` returns), imported when first asked
    for: its module brings numpy, which ``import aion_cli`` does not need."""
    if name == "SeriesTable":
        from aion_cli.prediction_series import SeriesTable

        return SeriesTable
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "AionError",
    "AionWarning",
    "InputError",
    "Map",
    "Plan",
    "SeriesTable",
    "Table",
    "__version__",
    "build",
    "compact",
    "merge",
    "to_ns",
]
