"""JSON and CSV text of records and reports (strict JSON: no NaN tokens).

Shared by the command line (``aion_cli.cli.output`` re-exports these) and the library layer
that writes files (``aion_cli.exports``), so neither needs the other.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from typing import Any


def clean(value: Any) -> Any:
    """JSON-safe copy: NaN/inf -> None, numpy scalars/arrays -> Python, tuples -> lists."""
    if isinstance(value, dict):
        return {str(k): clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [clean(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return clean(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def to_json(payload: Any) -> str:
    """Indented, strict JSON (no NaN tokens)."""
    return json.dumps(clean(payload), indent=2, allow_nan=False)


def to_csv(rows: Sequence[dict[str, Any]], keys: Sequence[str]) -> str:
    """CSV with a header; list values spread over ``key_i`` columns."""
    cleaned = [clean(row) for row in rows]
    header: list[str] = []
    for key in keys:
        width = max((len(r[key]) for r in cleaned if isinstance(r.get(key), list)), default=-1)
        header.extend([f"{key}_{i}" for i in range(width)] if width >= 0 else [key])
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    for row in cleaned:
        out: list[Any] = []
        for key in keys:
            value = row.get(key)
            if isinstance(value, list):
                out.extend("" if v is None else _csv_value(v) for v in value)
            else:
                out.append("" if value is None else _csv_value(value))
        writer.writerow(out)
    return buf.getvalue()


def _csv_value(value: Any) -> Any:
    if isinstance(value, float):
        return repr(round(value, 9) + 0.0)  # + 0.0: a value that rounds to -0.0 reads 0.0
    return value
