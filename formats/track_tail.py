"""Whether a tracks table's last line looks cut inside its last number
(:func:`cut_last_line`), and which line holds a negative track id (:func:`negative_id_line`):
scans of the file's lines after it was read.

A copy or an export that did not finish ends inside a line. When the cut leaves a field that
is no number (``-``, ``1e``) or too few columns, the readers of :mod:`formats.track_csv` refuse
the file and say it ends inside that line. A cut inside the last number can leave a number
that still parses (``1.`` of ``1.25``, ``1.2`` of ``1.25``): the line is read as it is, and
:func:`cut_last_line` says why it looks cut, for a warning. Files whose last line merely has no
line end (THÖR's public files) are not flagged: only a last value that ends in its decimal
point, or one with fewer decimals than the same column has on every line before it (aion's
canonical CSV writes six), is.
"""

from __future__ import annotations

from pathlib import Path

from aion_cli.formats.track_csv import _SPECS
from aion_cli.formats.track_parse import _data_lines, _split

#: bytes read from the end of the file: the last line and the lines before it
TAIL_BYTES = 65_536
#: complete lines before the last whose last column sets the decimals it is written with
TAIL_LINES = 50

_SPEC_OF = {"canonical": "canonical", "atc": "atc", "thor": "atc", "eth": "eth", "ucy": "eth"}


def _decimals(text: str) -> int | None:
    """Digits after the decimal point of a plain decimal number, else None (nan, 1e-3)."""
    if "e" in text.lower() or not text.lstrip("+-").replace(".", "", 1).isdigit():
        return None
    return len(text.split(".", 1)[1]) if "." in text else 0


def cut_last_line(path: str | Path, layout: str) -> str | None:
    """A one-line warning when ``path`` (a tracks table of ``layout``) ends without a line end
    inside what looks like its last number, else None (also for a layout that is no
    one-line-per-detection table, and for a file that cannot be read)."""
    key = _SPEC_OF.get(layout.lower())
    if key is None:
        return None
    spec = _SPECS[key]
    p = Path(path)
    try:
        with p.open("rb") as f:
            size = f.seek(0, 2)
            f.seek(max(0, size - TAIL_BYTES))
            tail = f.read()
    except OSError:
        return None
    if not tail or tail.endswith((b"\n", b"\r")):
        return None
    lines = tail.decode("utf-8", errors="replace").splitlines()
    if size > TAIL_BYTES:
        lines = lines[1:]  # the first may be part of a line
    rows = [_split(line.split("#", 1)[0].strip(), spec.delimiter) for line in lines]
    rows = [r for r in rows if r != [""] and r]
    if not rows or len(rows[-1]) != len(spec.columns):
        return None  # no data line, or one the reader refuses as cut short
    last = rows[-1][-1]
    column = spec.columns[-1]
    written = _decimals(last)
    if written is None:
        return None
    why = ""
    if last.endswith("."):
        why = "ends in its decimal point"
    else:
        earlier = [
            _decimals(r[-1]) for r in rows[-1 - TAIL_LINES : -1] if len(r) == len(spec.columns)
        ]
        known = {d for d in earlier if d is not None}
        if len(earlier) >= 2 and len(known) == 1 and written < min(known):
            why = f"has {written} decimals where every line before it has {min(known)}"
    if not why:
        return None
    with p.open("rb") as f:
        number = sum(block.count(b"\n") for block in iter(lambda: f.read(1 << 20), b"")) + 1
    return (
        f"{p.name}: the file ends inside line {number:,} (no line end) and its last value, "
        f"{column} {last!r}, {why}: the line looks cut short (a copy or an export that did not "
        "finish) and was read as it is"
    )


#: the track id column of each table layout's columns
_ID_COLUMNS = ("track_id", "person_id", "ped_id")


def negative_id_line(path: str | Path, layout: str) -> str | None:
    """Where the first negative track id of a tracks table of ``layout`` is, ``line 12,
    column 2 (person_id): '-5'`` (a slow scan, after the log writer refused the id), else None
    (also for layouts whose ids are no column of the file: Lincoln's are linked, Edinburgh's
    are its ``Rn`` names)."""
    key = _SPEC_OF.get(layout.lower())
    if key is None:
        return None
    spec = _SPECS[key]
    column = next(k for k, name in enumerate(spec.columns) if name in _ID_COLUMNS)
    for lineno, line in _data_lines(Path(path), spec):
        fields = _split(line, spec.delimiter)
        try:
            negative = float(fields[column]) < 0
        except (IndexError, ValueError):
            continue
        if negative:
            return (
                f"line {lineno:,}, column {column + 1} ({spec.columns[column]}): "
                f"{fields[column][:40]!r}"
            )
    return None
