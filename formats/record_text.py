"""JSON and CSV text of many records written from columns, byte for byte as
:mod:`formats.serialize` writes a list of dicts, without a dict per record.

``to_json(doc)`` of a document holding 10^5 records spends most of its time in
Python's pure-Python indenting encoder and in ``clean``; ``to_csv`` in a ``csv`` call and a
cleaned dict per row. Here every field is turned into its text token once, for a block of
rows at a time (``float.__repr__`` / ``round`` mapped over the block's list: what the encoder
and ``to_csv`` call per value, without a Python frame per record), and the tokens are laid
out in an object array ``[rows, pieces]`` between the constant separators, keys and
indents, then joined: the text of a block. Blocks bound the memory to a block's strings.

The layout is ``json.dumps(..., indent=2)``'s and ``csv.writer(lineterminator="\\n")``'s
with ``serialize``'s conventions: NaN/inf are ``null`` in JSON and an empty cell in CSV, CSV
floats are ``repr(round(x, 9))``, JSON strings are ASCII-escaped as ``json.dumps`` does.
``tests/formats/test_record_text.py`` compares cells and tokens with ``serialize``'s,
``tests/cli/test_entry_text.py`` whole documents.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Callable, Iterator, Sequence
from itertools import repeat
from json.encoder import encode_basestring_ascii
from typing import Any

import numpy as np
import numpy.typing as npt

Obj = npt.NDArray[np.object_]

#: records turned into text at a time (bounds the token strings held at once)
BLOCK = 4096

#: what a column is given as for a block of rows: (key, tokens [n] or [n, K])
Fields = list[tuple[str, Obj]]


def _is_none(values: Obj) -> npt.NDArray[np.bool_]:
    return np.asarray(np.equal(values, np.array(None, dtype=object)), dtype=bool)


def object_array(values: Sequence[Any], shape: tuple[int, ...] | None = None) -> Obj:
    """``values`` as an object array (of ``shape``; default 1-D), each item kept as it is:
    ``np.asarray`` would make strings a fixed-width str array and lists a 2-D one."""
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out if shape is None else out.reshape(shape)


def json_floats(values: Any) -> Obj:
    """``json.dumps`` tokens of float64 values (any shape): ``repr`` of a finite value,
    ``null`` for NaN and infinities (``serialize.clean`` makes them None)."""
    array = np.asarray(values, dtype=np.float64)
    out = object_array(list(map(float.__repr__, array.reshape(-1).tolist())), array.shape)
    out[~np.isfinite(array)] = "null"
    return out


def json_ints(values: Any) -> Obj:
    """``json.dumps`` tokens of integers."""
    array = np.asarray(values, dtype=np.int64)
    return object_array(list(map(int.__repr__, array.reshape(-1).tolist())), array.shape)


def json_strings(values: Any) -> Obj:
    """``json.dumps`` tokens of str values (ASCII, escaped), ``null`` for None."""
    array = np.asarray(values, dtype=object).reshape(-1)
    none = _is_none(array)
    text = array.copy()
    text[none] = ""
    out = object_array(list(map(encode_basestring_ascii, text.tolist())), array.shape)
    out[none] = "null"
    return out


def json_object_list(
    n: int, fields: Callable[[int, int], Fields], pad: int, block: int = BLOCK
) -> Iterator[str]:
    """The text of a JSON list of ``n`` objects as ``json.dumps(indent=2)`` writes it where
    the list's ``[`` stands on a line indented by ``pad`` spaces, in chunks of ``block``
    objects. ``fields(a, b)``: the keys (in order, the same for every object) and tokens of
    objects ``a .. b - 1``; a 2-D token array is a list-valued field."""
    if n == 0:
        yield "[]"
        return
    yield "[\n"
    for a in range(0, n, block):
        b = min(n, a + block)
        pieces = _object_pieces(fields(a, b), b - a, pad)
        if b < n:
            pieces[-1, -1] += ",\n"
        yield "".join(pieces.reshape(-1).tolist())
    yield "\n" + " " * pad + "]"


def _object_pieces(fields: Fields, rows: int, pad: int) -> Obj:
    """``[rows, pieces]``: constant text and tokens alternating, one object per row, the
    objects separated by ``,\\n`` (the last row without it)."""
    item, key_pad, value_pad = " " * (pad + 2), " " * (pad + 4), " " * (pad + 6)
    columns: list[Any] = []  # constant strings and token columns, in text order
    text = item + "{\n"
    for f, (key, tokens) in enumerate(fields):
        text += ("" if f == 0 else ",\n") + key_pad + encode_basestring_ascii(key) + ": "
        if tokens.ndim == 1:
            columns += [text, tokens]
            text = ""
        elif tokens.shape[1] == 0:
            text += "[]"
        else:
            text += "[\n"
            for k in range(tokens.shape[1]):
                columns += [text + ("" if k == 0 else ",\n") + value_pad, tokens[:, k]]
                text = ""
            text = "\n" + key_pad + "]"
    columns.append(text + "\n" + item + "}")
    pieces = np.empty((rows, len(columns)), dtype=object)
    for j, column in enumerate(columns):
        pieces[:, j] = column
    pieces[:-1, -1] = columns[-1] + ",\n"
    return pieces


def json_document(doc: dict[str, Any], key: str, value: Iterator[str]) -> Iterator[str]:
    """``serialize.to_json(doc)`` with ``doc[key]`` (a placeholder in ``doc``) written as
    the chunks ``value`` (e.g. :func:`json_object_list` with ``pad=2``, a key of the top
    level), in chunks: the document around it is encoded by ``to_json``."""
    from aion_cli.formats.serialize import to_json

    marker = "\x00aion-record-text\x00"
    text = to_json({**doc, key: marker})
    head, found, tail = text.partition(json.dumps(marker))
    if not found or json.dumps(marker) in tail:
        raise ValueError("the document holds the placeholder text (a bug)")
    yield head
    yield from value
    yield tail


def csv_floats(values: Any) -> Obj:
    """``serialize.to_csv`` cells of float64 values: ``repr(round(x, 9))``, empty for NaN
    and infinities.

    ``round(x, 9)`` is the double nearest the decimal ``"%.9f" % x`` (both are CPython's
    correctly rounded dtoa, mode 3), and a decimal of at most 15 significant digits is the
    shortest repr of its nearest double (DBL_DIG): where ``1e-4 <= |x| < 1e5`` (14 digits at
    most, written without an exponent) the cell is that decimal without its trailing zeros,
    made for the whole block by one ``%`` format and a strip; a value that rounds to zero
    likewise, ``0.0`` whatever its sign (``serialize`` adds 0.0 to it). The rest (below
    1e-4: ``1.5e-05``; 1e5 and above) go through ``round`` and ``repr`` themselves."""
    array = np.asarray(values, dtype=np.float64)
    flat = array.reshape(-1)
    size = np.abs(flat)
    fast = ((size >= 1e-4) & (size < 1e5)) | (size < 4e-10)  # NaN: neither
    slow = np.flatnonzero(~fast & np.isfinite(flat))
    out = np.full(flat.size, "", dtype=object)
    out[fast] = _fixed_9(flat[fast].tolist())
    if slow.size:
        rounded = map(round, flat[slow].tolist(), repeat(9))
        out[slow] = list(map(float.__repr__, rounded))
    out[out == "-0.0"] = "0.0"  # as serialize: never a negative zero
    return out.reshape(array.shape)


def _fixed_9(values: list[float]) -> list[str]:
    """``"%.9f" % v`` of each value, trailing zeros stripped to one digit after the point."""
    if not values:
        return []
    text = ("%.9f\n" * len(values)) % tuple(values)
    stripped = "\n".join(map(str.rstrip, text.split("\n"), repeat("0")))
    return stripped.replace(".\n", ".0\n").split("\n")[:-1]


def csv_ints(values: Any) -> Obj:
    """``serialize.to_csv`` cells of integers."""
    array = np.asarray(values, dtype=np.int64)
    return object_array(list(map(int.__repr__, array.reshape(-1).tolist())), array.shape)


def csv_strings(values: Any) -> Obj:
    """``serialize.to_csv`` cells of str values (empty for None): the text itself, or the
    ``csv`` module's quoted form for the few that hold a comma, a quote or a line break
    (found with ``numpy.char.find`` over the column, one scan per such character)."""
    array = np.asarray(values, dtype=object).reshape(-1)
    out = array.copy()
    out[_is_none(array)] = ""
    if out.size == 0:
        return out
    text = out.astype(str)
    special = np.zeros(out.size, dtype=bool)
    for char in ',"\r\n':
        special |= np.char.find(text, char) >= 0
    if special.any():
        out[special] = list(map(_quoted, out[special].tolist()))
    return out


def _quoted(text: str) -> str:
    """The ``csv`` writer's cell for ``text`` (written beside a second cell: a row of one
    empty cell is written differently)."""
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow([text, ""])
    return buf.getvalue()[: -len(",\n")]


def csv_header(keys: Sequence[str], widths: dict[str, int]) -> str:
    """``to_csv``'s header: ``key_0 .. key_{k-1}`` for a list field of ``widths[key]`` values
    (no rows: the bare key), the key itself for the others."""
    header: list[str] = []
    for key in keys:
        width = widths.get(key, -1)
        header.extend([f"{key}_{i}" for i in range(width)] if width >= 0 else [key])
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(header)
    return buf.getvalue()


def csv_rows(
    n: int, cells: Callable[[int, int], list[Obj]], block: int = BLOCK
) -> Iterator[str]:
    """The rows of ``n`` records, ``block`` at a time: ``cells(a, b)`` gives the cells of
    rows ``a .. b - 1`` field by field ([n] or [n, K] for a list field spread over columns)."""
    for a in range(0, n, block):
        b = min(n, a + block)
        columns = [c if c.ndim == 2 else c[:, None] for c in cells(a, b)]
        width = sum(c.shape[1] for c in columns)
        pieces = np.empty((b - a, 2 * width), dtype=object)
        pieces[:, 1::2] = ","
        pieces[:, -1] = "\n"
        at = 0
        for c in columns:
            pieces[:, at : at + 2 * c.shape[1] : 2] = c
            at += 2 * c.shape[1]
        yield "".join(pieces.reshape(-1).tolist())
