"""How entry records (``aion_cli.predictions``) look in a terminal table: the columns of
``aion predict`` and the direction histogram drawn as a sparkline."""

from __future__ import annotations

import math
from typing import Any

from aion_cli.cli.output import Column, degrees, num, small_num

COLUMNS = [
    Column("id", "id", justify="left"),
    Column("kind", "kind", justify="left"),
    Column("x", "x", num(2)),
    Column("y", "y", num(2)),
    Column("z", "z", num(2)),
    Column("flow", "flow/win", small_num),  # a quiet place reads 0.0031, not 0.00
    Column("direction_deg", "dir", lambda v: degrees(math.radians(v)) if v is not None else "-"),
    Column("entropy", "entropy", num(2)),
    Column("concentration", "conc.", num(2)),
    Column("mean_speed", "m/s", num(2)),
    Column("histogram", "histogram", lambda h: _spark(h), justify="left"),
    Column("family", "model", justify="left"),
]
_BARS = " ▁▂▃▄▅▆▇█"


def _spark(hist: Any) -> str:
    if not hist:
        return ""
    values = [0.0 if v is None else float(v) for v in hist]
    top = max(values) or 1.0
    return "".join(_BARS[min(round(v / top * 8), 8)] for v in values)
