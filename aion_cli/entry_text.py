"""The JSON and CSV text of ``aion predict`` (one time and a series) and of ``aion export``'s
``entries.json`` / ``entries.csv``, written from columns in chunks
(:mod:`aion_cli.formats.record_text`): the bytes ``serialize.to_json`` / ``to_csv`` of the
records make, without a dict per entry (9.3 s and 1.3 GB for 10^5 entries that way).

Chunks are strings to write one after the other (``click.echo(chunk, nl=False)``, or a
file's ``writelines``); a JSON document's text has no final newline, as ``to_json``'s.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.entry_columns import RECORD_KEYS, EntryColumns
from aion_cli.formats import record_text as rt

if TYPE_CHECKING:
    from aion_cli.prediction_series import SeriesTable

#: tokens turned into text at a time (a block of records holds about this many values)
BLOCK_TOKENS = 1 << 17


def _block(per_record: int) -> int:
    return max(1, BLOCK_TOKENS // max(1, per_record))


def _json_tokens(columns: EntryColumns, key: str, a: int, b: int) -> Any:
    values = columns.column(key)[a:b]
    if key in columns.text:
        return rt.json_strings(values)
    if key == "direction_bin":
        return rt.json_ints(values)
    return rt.json_floats(values)


def _csv_cells(columns: EntryColumns, key: str, rows: Any) -> Any:
    values = columns.column(key)[rows]
    if key in columns.text:
        return rt.csv_strings(values)
    if key == "direction_bin":
        return rt.csv_ints(values)
    return rt.csv_floats(values)


def _bins(columns: EntryColumns) -> int:
    return int(columns.floats["histogram"].shape[1])


def predict_json(doc: dict[str, Any], columns: EntryColumns) -> Iterator[str]:
    """``to_json(doc)`` with ``doc["entries"]`` the records of ``columns`` (``doc`` from
    :func:`aion_cli.predictions.document`, its entries empty)."""

    def fields(a: int, b: int) -> rt.Fields:
        return [(key, _json_tokens(columns, key, a, b)) for key in RECORD_KEYS]

    per_record = len(RECORD_KEYS) + 2 * _bins(columns)
    entries = rt.json_object_list(len(columns), fields, pad=2, block=_block(per_record))
    return rt.json_document(doc, "entries", entries)


def predict_csv(
    columns: EntryColumns, keys: Sequence[str], hour_observed: bool | None = None
) -> Iterator[str]:
    """``to_csv(records, keys)`` of the records of ``columns``, each with the time's
    ``hour_observed`` (:func:`aion_cli.predictions.observed_text` of it: the same cell on
    every row) where ``keys`` holds that column."""
    from aion_cli.predictions import observed_text

    n = len(columns)
    widths = {k: int(columns.floats[k].shape[1]) for k in keys if _is_list(columns, k) and n}
    yield rt.csv_header(keys, widths)
    seen = rt.csv_strings(rt.object_array([observed_text(hour_observed)]))[0]

    def cells(a: int, b: int) -> list[Any]:
        return [
            np.full(b - a, seen, dtype=object)
            if k == "hour_observed"
            else _csv_cells(columns, k, slice(a, b))
            for k in keys
        ]

    per_record = len(keys) + _bins(columns)
    yield from rt.csv_rows(n, cells, _block(per_record))


def _is_list(columns: EntryColumns, key: str) -> bool:
    return key in columns.floats and columns.floats[key].ndim == 2


#: the fields of a series' entries before their flows (JSON and CSV)
SERIES_STATIC = ("id", "name", "kind", "layer", "x", "y", "z")


def series_json(table: SeriesTable) -> Iterator[str]:
    """``to_json(table.to_dict())``: the entries' fields and series written from columns."""
    static = _series_columns(table)
    times = len(table.times_ns)

    def fields(a: int, b: int) -> rt.Fields:
        out = [(key, _json_tokens(static, key, a, b)) for key in SERIES_STATIC]
        return [
            *out,
            ("flow", rt.json_floats(table.flow[a:b])),
            ("flow_per_hour", rt.json_floats(table.flow_per_hour[a:b])),
        ]

    doc = table.to_dict(with_entries=False)
    per_record = len(SERIES_STATIC) + 2 * times
    entries = rt.json_object_list(len(static), fields, pad=2, block=_block(per_record))
    return rt.json_document(doc, "entries", entries)


PER_TIME = ("time", "time_ns", "hour_observed")
"""The series CSV's columns of a time (the rest are an entry's, or its flow then)."""


def series_csv(table: SeriesTable, labels: Sequence[str], keys: Sequence[str]) -> Iterator[str]:
    """``to_csv(table.long_rows(labels), keys)``: one row per (time, entry), times outermost;
    each entry's cells are made once, its flows one block of rows at a time."""
    static = _series_columns(table)
    entries, times = len(static), len(table.times_ns)
    every = slice(None)
    cells = {key: _csv_cells(static, key, every) for key in SERIES_STATIC}
    cells["time"] = rt.csv_strings(np.asarray(list(labels), dtype=object))
    cells["time_ns"] = rt.csv_ints(np.asarray(table.times_ns, dtype=np.int64))
    cells["hour_observed"] = rt.csv_strings(np.asarray(table.observed_text(), dtype=object))
    yield rt.csv_header(keys, {})  # no list fields: one column per key

    def block(a: int, b: int) -> list[Any]:
        row = np.arange(a, b)
        j, k = row // entries, row % entries
        out = []
        for key in keys:
            if key in ("flow", "flow_per_hour"):
                values = table.flow if key == "flow" else table.flow_per_hour
                out.append(rt.csv_floats(values[k, j]))
            else:
                out.append(cells[key][j if key in PER_TIME else k])
        return out

    yield from rt.csv_rows(entries * times, block, _block(len(keys)))


def _series_columns(table: SeriesTable) -> EntryColumns:
    """The static fields of a series' entries as columns (kept by ``predict_series``; else
    gathered from its entry dicts)."""
    if table.columns is not None:
        return table.columns
    text = {
        key: rt.object_array([e[key] for e in table.entries])
        for key in ("id", "name", "kind", "layer")
    }
    floats = {
        key: np.asarray([e[key] for e in table.entries], dtype=np.float64).reshape(-1)
        for key in ("x", "y", "z")
    }
    return EntryColumns(text, floats, np.zeros(len(table.entries), np.int64))
