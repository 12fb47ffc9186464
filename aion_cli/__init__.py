"""aion: 4D scene graphs (3D scene graphs with temporal flow dynamics) from robot logs.

The Python API (docs/API.md)::

    import aion_cli as aion
    m = aion.build(["run.mcap"], output="office.aion")
    table = m.predict("2026-11-23 08:30")
    plan = m.plan("p12", "p87", time="2026-11-23 08:30")
    week = aion.merge(["monday.aion", "wednesday.aion"], "week.aion")
"""

__version__ = "0.1.0"

from aion_cli.api import Map, Plan, Table, build, compact, merge, to_ns
from aion_cli.errors import AionError, AionWarning, InputError

__all__ = [
    "AionError",
    "AionWarning",
    "InputError",
    "Map",
    "Plan",
    "Table",
    "__version__",
    "build",
    "compact",
    "merge",
    "to_ns",
]
