"""THÖR-MAGNI trajectory CSVs (header ``Time,frame_id,x,y,z,ag_id,data_label,...``,
millimetres, seconds from the start, ``ag_id`` names such as ``Helmet_3``):
:func:`read_thor_magni`. Shares the parsing helpers of :mod:`formats.track_csv`."""

from __future__ import annotations

import csv
import re
import warnings
from pathlib import Path
from typing import BinaryIO, Literal

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, I64
from aion_cli.errors import path_word
from aion_cli.formats.track_csv import differenced
from aion_cli.formats.track_parse import _seconds_to_ns, check_encoding
from aion_cli.formats.track_tail import TAIL_BYTES
from aion_cli.formats.track_types import NoTrackRowsError, TrackData, TracksFormatError
from aion_cli.listing import first_few

#: the columns a THÖR-MAGNI CSV must have, found by name in its header
THOR_MAGNI_REQUIRED = ("Time", "ag_id", "x", "y")
#: agents that are people: THÖR-MAGNI's participants wear tracked helmets (``Helmet_3``); the
#: robot (``DARKO_Robot``) and tracked objects (``LO1``) are not people
THOR_MAGNI_PEOPLE = "Helmet"
#: a position extent beyond this many units means millimetres (a mocap room is ~10-20 m)
_MM_EXTENT = 200.0
Units = Literal["auto", "mm", "m"]


def read_thor_magni(path: str | Path, start_ns: int = 0, units: str = "auto") -> TrackData:
    """A THÖR-MAGNI trajectory CSV as ``thor-magni-tools`` writes it (header ``Time,frame_id,
    x,y,z,ag_id,data_label,...``; columns found by name, any order, extra columns ignored).

    ``Time`` is seconds from the recording's start (``start_ns`` is when that was). Positions
    are millimetres in the files of the dataset (thor-magni-tools' converters divide ``x, y, z``
    by 1000); ``units="auto"`` takes millimetres when the positions span or reach more than
    200 units from the origin and metres otherwise, with a note saying which; ``"mm"`` /
    ``"m"`` force it. Rows without a position (untracked frames, empty ``x`` / ``y``) are
    dropped, with a note. Only people are kept: agents whose ``ag_id`` starts with
    ``Helmet`` when there are any (the robot and objects are dropped, with a note), else every
    agent. ``ag_id`` strings become integer track ids: the number that ends the name
    (``Helmet_3`` -> 3) when those are unique, else the name's rank. Heading and speed come
    from differencing each track.
    """
    if units not in ("auto", "mm", "m"):
        raise TracksFormatError(f"unknown length unit {units!r}", hint="use auto, mm or m")
    p = Path(path)
    columns = _thor_magni_header(p)
    used = [columns[name] for name in (*THOR_MAGNI_REQUIRED, "z") if name in columns]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            table = np.loadtxt(
                p,
                dtype=str,
                delimiter=",",
                skiprows=1,
                usecols=used,
                quotechar='"',
                ndmin=2,
                encoding="utf-8-sig",
            )
    except ValueError as exc:  # UnicodeDecodeError included
        raise _magni_problem(p, max(used) + 1, str(exc)) from exc
    _check_last_line(p)
    if table.size == 0:
        raise NoTrackRowsError(f"{p}: no track rows", hint="the file has only its header")
    t_s = _number_column(p, table[:, 0], "Time", finite=True)
    x = _number_column(p, table[:, 2], "x")
    y = _number_column(p, table[:, 3], "y")
    z = _number_column(p, table[:, 4], "z") if table.shape[1] > 4 else np.zeros(len(table))
    names = np.char.strip(table[:, 1])
    notes: list[str] = []
    located = np.isfinite(x) & np.isfinite(y)
    if not located.all():
        notes.append(
            f"{p.name}: {int((~located).sum()):,} of {len(located):,} rows have no position "
            "(untracked frames) and are skipped"
        )
    people = np.char.startswith(names, THOR_MAGNI_PEOPLE)
    keep = located & people if people.any() else located
    if people.any() and not people.all():
        others = sorted(set(names[~people].tolist()))
        notes.append(f"{p.name}: not people, skipped: {', '.join(others)}")
    elif not people.any():  # other names: every agent is taken for a person, and said so
        agents = sorted(set(names[located].tolist()))
        notes.append(
            f"{p.name}: no {THOR_MAGNI_PEOPLE}_N agent (THÖR-MAGNI's people): every agent is "
            f"converted as a person: {first_few(agents, 8)}"
        )
    if not keep.any():
        raise TracksFormatError(f"{p}: no row with a position", hint="x and y are all empty")
    t_s, x, y, z, names = t_s[keep], x[keep], y[keep], z[keep], names[keep]
    scale = _thor_magni_scale(p, x, y, units, notes)
    tid = _agent_ids(names)
    xyz = np.stack([x, y, np.nan_to_num(z)], axis=1) * scale
    t_ns = _seconds_to_ns(t_s, start_ns, p)
    batch = differenced(t_ns, xyz, tid)
    return TrackData(batch, notes=tuple(notes))


_MAGNI_HINT = "every row needs the header's columns, comma-separated"


def _fields(line: str) -> list[str]:
    """The comma-separated fields of one line (no line break in it: :func:`_lines`)."""
    return next(csv.reader([line]), [])


def _lines(block: bytes) -> list[bytes]:
    """The lines of ``block`` (bytes up to a ``\\n``, as a binary file iterates) with their
    ends, split at ``\\r\\n``, ``\\r`` and ``\\n`` as np.loadtxt's universal newlines read the
    file: a lone ``\\r`` inside a line ends it (the csv module refused such a line with an
    untyped ``_csv.Error``)."""
    return block.splitlines(keepends=True)


def _count_lines(fh: BinaryIO) -> int:
    """How many line ends the rest of ``fh`` has, counted as :func:`_lines` splits them, block
    by block (a ``\\r\\n`` across two blocks is one)."""
    n, previous = 0, b""
    for block in iter(lambda: fh.read(1 << 20), b""):
        n += block.count(b"\n") + block.count(b"\r") - block.count(b"\r\n")
        n -= previous.endswith(b"\r") and block.startswith(b"\n")
        previous = block
    return n


def _magni_problem(path: Path, need: int, detail: str) -> TracksFormatError:
    """The refusal of a THÖR-MAGNI file np.loadtxt failed on: its first line that is not UTF-8
    or has fewer than ``need`` columns (those up to the last one read), by number (slow path,
    after a failure); numpy's "invalid column index 5 at row 4 with 3 columns" was the
    message before."""
    columns = need
    with path.open("rb") as fh:
        for lineno, raw in enumerate((line for block in fh for line in _lines(block)), start=1):
            try:
                line = raw.decode("utf-8-sig" if lineno == 1 else "utf-8")
            except UnicodeDecodeError:
                return TracksFormatError(
                    f"{path}: line {lineno} is not UTF-8 text: {raw[:60]!r}",
                    hint=f"convert it first, e.g. iconv -f LATIN1 -t UTF-8 {path_word(path)} > "
                    f"{path_word(f'{path.stem}-utf8{path.suffix}')}",
                )
            got = len(_fields(line.strip()))
            if lineno == 1:
                columns = got
            elif line.strip() and got < need:
                cut = not raw.endswith((b"\n", b"\r"))
                return _short_line(path, lineno, columns, got, cut)
    return TracksFormatError(f"{path}: not a valid thor-magni tracks file: {detail}",
                             hint=_MAGNI_HINT)


def _short_line(path: Path, lineno: int, need: int, got: int, cut: bool) -> TracksFormatError:
    problem = f"{path}: not a valid thor-magni tracks file: line {lineno}: expected the " \
        f"header's {need} columns, got {got}"
    if not cut:
        return TracksFormatError(problem, hint=_MAGNI_HINT)
    return TracksFormatError(
        f"{problem} (the file ends inside this line)",
        hint="the file looks cut short (a copy or an export that did not finish): without its "
        f"last line, line {lineno:,}, the lines before it can be read",
    )


def _check_last_line(path: Path) -> None:
    """Refuse a file whose last line has no line end and fewer columns than the header: cut
    short inside it (its ``ag_id`` cut from ``Helmet_1`` to ``Hel`` was skipped as "not
    people", to ``Helmet_`` renumbered every agent), as the other layouts refuse a cut line."""
    with path.open("rb") as fh:
        header = fh.readline()
        size = fh.seek(0, 2)
        fh.seek(max(0, size - TAIL_BYTES))
        tail = fh.read()
    if not tail or tail.endswith((b"\n", b"\r")):
        return
    last = _lines(tail)[-1].decode("utf-8", errors="replace").strip()
    first = _lines(header)[0].decode("utf-8-sig", errors="replace")
    need, got = len(_fields(first.strip())), len(_fields(last))
    if got >= need or not last:
        return
    with path.open("rb") as fh:
        lineno = _count_lines(fh) + 1
    raise _short_line(path, lineno, need, got, cut=True)


def _thor_magni_header(path: Path) -> dict[str, int]:
    """Column name -> index of a THÖR-MAGNI CSV's header, with the required ones checked."""
    if not path.is_file():
        raise TracksFormatError(f"tracks file not found: {path}")
    if path.stat().st_size == 0:
        raise NoTrackRowsError(f"{path}: no track rows", hint="the file is empty")
    check_encoding(path)
    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        first = fh.readline().strip()
    names = [name.strip().strip('"') for name in first.split(",")]
    columns = {name: k for k, name in reversed(list(enumerate(names)))}
    missing = [name for name in THOR_MAGNI_REQUIRED if name not in columns]
    if missing:
        from aion_cli.formats.track_sniff import other_layout_hint

        raise TracksFormatError(
            f"{path}: line 1 must be a THÖR-MAGNI header with the columns "
            f"{', '.join(THOR_MAGNI_REQUIRED)}; {', '.join(missing)} missing (got {first[:80]!r})",
            hint=other_layout_hint(path, "thor-magni")
            or "THÖR-MAGNI CSVs start `Time,frame_id,x,y,z,ag_id,data_label,...`",
        )
    return columns


def _number_column(path: Path, text: npt.NDArray[np.str_], name: str, finite: bool = False) -> F64:
    """A text column as float64 (empty fields -> NaN), or the first bad value's line."""
    cleaned = np.char.strip(text)
    try:
        values: F64 = np.where(cleaned == "", "nan", cleaned).astype(np.float64)
    except ValueError:
        parsed = []
        for k, v in enumerate(cleaned.tolist()):  # slow path, only after a failure
            try:
                parsed.append(float(v or "nan"))
            except ValueError:
                raise TracksFormatError(
                    f"{path}: line {k + 2}, column {name}: {v[:40]!r} is not a number"
                ) from None
        values = np.array(parsed, dtype=np.float64)
    if finite:
        bad = np.flatnonzero(~np.isfinite(values))
        if len(bad):
            raise TracksFormatError(
                f"{path}: line {int(bad[0]) + 2}, column {name}: {str(text[bad[0]])[:40]!r} is not "
                "a finite number"
            )
    return values


def _thor_magni_scale(path: Path, x: F64, y: F64, units: str, notes: list[str]) -> float:
    """Metres per file unit: 1e-3 for millimetres, 1 for metres (``auto``: millimetres when
    the positions span or reach more than :data:`_MM_EXTENT` units from the origin; by the
    span alone, a ``head -n 50`` excerpt of a dataset file, people standing at 2,500 mm, was
    read as metres and put them 2.5 km away)."""
    extent = float(max(np.ptp(x), np.ptp(y)))
    reach = float(max(np.abs(x).max(), np.abs(y).max()))
    if units == "auto":
        units = "mm" if max(extent, reach) > _MM_EXTENT else "m"
        scale = 1e-3 if units == "mm" else 1.0
        notes.append(
            f"{path.name}: positions read as {'millimetres' if units == 'mm' else 'metres'} "
            f"(they span {extent * scale:,.1f} m and reach {reach * scale:,.1f} m from the "
            "origin); give --length-unit mm|m if that is wrong"
        )
    return 1e-3 if units == "mm" else 1.0


def _agent_ids(names: npt.NDArray[np.str_]) -> I64:
    """Integer track ids of agent names: each name's trailing number when those are unique
    (``Helmet_3`` -> 3), else the name's rank among the sorted names."""
    unique, inverse = np.unique(names, return_inverse=True)
    numbers = [re.search(r"(\d+)$", str(name)) for name in unique.tolist()]
    if all(numbers) and len({int(m.group(1)) for m in numbers if m}) == len(unique):
        codes = np.array([int(m.group(1)) for m in numbers if m], dtype=np.int64)
    else:
        codes = np.arange(len(unique), dtype=np.int64)
    ids: I64 = codes[inverse.reshape(-1)]
    return ids
