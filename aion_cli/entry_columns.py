"""The records of ``aion predict`` as columns: one array per field, rows in output order.

``aion predict --format json|csv`` and ``aion export``'s ``entries.json`` / ``entries.csv``
print every entry of a map (10^5 and more). A dict per entry, cleaned and fed to Python's
JSON encoder, cost ~9 s there; these columns are computed on arrays and written as text by
:mod:`aion_cli.entry_text` without a dict per entry. :meth:`EntryColumns.records` gives the
dicts (``aion_cli.predictions.rows_from_table``, the Python API, the table a terminal shows),
equal to those the per-entry code made, which ``tests/cli/test_entry_text.py`` keeps as the
reference. Field meanings are documented in :mod:`aion_cli.predictions`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.grouping import distinct
from aion_cli.predictions import entry_ids, kind_label

F64 = npt.NDArray[np.float64]
Obj = npt.NDArray[np.object_]

#: the fields of a record, in the order of its dict (and of the JSON entries)
RECORD_KEYS = (
    "id", "name", "kind", "layer", "x", "y", "z", "flow", "flow_per_hour", "flow_p10",
    "flow_p90", "direction_deg", "direction_bin", "concentration", "entropy", "mean_speed",
    "histogram", "speed_per_bin", "family", "direction_family",
)

#: float fields a record holds as None where not finite (x, y, z and the histogram keep NaN)
FINITE_OR_NONE = frozenset({
    "flow", "flow_per_hour", "flow_p10", "flow_p90", "direction_deg", "concentration",
    "entropy", "mean_speed", "speed_per_bin",
})


@dataclass(frozen=True)
class EntryColumns:
    """Per field an array over the rows: ``text`` str / None fields (object arrays),
    ``floats`` float64 fields ([n] or [n, B] for ``histogram`` and ``speed_per_bin``; NaN
    where unknown), ``direction_bin`` int64."""

    text: dict[str, Obj]
    floats: dict[str, F64]
    direction_bin: npt.NDArray[np.int64]

    def __len__(self) -> int:
        return len(self.direction_bin)

    def column(self, key: str) -> Any:
        """The array of field ``key``."""
        if key == "direction_bin":
            return self.direction_bin
        return self.text[key] if key in self.text else self.floats[key]

    def take(self, rows: Any) -> EntryColumns:
        """The rows ``rows`` (a slice or an index array) of every column."""
        return EntryColumns(
            {k: v[rows] for k, v in self.text.items()},
            {k: v[rows] for k, v in self.floats.items()},
            self.direction_bin[rows],
        )

    def records(self, keys: tuple[str, ...] = RECORD_KEYS) -> list[dict[str, Any]]:
        """One dict per row with the fields ``keys``, Python values as the per-entry code
        made them (float, int, str, None; lists for the histograms)."""
        lists = [_python_values(key, self.column(key)) for key in keys]
        return [dict(zip(keys, values, strict=True)) for values in zip(*lists, strict=True)]


def _python_values(key: str, values: Any) -> list[Any]:
    """The column ``key`` as a list of Python values: NaN as None for the fields of
    :data:`FINITE_OR_NONE`, rows of a 2-D column as lists."""
    if values.dtype == object or key not in FINITE_OR_NONE:
        return list(values.tolist())
    out = values.astype(object)
    out[~np.isfinite(values)] = None
    return list(out.tolist())


def entry_columns(
    table: Any, index: Any = None, names: Mapping[str, str] | None = None
) -> EntryColumns:
    """The columns of an engine ``EntryTable`` for the rows ``index`` (row numbers, in that
    order; default every row), computed for those rows only: the descriptors and count
    quantiles of ten rows for ``--top 10``. ``names``: the graph's names of rooms and
    buildings by id ("R2": "kitchen"), the rows' ``name`` (None for the rest)."""
    from aion_cli.engine.temporal.quantiles import count_quantiles

    picked = np.arange(len(table.xyz)) if index is None else np.asarray(index, dtype=np.int64)
    # every row: the table's own (cached, shared with a scene export); else those returned
    d = table.descriptors if index is None else table.descriptors_of(picked)
    flow, var = np.asarray(table.flow)[picked], np.asarray(table.flow_var)[picked]
    ids = _as_str(entry_ids(table, picked))
    lookup = names or {}
    kind = _labels(np.asarray(table.kind)[picked], kind_label)
    angle = np.asarray(d.dominant_angle, dtype=np.float64)
    xyz = np.asarray(table.xyz, dtype=np.float64)[picked]
    probabilities = np.asarray(d.probabilities, dtype=np.float64)
    speeds = np.asarray(d.mean_speed, dtype=np.float64)
    floats = {
        "x": xyz[:, 0].copy(),
        "y": xyz[:, 1].copy(),
        "z": xyz[:, 2].copy(),
        "flow": np.asarray(d.flow_per_window, dtype=np.float64),
        "flow_per_hour": np.asarray(d.flow_per_hour, dtype=np.float64),
        "flow_p10": np.asarray(count_quantiles(flow, var, 0.1), dtype=np.float64),
        "flow_p90": np.asarray(count_quantiles(flow, var, 0.9), dtype=np.float64),
        "direction_deg": np.where(np.isfinite(angle), np.degrees(angle), np.nan),
        "concentration": np.asarray(d.concentration, dtype=np.float64),
        "entropy": np.asarray(d.entropy, dtype=np.float64),
        "mean_speed": mean_speed(probabilities, speeds),
        "histogram": probabilities,
        "speed_per_bin": speeds,
    }
    name_values = np.empty(len(picked), dtype=object)
    if lookup:
        name_values[:] = list(map(lookup.get, ids.tolist()))
    text = {
        "id": ids,
        "name": name_values,
        "kind": kind,
        "layer": _labels(np.asarray(table.layer)[picked], str),
        "family": _labels(np.asarray(table.flow_family)[picked], str),
        "direction_family": _labels(np.asarray(table.direction_family)[picked], str),
    }
    bins = np.asarray(d.dominant_bin).astype(np.int64).reshape(len(picked))
    return EntryColumns(text, floats, bins)


def mean_speed(probabilities: F64, speeds: F64) -> F64:
    """Per row, the probability-weighted mean of the bins' speeds over the bins with a known
    speed and some probability (NaN where there is none), summed as ``numpy`` sums the 1-D
    array of those bins alone, so the value is the per-row code's to the last bit: each row's
    known bins are moved to its front and the rows with k known bins summed over their first
    k columns (at most B + 1 groups)."""
    known = np.isfinite(speeds) & (probabilities > 0)
    count = known.sum(axis=1)
    front = np.argsort(~known, axis=1, kind="stable")  # known bins first, in bin order
    weighted = np.take_along_axis(np.where(known, speeds, 0.0) * probabilities, front, axis=1)
    weights = np.take_along_axis(np.where(known, probabilities, 0.0), front, axis=1)
    out = np.full(len(probabilities), np.nan)
    # distinct counts, as np.unique (whose first call imports numpy.ma: 10-30 ms a query)
    for k in distinct(count[count > 0].astype(np.int64)).tolist():
        rows = np.flatnonzero(count == k)
        top = np.ascontiguousarray(weighted[rows, :k]).sum(axis=1)
        bottom = np.ascontiguousarray(weights[rows, :k]).sum(axis=1)
        out[rows] = top / bottom
    return out


def _labels(values: Any, label: Any) -> Obj:
    """``label(v)`` of every value, computed once per distinct value (a layer, a kind, a
    family: a handful over 10^5 rows)."""
    flat = np.asarray(values).reshape(-1)
    out = np.empty(flat.size, dtype=object)
    if flat.size == 0:
        return out
    distinct, inverse = np.unique(flat, return_inverse=True)
    labelled = np.empty(distinct.size, dtype=object)
    labelled[:] = [label(v) for v in distinct.tolist()]
    out[:] = labelled[inverse.reshape(-1)]
    return out


def _as_str(values: Any) -> Obj:
    """The values as an object array of Python ``str``."""
    flat = np.asarray(values).reshape(-1)
    out = np.empty(flat.size, dtype=object)
    out[:] = flat.astype(str).tolist()
    return out
