"""Parsing the plain tables of tracks (one line per detection): layouts' column specs
(:class:`_Spec`), the checks of a file before it is read (encoding, compression, header), the
C-speed read with ``np.loadtxt`` (:func:`_load`, :func:`_plain_columns`) and, only when that
fails, the line-by-line rescan that names the first bad line (:func:`_first_problem`), and
times in seconds to nanoseconds (:func:`_seconds_to_ns`).

Shared by :mod:`formats.track_csv` (canonical, ATC, THÖR, ETH/UCY), the dataset readers of
:mod:`formats.datasets` and :mod:`formats.thor_magni`, and :mod:`formats.track_tail`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, I64
from aion_cli.errors import path_word
from aion_cli.formats.track_types import LAYOUTS, NoTrackRowsError, TracksFormatError


@dataclass(frozen=True)
class _Spec:
    """How to parse one layout: column names, which must be integers or finite, delimiter,
    a fixed header line or a number of header lines to skip, columns that are not read
    (undocumented or constant ones, which may even be text), and columns that may not be
    negative (speeds: a magnitude, whose direction is another column)."""

    columns: tuple[str, ...]
    int_columns: frozenset[int]
    finite_columns: frozenset[int]
    delimiter: str | None
    header: str | None
    header_lines: int = 0
    ignored_columns: frozenset[int] = frozenset()
    nonnegative_columns: frozenset[int] = frozenset()

    @property
    def skip(self) -> int:
        """Lines before the data."""
        return 1 if self.header is not None else self.header_lines

    @property
    def used(self) -> tuple[int, ...]:
        """Columns that are read."""
        return tuple(k for k in range(len(self.columns)) if k not in self.ignored_columns)





def _split(line: str, delimiter: str | None) -> list[str]:
    return [f.strip() for f in line.split(delimiter)] if delimiter else line.split()


def _data_lines(path: Path, spec: _Spec) -> Iterator[tuple[int, str]]:
    """(line number, text) of every data line, comments cut, as np.loadtxt sees them."""
    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        for lineno, raw in enumerate(fh, start=1):
            if lineno <= spec.skip:
                continue
            line = raw.split("#", 1)[0].strip()
            if line:
                yield lineno, line


#: what separates the fields of a line, by delimiter (None: runs of white space)
_SEPARATORS = {",": "commas", ";": "semicolons", "\t": "tabs", "|": "bars", None: "spaces"}


def _other_separator(line: str, spec: _Spec) -> str:
    """``: its fields are separated by semicolons, not commas`` when ``line`` splits into the
    layout's columns, all numbers, at another separator than the layout's; else ``""``."""
    for delimiter, name in _SEPARATORS.items():
        if delimiter == spec.delimiter:
            continue
        fields = _split(line, delimiter)
        if len(fields) != len(spec.columns):
            continue
        try:
            [float(f) for k, f in enumerate(fields) if k not in spec.ignored_columns]
        except ValueError:
            continue
        layouts = "white space" if spec.delimiter is None else _SEPARATORS[spec.delimiter]
        return f": its fields are separated by {name}, not {layouts}"
    return ""


def _first_problem(path: Path, spec: _Spec) -> tuple[int, str] | None:
    """The number of the first line that does not parse and what is wrong with it (slow
    path, only after a failure)."""
    for lineno, line in _data_lines(path, spec):
        fields = _split(line, spec.delimiter)
        if len(fields) != len(spec.columns):
            return lineno, (
                f"line {lineno}: expected {len(spec.columns)} columns "
                f"({', '.join(spec.columns)}), got {len(fields)}"
                + _other_separator(line, spec)
            )
        for k, text in enumerate(fields):
            if k in spec.ignored_columns:
                continue
            where = f"line {lineno}, column {k + 1} ({spec.columns[k]}): {text[:40]!r}"
            try:
                value = float(text)
            except ValueError:
                return lineno, f"{where} is not a number"
            if k in spec.finite_columns and not math.isfinite(value):
                return lineno, f"{where} is not finite"
            if k in spec.nonnegative_columns and value < 0:
                return lineno, f"{where} is negative"
            if k in spec.int_columns and not value.is_integer():
                return lineno, f"{where} is not an integer"
            if k in spec.int_columns and not abs(value) < _INT_LIMIT:
                return lineno, f"{where} is beyond the 64-bit integers an id or frame is kept in"
    return None


#: Integer columns (ids, frames) are kept in int64: a magnitude from here on would wrap around.
_INT_LIMIT = 2.0**63


def _fail(path: Path, spec: _Spec, layout: str, detail: str | None = None) -> TracksFormatError:
    """The refusal of a file that does not read as ``layout``: its first problem, and a hint
    naming the layout it looks like (``track_sniff``), else ``layout``'s columns."""
    from aion_cli.formats.track_sniff import other_layout_hint

    found = _first_problem(path, spec)
    problem = found[1] if found is not None else detail or "unreadable data"
    hint = other_layout_hint(path, layout) or f"{layout} columns: {', '.join(spec.columns)}"
    if found is not None and _ends_inside(path, found[0]):
        problem += " (the file ends inside this line)"
        hint = (
            "the file looks cut short (a copy or an export that did not finish): without its "
            f"last line, line {found[0]:,}, the lines before it can be read"
        )
    return TracksFormatError(f"{path}: not a valid {layout} tracks file: {problem}", hint=hint)


def _ends_inside(path: Path, lineno: int) -> bool:
    """Whether line ``lineno`` is the file's last and has no line end: where a file cut
    short ends."""
    lines, last = 0, b""
    with path.open("rb") as f:
        while block := f.read(1 << 20):
            lines += block.count(b"\n")
            last = block[-1:]
    return last not in (b"\n", b"\r", b"") and lineno == lines + 1


#: byte-order marks of the Unicode encodings that are not UTF-8 (UTF-32's first)
_BOMS = (
    (b"\xff\xfe\x00\x00", "UTF-32"),
    (b"\x00\x00\xfe\xff", "UTF-32"),
    (b"\xff\xfe", "UTF-16"),
    (b"\xfe\xff", "UTF-16"),
)


#: leading bytes of compressed files, their name and the command that unpacks them
_PACKED = ((b"\x1f\x8b", "gzip", "gunzip -k"), (b"PK\x03\x04", "zip", "unzip"),
           (b"\xfd7zXZ\x00", "xz", "unxz -k"), (b"\x28\xb5\x2f\xfd", "zstd", "zstd -d"))


def check_encoding(path: Path) -> None:
    """Refuse a tracks file in UTF-16 or UTF-32 (what Windows tools save as "Unicode text"),
    with or without its byte-order mark: read as UTF-8 each character came with NUL bytes and
    the file was refused as "'\\x000\\x00.\\x00' is not a number" on line 1. Refuse a
    compressed file (gzip, zip, bzip2, xz, zstd) as such: it was "line 1: expected 6
    columns, got 1 (the file ends inside this line)" with the hint that it looks cut short."""
    with path.open("rb") as f:
        head = f.read(4096)
    packed = next((p for p in _PACKED if head.startswith(p[0])), None)
    if packed is None and head[:3] == b"BZh" and head[3:4].isdigit():
        packed = (b"BZh", "bzip2", "bunzip2 -k")
    if packed is not None:
        raise TracksFormatError(
            f"{path}: the file is {packed[1]}-compressed; aion reads tracks files as plain text",
            hint=f"unpack it first: {packed[2]} {path.name}",
        )
    name = next((n for bom, n in _BOMS if head.startswith(bom)), None)
    if name is None and len(head) >= 8:  # no mark: text with a NUL in every other byte
        odd, even = head[1::2].count(0) / len(head[1::2]), head[0::2].count(0) / len(head[0::2])
        if max(odd, even) > 0.9 and min(odd, even) < 0.1:
            name = "UTF-16LE" if odd > even else "UTF-16BE"
    if name is not None:
        raise TracksFormatError(
            f"{path}: the file is {name} text; aion reads tracks files as UTF-8 (or ASCII)",
            hint=f"convert it first: iconv -f {name} -t UTF-8 {path_word(path)} > "
            f"{path_word(f'{path.stem}-utf8{path.suffix}')}",
        )


def _check_file(path: Path, spec: _Spec, layout: str) -> None:
    if not path.is_file():
        raise TracksFormatError(f"tracks file not found: {path}")
    if path.stat().st_size == 0:
        raise NoTrackRowsError(f"{path}: no track rows", hint="the file is empty")
    check_encoding(path)
    if spec.header is None:
        return
    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        first = fh.readline().strip()
    if first.replace(" ", "") != spec.header:
        from aion_cli.formats.track_sniff import other_layout_hint

        hint = other_layout_hint(path, layout) or (
            f"is this another layout ({', '.join(LAYOUTS)})? pass it as the layout"
        )
        raise TracksFormatError(
            f"{path}: line 1 must be the header {spec.header!r}, got {first[:80]!r}", hint=hint
        )


def _no_rows_hint(spec: _Spec) -> str:
    """What a file without a detection row holds (after :func:`_check_file`: not 0 bytes)."""
    return (
        "the file has only its header line" if spec.header is not None
        else "the file holds no data line"
    ) + " (a sensor that recorded nobody: give its --observed spans)"


def _load(path: Path, spec: _Spec, layout: str, dtype: npt.DTypeLike, ndmin: Literal[1, 2]) -> Any:
    """``np.loadtxt`` with our errors: bad lines named by number, empty files refused."""
    _check_file(path, spec, layout)
    try:
        # a byte that is not UTF-8 (a Latin-1 comment) becomes U+FFFD: ignored in a comment,
        # "'1.\ufffd' is not a number" by line in a value, never the codec's "position 5"
        with warnings.catch_warnings(), path.open(encoding="utf-8-sig", errors="replace") as fh:
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            data = np.loadtxt(
                fh,
                dtype=dtype,
                delimiter=spec.delimiter,
                skiprows=spec.skip,
                usecols=spec.used if spec.ignored_columns else None,
                ndmin=ndmin,
            )
    except (ValueError, OverflowError) as exc:
        raise _fail(path, spec, layout, str(exc)) from exc
    if data.size == 0:
        raise NoTrackRowsError(f"{path}: no track rows", hint=_no_rows_hint(spec))
    if spec.ignored_columns:
        _check_widths(path, spec, layout)
    return data


def _check_widths(path: Path, spec: _Spec, layout: str) -> None:
    """Refuse a line with more or fewer columns than ``spec``'s, unread ones included: a read
    that picks columns (``usecols``) takes ``t x y`` inside a ``t x y a b WPn`` file, and
    one with a seventh field, without a word. Each field is kept as its first character
    only (C speed, 4 bytes a field); :func:`_fail` names the first such line."""
    try:
        with warnings.catch_warnings(), path.open(encoding="utf-8-sig", errors="replace") as fh:
            warnings.simplefilter("ignore", UserWarning)
            fields = np.loadtxt(
                fh, dtype="U1", delimiter=spec.delimiter, skiprows=spec.skip, ndmin=2
            )
    except ValueError as exc:
        raise _fail(path, spec, layout, str(exc)) from exc
    if fields.shape[1] != len(spec.columns):
        raise _fail(path, spec, layout, f"expected {len(spec.columns)} columns")


def _plain_columns(path: Path, spec: _Spec, layout: str) -> F64:
    """The read columns (``spec.used``) of a header-less numeric layout, checked."""
    return _checked_plain(path, spec, layout, _load(path, spec, layout, np.float64, ndmin=2))


def _checked_plain(path: Path, spec: _Spec, layout: str, data: F64) -> F64:
    """``data`` (rows of the read columns) checked: column count, finite, non-negative and
    integer columns; the ignored columns come back as zeros."""
    if data.shape[1] != len(spec.used):
        raise _fail(path, spec, layout, f"expected {len(spec.columns)} columns")
    arr: F64 = data
    if spec.ignored_columns:
        arr = np.zeros((len(data), len(spec.columns)))
        arr[:, list(spec.used)] = data  # ignored columns stay 0
    bad = ~np.isfinite(arr[:, sorted(spec.finite_columns)]).all(axis=1)
    bad |= (arr[:, sorted(spec.nonnegative_columns)] < 0).any(axis=1)
    ints = arr[:, sorted(spec.int_columns)]
    if bad.any() or (ints != np.round(ints)).any() or not (np.abs(ints) < _INT_LIMIT).all():
        raise _fail(path, spec, layout)
    return arr


#: Largest magnitude of a time in ns that int64 holds with margin (about 2262-04-11).
_MAX_ABS_NS = 9.2e18


def _seconds_to_ns(t_s: F64, start_ns: int = 0, path: Path | None = None) -> I64:
    """Seconds -> int64 ns, rounded to the microsecond (the files carry ms at best). A time
    (after the ``start_ns`` shift) beyond int64 nanoseconds is a :class:`TracksFormatError`
    (naming ``path``), never a value that wrapped around."""
    with np.errstate(invalid="ignore", over="ignore"):
        shifted = t_s * 1e9 + float(start_ns)
    if len(t_s) and not (np.abs(shifted) < _MAX_ABS_NS).all():  # NaN fails too
        k = int(np.flatnonzero(~(np.abs(shifted) < _MAX_ABS_NS))[0])
        raise TracksFormatError(
            f"{'' if path is None else f'{path}: '}a time of {t_s[k]:g} s is beyond the range "
            "of nanosecond log times (1970 +- 292 years)",
            hint="is the time column in seconds? check --start, --fps or the layout",
        )
    return np.round(t_s * 1e6).astype(np.int64) * 1000 + np.int64(start_ns)
