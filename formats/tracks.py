"""People-track files -> :class:`DetectionBatch`, and track batches -> robot-style logs.

Layouts (``../shared/data/README.md``):

- ``canonical``: aion's own CSV, header ``t_ns,track_id,x,y,z,heading_rad,speed_mps``
  (``nan`` for an unknown heading or speed); :func:`write_canonical_csv` writes it.
- ``atc``: ATC shopping centre, header-less ``time_s (UNIX), person_id, x_m, y_m, speed_mps,
  motion_angle_rad``.
- ``thor``: THÖR, the same columns with time from 0; ``start_ns`` shifts it to an absolute time.
- ``eth`` / ``ucy``: whitespace-separated ``frame ped_id x y`` (the common ETH/UCY text format:
  25 fps frame numbers, a sample every 10 frames = 2.5 Hz); heading and speed are estimated by
  differencing each track (central where possible).
- ``lincoln``: the L-CAS corridor detections (UNIX seconds, no ids), every variant of the
  files told apart by content (:func:`read_lincoln`); the detections are linked into tracks by
  :mod:`aion_cli.engine.tracking` (pure numpy, like the differencing the ETH reader uses).
- ``edinburgh``: the Edinburgh Informatics Forum tracks (``TRACK.Rn=[[x y frame];...];``,
  overhead-camera pixels at 24.7 mm, frame numbers at about 9 fps, no clock time:
  :func:`read_edinburgh`).
- ``thor-magni``: THÖR-MAGNI CSVs (header ``Time,frame_id,x,y,z,ag_id,data_label,...``,
  millimetres, seconds from the start, ``ag_id`` names such as ``Helmet_3``:
  :func:`read_thor_magni`).

Files are parsed with ``np.loadtxt`` (C speed: ATC's ~500k rows in well under a second). Only
when that fails is the file re-scanned line by line, to name the first bad line exactly.
:func:`read_track_data` also returns when the sensor was recording (:class:`TrackData`: the
spans a file declares); :func:`sessions` finds recording sessions in header-less files.
:func:`tracks_to_log` turns a batch (plus optionally a Hydra graph and the observed spans,
written as empty detection messages) into an MCAP or bag that ``aion build`` reads like any
robot log.
"""

from __future__ import annotations

import io
import math
import re
import struct
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from aion_cli.engine.errors import InputError
from aion_cli.engine.tracking import difference_tracks
from aion_cli.engine.types import F64, I64, BoolA, DetectionBatch

if TYPE_CHECKING:
    from aion_cli.engine.tracking import LinkerConfig

CANONICAL_HEADER = "t_ns,track_id,x,y,z,heading_rad,speed_mps"
Layout = Literal[
    "canonical", "atc", "thor", "eth", "ucy", "lincoln", "edinburgh", "thor-magni"
]
LAYOUTS: tuple[str, ...] = (
    "canonical",
    "atc",
    "thor",
    "eth",
    "ucy",
    "lincoln",
    "edinburgh",
    "thor-magni",
)
#: layouts whose times count from 0 (the recording's start), not from the UNIX epoch
RELATIVE_TIME_LAYOUTS: tuple[str, ...] = ("thor", "eth", "ucy", "edinburgh", "thor-magni")

#: columns of the header-less ATC / THÖR files
ATC_COLUMNS = ("time_s", "person_id", "x_m", "y_m", "speed_mps", "motion_angle_rad")
ETH_COLUMNS = ("frame", "ped_id", "x", "y")
CANONICAL_COLUMNS = tuple(CANONICAL_HEADER.split(","))


class TracksFormatError(InputError):
    """A tracks file has the wrong layout, non-numeric data, or no rows."""


@dataclass(frozen=True)
class _Spec:
    """How to parse one layout: column names, which must be integers or finite, delimiter,
    a fixed header line or a number of header lines to skip, and columns that are not read
    (undocumented or constant ones, which may even be text)."""

    columns: tuple[str, ...]
    int_columns: frozenset[int]
    finite_columns: frozenset[int]
    delimiter: str | None
    header: str | None
    header_lines: int = 0
    ignored_columns: frozenset[int] = frozenset()

    @property
    def skip(self) -> int:
        """Lines before the data."""
        return 1 if self.header is not None else self.header_lines

    @property
    def used(self) -> tuple[int, ...]:
        """Columns that are read."""
        return tuple(k for k in range(len(self.columns)) if k not in self.ignored_columns)


_SPECS: dict[str, _Spec] = {
    "canonical": _Spec(
        CANONICAL_COLUMNS, frozenset({0, 1}), frozenset({0, 1, 2, 3, 4}), ",", CANONICAL_HEADER
    ),
    "atc": _Spec(ATC_COLUMNS, frozenset({1}), frozenset({0, 1, 2, 3}), ",", None),
    "eth": _Spec(ETH_COLUMNS, frozenset({1}), frozenset({0, 1, 2, 3}), None, None),
}


# ----------------------------------------------------------------------------- parsing


def _split(line: str, delimiter: str | None) -> list[str]:
    return [f.strip() for f in line.split(delimiter)] if delimiter else line.split()


def _data_lines(path: Path, spec: _Spec) -> Iterator[tuple[int, list[str]]]:
    """(line number, fields) of every data line, as np.loadtxt sees them."""
    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        for lineno, raw in enumerate(fh, start=1):
            if lineno <= spec.skip:
                continue
            line = raw.split("#", 1)[0].strip()
            if line:
                yield lineno, _split(line, spec.delimiter)


def _first_problem(path: Path, spec: _Spec) -> str | None:
    """Describe the first line that does not parse (slow path, only after a failure)."""
    for lineno, fields in _data_lines(path, spec):
        if len(fields) != len(spec.columns):
            return (
                f"line {lineno}: expected {len(spec.columns)} columns "
                f"({', '.join(spec.columns)}), got {len(fields)}"
            )
        for k, text in enumerate(fields):
            if k in spec.ignored_columns:
                continue
            try:
                value = float(text)
            except ValueError:
                return (
                    f"line {lineno}, column {k + 1} ({spec.columns[k]}): {text!r} is not a number"
                )
            if k in spec.finite_columns and not math.isfinite(value):
                return f"line {lineno}, column {k + 1} ({spec.columns[k]}): {text!r} is not finite"
            if k in spec.int_columns and not value.is_integer():
                return (
                    f"line {lineno}, column {k + 1} ({spec.columns[k]}): {text!r} is not an integer"
                )
    return None


def _fail(path: Path, spec: _Spec, layout: str, detail: str | None = None) -> TracksFormatError:
    problem = _first_problem(path, spec) or detail or "unreadable data"
    return TracksFormatError(
        f"{path}: not a valid {layout} tracks file: {problem}",
        hint=f"{layout} columns: {', '.join(spec.columns)}",
    )


def _check_file(path: Path, spec: _Spec, layout: str) -> None:
    if not path.is_file():
        raise TracksFormatError(f"tracks file not found: {path}")
    if path.stat().st_size == 0:
        raise TracksFormatError(f"{path}: no track rows", hint="the file is empty")
    if spec.header is None:
        return
    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        first = fh.readline().strip().replace(" ", "")
    if first != spec.header:
        raise TracksFormatError(
            f"{path}: line 1 must be the header {spec.header!r}, got {first[:80]!r}",
            hint=f"is this another layout ({', '.join(LAYOUTS)})? pass it as the layout",
        )


def _load(path: Path, spec: _Spec, layout: str, dtype: npt.DTypeLike, ndmin: Literal[1, 2]) -> Any:
    """``np.loadtxt`` with our errors: bad lines named by number, empty files refused."""
    _check_file(path, spec, layout)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            data = np.loadtxt(
                path,
                dtype=dtype,
                delimiter=spec.delimiter,
                skiprows=spec.skip,
                usecols=spec.used if spec.ignored_columns else None,
                ndmin=ndmin,
                encoding="utf-8-sig",
            )
    except (ValueError, UnicodeDecodeError, OverflowError) as exc:
        raise _fail(path, spec, layout, str(exc)) from exc
    if data.size == 0:
        raise TracksFormatError(f"{path}: no track rows", hint="the file is empty")
    return data


def _plain_columns(path: Path, spec: _Spec, layout: str) -> F64:
    """The read columns (``spec.used``) of a header-less numeric layout, checked."""
    return _checked_plain(path, spec, layout, _load(path, spec, layout, np.float64, ndmin=2))


def _checked_plain(path: Path, spec: _Spec, layout: str, data: F64) -> F64:
    """``data`` (rows of the read columns) checked: column count, finite and integer columns;
    the ignored columns come back as zeros."""
    if data.shape[1] != len(spec.used):
        raise _fail(path, spec, layout, f"expected {len(spec.columns)} columns")
    arr: F64 = data
    if spec.ignored_columns:
        arr = np.zeros((len(data), len(spec.columns)))
        arr[:, list(spec.used)] = data  # ignored columns stay 0
    bad = ~np.isfinite(arr[:, sorted(spec.finite_columns)]).all(axis=1)
    ints = arr[:, sorted(spec.int_columns)]
    if bad.any() or (ints != np.round(ints)).any():
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


# ----------------------------------------------------------------------------- readers


_CANONICAL_DTYPE = np.dtype(
    [(name, "i8" if k in (0, 1) else "f8") for k, name in enumerate(CANONICAL_COLUMNS)]
)


def _canonical_rows(path: Path, rec: Any) -> DetectionBatch:
    """Canonical records (file order) -> batch; non-finite positions are a format error."""
    xyz = np.stack([rec["x"], rec["y"], rec["z"]], axis=1)
    if not np.isfinite(xyz).all():
        raise _fail(path, _SPECS["canonical"], "canonical")
    return DetectionBatch.from_arrays(
        rec["t_ns"], xyz, rec["heading_rad"], rec["speed_mps"], rec["track_id"]
    )


def _atc_rows(path: Path, layout: str, data: F64, start_ns: int) -> DetectionBatch:
    """ATC / THÖR rows (file order, checked by :func:`_checked_plain`) -> batch."""
    a = _checked_plain(path, _SPECS["atc"], layout, data)
    xyz = np.zeros((len(a), 3))
    xyz[:, :2] = a[:, 2:4]
    heading = np.mod(a[:, 5] + np.pi, 2 * np.pi) - np.pi
    return DetectionBatch.from_arrays(
        _seconds_to_ns(a[:, 0], start_ns, path), xyz, heading, a[:, 4], a[:, 1].astype(np.int64)
    )


def read_canonical(path: str | Path) -> DetectionBatch:
    """Read aion's canonical tracks CSV (exact int64 ``t_ns``)."""
    p = Path(path)
    rec = _load(p, _SPECS["canonical"], "canonical", _CANONICAL_DTYPE, ndmin=1)
    return _canonical_rows(p, rec).sorted_by_time()


def read_atc(path: str | Path, start_ns: int = 0, layout: str = "atc") -> DetectionBatch:
    """ATC / THÖR CSV: ``time_s, person_id, x_m, y_m, speed_mps, motion_angle_rad``.

    ``start_ns`` is added to the times (THÖR times start at 0; ATC's are UNIX seconds).
    Headings are wrapped to [-π, π).
    """
    p = Path(path)
    data = _load(p, _SPECS["atc"], layout, np.float64, ndmin=2)
    return _atc_rows(p, layout, data, start_ns).sorted_by_time()


#: Rows per chunk when a tracks file is streamed (``aion convert``) and when messages are
#: built: a chunk takes about 1 KB per row while it is written (TrackedPerson records are 712
#: bytes), so ~25 MB at most, whatever the file's length.
CHUNK_ROWS = 20_000
#: Layouts that can be streamed: one line is one detection, nothing needs the whole file.
STREAM_LAYOUTS: tuple[str, ...] = ("canonical", "atc", "thor")


def track_chunks(
    path: str | Path, layout: str = "canonical", start_ns: int = 0, rows: int | None = None
) -> Iterator[DetectionBatch]:
    """The detections of a canonical / ATC / THÖR file in *file* order, ``rows`` lines
    (default :data:`CHUNK_ROWS`) at a time (no chunk is empty), each chunk checked as
    :func:`read_tracks` checks the whole file (the same errors, naming the first bad line of
    the file). A file without rows is a :class:`TracksFormatError`. Memory: one chunk,
    whatever the file's length."""
    key = layout.lower()
    if key not in STREAM_LAYOUTS:
        raise TracksFormatError(
            f"the {layout!r} layout cannot be streamed", hint=f"use {', '.join(STREAM_LAYOUTS)}"
        )
    rows = CHUNK_ROWS if rows is None else rows
    if rows < 1:
        raise ValueError(f"rows must be >= 1, got {rows}")
    p = Path(path)
    spec = _SPECS["canonical" if key == "canonical" else "atc"]
    _check_file(p, spec, key)
    found = 0
    for lines in _line_chunks(p, spec, key, rows):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # a chunk of comments only
                data: Any = np.loadtxt(
                    lines,
                    dtype=_CANONICAL_DTYPE if key == "canonical" else np.float64,
                    delimiter=spec.delimiter,
                    ndmin=1 if key == "canonical" else 2,
                )
        except (ValueError, OverflowError) as exc:
            raise _fail(p, spec, key, str(exc)) from exc
        if data.size == 0:
            continue
        found += len(data)
        yield _canonical_rows(p, data) if key == "canonical" else _atc_rows(p, key, data, start_ns)
    if found == 0:
        raise TracksFormatError(f"{p}: no track rows", hint="the file is empty")


def _line_chunks(path: Path, spec: _Spec, layout: str, rows: int) -> Iterator[list[str]]:
    """The data lines of a file (after its header), ``rows`` at a time."""
    import itertools

    with path.open(encoding="utf-8-sig") as fh:
        try:
            for _ in range(spec.skip):
                fh.readline()
            while lines := list(itertools.islice(fh, rows)):
                yield lines
        except UnicodeDecodeError as exc:
            raise _fail(path, spec, layout, str(exc)) from exc


def finite_difference(t_ns: I64, track_id: I64, xy: F64) -> tuple[F64, F64]:
    """Heading (rad) and speed (m/s) per row from each track's neighbouring samples.

    Central difference between the previous and next sample of the same track, one-sided at a
    track's ends; NaN for single-sample tracks or zero time steps. Vectorized over all rows.
    (:func:`aion_cli.engine.tracking.difference_tracks` with ``min_step = 0``.)
    """
    return difference_tracks(t_ns, track_id, xy)


def read_eth(path: str | Path, fps: float = 25.0, start_ns: int = 0) -> DetectionBatch:
    """ETH/UCY ``frame ped_id x y`` (whitespace separated); ``t = start + frame / fps``."""
    if not fps > 0:
        raise TracksFormatError(f"fps must be > 0, got {fps}")
    p = Path(path)
    a = _plain_columns(p, _SPECS["eth"], "eth")
    t_ns = _seconds_to_ns(a[:, 0] / fps, start_ns, p)
    tid = a[:, 1].astype(np.int64)
    heading, speed = finite_difference(t_ns, tid, a[:, 2:4])
    xyz = np.zeros((len(a), 3))
    xyz[:, :2] = a[:, 2:4]
    return DetectionBatch.from_arrays(t_ns, xyz, heading, speed, tid).sorted_by_time()


# ----------------------------------------------------------------------------- Edinburgh

#: Edinburgh Informatics Forum: ground size of one image pixel (README of the database)
EDINBURGH_M_PER_PX = 0.0247
#: its capture rate, "about 9 frames per second" (it varies with the capture host's load)
EDINBURGH_FPS = 9.0
#: image height in pixels (640 x 480): rows are flipped so that y points up
EDINBURGH_HEIGHT_PX = 480

_EDINBURGH_TRACK = re.compile(r"TRACK\.R(\d+)\s*=\s*\[\s*(.*?)\]\s*\]\s*;", re.S)
_EDINBURGH_PROPERTIES = re.compile(r"Properties\.R(\d+)\s*=\s*\[\s*([0-9.eE+-]+)")
_EDINBURGH_HINT = (
    "Edinburgh tracks files hold `Properties.Rn=[...];` and `TRACK.Rn=[[x y frame];...];` "
    "entries (tracks.DDMon.txt of the Informatics Forum database)"
)


def _line_of(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def read_edinburgh(path: str | Path, start_ns: int = 0, fps: float = EDINBURGH_FPS) -> TrackData:
    """An Edinburgh Informatics Forum tracks file (``tracks.01Jul.txt``): Matlab-like
    ``TRACK.Rn=[[x y frame];...];`` entries, image pixels of an overhead camera and frame
    numbers (``../shared/data/tracks/edinburgh/README.opentraj.md``).

    Positions: ``x = px * 24.7 mm``, ``y = (480 - py) * 24.7 mm`` (image rows flipped so the map
    frame is right-handed, y up; origin at the image's bottom-left corner). Times: ``start_ns +
    frame / fps`` (about 9 fps; the files carry no clock time, so ``start_ns`` is when frame 0
    was captured). The track id is ``n`` of ``Rn``; heading and speed come from differencing
    each track. ``Properties.Rn`` (whose first value is the number of points) is checked
    against the track where present: a mismatch is a note, not an error.
    """
    if not fps > 0:
        raise TracksFormatError(f"fps must be > 0, got {fps}")
    p = Path(path)
    if not p.is_file():
        raise TracksFormatError(f"tracks file not found: {p}")
    text = p.read_text(encoding="utf-8-sig", errors="replace")
    if not text.strip():
        raise TracksFormatError(f"{p}: no track rows", hint="the file is empty")
    found = list(_EDINBURGH_TRACK.finditer(text))
    entries = [m.start() for m in re.finditer(r"TRACK\.R", text)]
    if not found:
        raise TracksFormatError(f"{p}: no TRACK.Rn=[[x y frame];...]; entry", hint=_EDINBURGH_HINT)
    if len(found) != len(entries):
        parsed = {m.start() for m in found}
        bad = next(pos for pos in entries if pos not in parsed)
        raise TracksFormatError(
            f"{p}: line {_line_of(text, bad)}: a TRACK entry that is not [[x y frame];...];",
            hint=_EDINBURGH_HINT,
        )
    ids = np.array([int(m.group(1)) for m in found], dtype=np.int64)
    if len(np.unique(ids)) != len(ids):
        dup = int(ids[np.flatnonzero(np.bincount(np.unique(ids, return_inverse=True)[1]) > 1)[0]])
        raise TracksFormatError(f"{p}: track R{dup} is defined twice", hint=_EDINBURGH_HINT)
    # one C-speed parse of every point: each track's points become "x y frame" lines
    bodies = [re.sub(r"\]\s*;\s*\[", "\n", m.group(2)).replace("[", " ") for m in found]
    counts = np.array([b.count("\n") + 1 for b in bodies], dtype=np.int64)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            points = np.loadtxt(io.StringIO("\n".join(bodies)), dtype=np.float64, ndmin=2)
    except ValueError as exc:
        raise _edinburgh_problem(p, text, found) from exc
    if points.shape != (int(counts.sum()), 3) or not np.isfinite(points).all():
        raise _edinburgh_problem(p, text, found)
    if (points[:, 2] != np.round(points[:, 2])).any() or (points[:, 2] < 0).any():
        raise _edinburgh_problem(p, text, found)
    tid = np.repeat(ids, counts)
    notes = _edinburgh_count_notes(p, text, ids, counts)
    t_ns = _seconds_to_ns(points[:, 2] / fps, start_ns, p)
    xyz = np.zeros((len(points), 3))
    xyz[:, 0] = points[:, 0] * EDINBURGH_M_PER_PX
    xyz[:, 1] = (EDINBURGH_HEIGHT_PX - points[:, 1]) * EDINBURGH_M_PER_PX
    heading, speed = finite_difference(t_ns, tid, xyz[:, :2])
    batch = DetectionBatch.from_arrays(t_ns, xyz, heading, speed, tid).sorted_by_time()
    return TrackData(batch, notes=notes)


def _edinburgh_problem(path: Path, text: str, found: list[re.Match[str]]) -> TracksFormatError:
    """The first TRACK point that is not three numbers (slow path, after a failed parse)."""
    for m in found:
        for k, point in enumerate(re.split(r"\]\s*;\s*\[", m.group(2).strip("[] \n\t"))):
            values = point.split()
            try:
                numbers = [float(v) for v in values]
            except ValueError:
                numbers = []
            ok = len(numbers) == 3 and all(math.isfinite(v) for v in numbers)
            if ok and numbers[2].is_integer() and numbers[2] >= 0:
                continue
            return TracksFormatError(
                f"{path}: line {_line_of(text, m.start())}: TRACK.R{m.group(1)} point {k + 1}: "
                f"expected [x y frame] (numbers, a whole frame), got [{point.strip()[:40]}]",
                hint=_EDINBURGH_HINT,
            )
    return TracksFormatError(f"{path}: unreadable TRACK entries", hint=_EDINBURGH_HINT)


def _edinburgh_count_notes(
    path: Path, text: str, ids: I64, counts: I64
) -> tuple[str, ...]:
    """A note when ``Properties.Rn``'s point count differs from the track's (none when the
    file has no properties)."""
    declared = {int(m.group(1)): float(m.group(2)) for m in _EDINBURGH_PROPERTIES.finditer(text)}
    if not declared:
        return ()
    wrong = [int(i) for i, n in zip(ids.tolist(), counts.tolist(), strict=True)
             if i in declared and declared[i] != n]
    if not wrong:
        return ()
    return (
        f"{path.name}: {len(wrong)} track(s) hold another number of points than their "
        f"Properties entry says (first: R{wrong[0]}); the points are used as they are",
    )


# ----------------------------------------------------------------------------- THÖR-MAGNI

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
    by 1000); ``units="auto"`` takes millimetres when the positions span more than 200 units
    and metres otherwise, with a note saying which; ``"mm"`` / ``"m"`` force it. Rows without a
    position (untracked frames, empty ``x`` / ``y``) are dropped, with a note. Only people are
    kept: agents whose ``ag_id`` starts with ``Helmet`` when there are any (the robot and
    objects are dropped, with a note), else every agent. ``ag_id`` strings become integer
    track ids: the number that ends the name (``Helmet_3`` -> 3) when those are unique, else
    the name's rank. Heading and speed come from differencing each track.
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
    except ValueError as exc:
        raise TracksFormatError(
            f"{p}: not a valid thor-magni tracks file: {exc}",
            hint="every row needs the header's columns, comma-separated",
        ) from exc
    if table.size == 0:
        raise TracksFormatError(f"{p}: no track rows", hint="the file has only its header")
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
    if not keep.any():
        raise TracksFormatError(f"{p}: no row with a position", hint="x and y are all empty")
    t_s, x, y, z, names = t_s[keep], x[keep], y[keep], z[keep], names[keep]
    scale = _thor_magni_scale(p, x, y, units, notes)
    tid = _agent_ids(names)
    xyz = np.stack([x, y, np.nan_to_num(z)], axis=1) * scale
    t_ns = _seconds_to_ns(t_s, start_ns, p)
    heading, speed = finite_difference(t_ns, tid, xyz[:, :2])
    batch = DetectionBatch.from_arrays(t_ns, xyz, heading, speed, tid).sorted_by_time()
    return TrackData(batch, notes=tuple(notes))


def _thor_magni_header(path: Path) -> dict[str, int]:
    """Column name -> index of a THÖR-MAGNI CSV's header, with the required ones checked."""
    if not path.is_file():
        raise TracksFormatError(f"tracks file not found: {path}")
    if path.stat().st_size == 0:
        raise TracksFormatError(f"{path}: no track rows", hint="the file is empty")
    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        first = fh.readline().strip()
    names = [name.strip().strip('"') for name in first.split(",")]
    columns = {name: k for k, name in reversed(list(enumerate(names)))}
    missing = [name for name in THOR_MAGNI_REQUIRED if name not in columns]
    if missing:
        raise TracksFormatError(
            f"{path}: line 1 must be a THÖR-MAGNI header with the columns "
            f"{', '.join(THOR_MAGNI_REQUIRED)}; {', '.join(missing)} missing (got {first[:80]!r})",
            hint="THÖR-MAGNI CSVs start `Time,frame_id,x,y,z,ag_id,data_label,...`",
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
                f"{path}: line {int(bad[0]) + 2}, column {name}: {str(text[bad[0]])!r} is not "
                "a finite number"
            )
    return values


def _thor_magni_scale(path: Path, x: F64, y: F64, units: str, notes: list[str]) -> float:
    """Metres per file unit: 1e-3 for millimetres, 1 for metres (``auto``: by the extent)."""
    extent = float(max(np.ptp(x), np.ptp(y)))
    if units == "auto":
        units = "mm" if extent > _MM_EXTENT else "m"
        span = extent / 1000 if units == "mm" else extent
        notes.append(
            f"{path.name}: positions read as {'millimetres' if units == 'mm' else 'metres'} "
            f"(they span {span:,.1f} m); give --length-unit mm|m if that is wrong"
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


# ----------------------------------------------------------------------------- Lincoln

#: how long a sentinel row (x = y = 0: "the sensor was running") marks as observed
SENTINEL_SPAN_NS = 1_000_000_000
#: a declared recording span reaching further than this beyond the detections gets a note
DECLARED_SLACK_NS = 86_400 * 1_000_000_000

_LINCOLN_XY = ("time_s", "x_m", "y_m")
_LINCOLN_SPECS: dict[str, _Spec] = {
    # 2017-06-09.txt: `t_start t_end`, `x_min x_max`, `y_min y_max`, then `t x y`
    "header": _Spec(_LINCOLN_XY, frozenset(), frozenset({0, 1, 2}), None, None, header_lines=3),
    "xy": _Spec(_LINCOLN_XY, frozenset(), frozenset({0, 1, 2}), None, None),
    # 2017-05-24_25.txt: `t x y 1.0`
    "xy1": _Spec(
        (*_LINCOLN_XY, "one"),
        frozenset(),
        frozenset({0, 1, 2}),
        None,
        None,
        ignored_columns=frozenset({3}),
    ),
    # 2017-05-25.txt, 2017-05-26.txt: `t x y a b WPn` (a, b undocumented; WPn: robot waypoint)
    "waypoint": _Spec(
        (*_LINCOLN_XY, "a", "b", "waypoint"),
        frozenset(),
        frozenset({0, 1, 2}),
        None,
        None,
        ignored_columns=frozenset({3, 4, 5}),
    ),
    # 2017-05-31_heading.csv: `t, id, x, y, z, heading_rad` (id always 0)
    "heading": _Spec(
        ("time_s", "id", "x_m", "y_m", "z_m", "heading_rad"),
        frozenset(),
        frozenset({0, 2, 3}),
        ",",
        None,
        ignored_columns=frozenset({1}),
    ),
}
_LINCOLN_BY_FIELDS = {3: "xy", 4: "xy1", 6: "waypoint"}


@dataclass(frozen=True)
class TrackData:
    """A tracks file read whole: its detections and when the sensor was recording.

    ``observed`` lists sorted, disjoint, half-open ``[start, end)`` UNIX-ns spans in which the
    sensor ran (empty: the file does not say; do not take its time span as observed).
    ``notes`` are one-line remarks about the file for the user. ``detector_heading`` is a
    heading column the file itself carries (rad, aligned with ``batch`` rows), else None.
    """

    batch: DetectionBatch
    observed: list[tuple[int, int]] = field(default_factory=list)
    notes: tuple[str, ...] = ()
    detector_heading: F64 | None = None


def merge_spans(spans: Iterable[tuple[int, int]]) -> list[tuple[int, int]]:
    """Sorted union of half-open ``[start, end)`` spans (overlapping or touching ones joined).

    Raises :class:`InputError` for a span whose end is not after its start.
    """
    items = sorted((int(a), int(b)) for a, b in spans)
    for a, b in items:
        if b <= a:
            raise InputError(
                f"observed span {a}..{b} ns ends before it starts",
                hint="give each span as START..END with END after START",
            )
    merged: list[tuple[int, int]] = []
    for a, b in items:
        if merged and a <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], b))
        else:
            merged.append((a, b))
    return merged


def sessions(t_ns: npt.ArrayLike, gap_ns: int) -> list[tuple[int, int]]:
    """Recording sessions of a set of detection times: the times split wherever two successive
    detections are more than ``gap_ns`` apart, each session spanning ``[first, last + 1 ns)``
    (half-open, so its last detection is inside).

    Used to declare what a header-less dataset observed: a corridor dataset recorded on
    several days has sessions of hours separated by nights. Empty input: no sessions.
    """
    if not gap_ns > 0:
        raise InputError(f"the session gap must be > 0 ns, got {gap_ns}")
    t = np.unique(np.asarray(t_ns, dtype=np.int64))
    if t.size == 0:
        return []
    cut = np.flatnonzero(np.diff(t) > gap_ns)
    starts = np.concatenate([[0], cut + 1])
    ends = np.concatenate([cut, [len(t) - 1]])
    return [(int(a), int(b) + 1) for a, b in zip(t[starts], t[ends], strict=True)]


def _first_data_line(path: Path) -> tuple[int, str]:
    """Line number and text of the first line that is neither blank nor a comment."""
    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        for lineno, raw in enumerate(fh, start=1):
            line = raw.split("#", 1)[0].strip()
            if line:
                return lineno, line
    raise TracksFormatError(f"{path}: no track rows", hint="the file is empty")


def _lincoln_variant(path: Path) -> str:
    """Which Lincoln variant ``path`` is, from its first line: commas -> the heading CSV, two
    numbers -> the header of declared spans, else by the number of columns (3, 4 or 6)."""
    lineno, line = _first_data_line(path)
    if lineno != 1:  # header lines are counted from the top: no blank lines or comments first
        raise TracksFormatError(
            f"{path}: line {lineno}: Lincoln files start with data or the header on line 1"
        )
    if "," in line:
        return "heading"
    fields = line.split()
    if len(fields) == 2:
        return "header"
    if len(fields) in _LINCOLN_BY_FIELDS:
        return _LINCOLN_BY_FIELDS[len(fields)]
    raise TracksFormatError(
        f"{path}: line 1 has {len(fields)} columns: not a Lincoln corridor file",
        hint="Lincoln rows are `t x y`, `t x y 1.0`, `t x y a b WPn` or `t, id, x, y, z, heading`"
        ", optionally after a 3-line header `t_start t_end` / `x_min x_max` / `y_min y_max`",
    )


def _lincoln_header(path: Path) -> tuple[int, int]:
    """The declared recorded span ``[t_start, t_end)`` (ns) of a 3-line Lincoln header."""
    names = ("t_start t_end", "x_min x_max", "y_min y_max")
    pairs: list[tuple[float, float]] = []
    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        for lineno, name in enumerate(names, start=1):
            text = fh.readline().strip()
            try:
                lo, hi = (float(v) for v in text.split())
            except ValueError:
                lo = hi = math.nan
            if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
                raise TracksFormatError(
                    f"{path}: line {lineno}: expected the header `{name}` (two numbers, the "
                    f"second larger), got {text[:80]!r}"
                )
            pairs.append((lo, hi))
    (t0, t1) = pairs[0]
    return round(t0 * 1e6) * 1000, round(t1 * 1e6) * 1000


def _utc(t_ns: int) -> str:
    return datetime.fromtimestamp(t_ns / 1e9, UTC).strftime("%Y-%m-%d %H:%M:%S")


def read_lincoln(path: str | Path, linker: LinkerConfig | None = None) -> TrackData:
    """A Lincoln (L-CAS) corridor file, any of its variants (``../shared/data/README.md``).

    The variant is told by content (:func:`_lincoln_variant`); only ``t x y`` (UNIX seconds,
    metres) are read from the 4- and 6-column files. The detections have no ids: they are
    linked into tracks (:func:`aion_cli.engine.tracking.link_tracks` with ``linker``), which
    gives the track ids, headings and speeds. The 2017-05-31 CSV's own heading column is kept
    as ``detector_heading`` but not used: on that file it points opposite (π off) to the
    direction the linked tracks move for most walking detections, so it is not a walking
    direction in the map's convention.

    Observed spans: the declared header span ``[t_start, t_end)`` (used as declared, with a
    note when it reaches more than a day beyond the detections, as 2017-06-09.txt's does),
    and ``[t, t + 1 s)`` around every sentinel row (x = y = 0, "the sensor was running"),
    which is not a detection. A file with neither gives no observed spans.
    """
    from aion_cli.engine.tracking import link_tracks

    p = Path(path)
    _check_file(p, _LINCOLN_SPECS["xy"], "lincoln")
    variant = _lincoln_variant(p)
    spec = _LINCOLN_SPECS[variant]
    declared = _lincoln_header(p) if variant == "header" else None
    a = _plain_columns(p, spec, "lincoln")
    if variant == "heading":
        t_s, xyz, own = a[:, 0], a[:, 2:5], np.mod(a[:, 5] + np.pi, 2 * np.pi) - np.pi
    else:
        t_s, xyz, own = a[:, 0], np.c_[a[:, 1:3], np.zeros(len(a))], None
    t_ns = _seconds_to_ns(t_s, path=p)
    sentinel = (xyz[:, 0] == 0) & (xyz[:, 1] == 0)
    spans = [(t, t + SENTINEL_SPAN_NS) for t in np.unique(t_ns[sentinel]).tolist()]
    people = ~sentinel
    order = np.flatnonzero(people)[np.argsort(t_ns[people], kind="stable")]
    t_ns, xyz = t_ns[order], xyz[order]
    links = link_tracks(t_ns, xyz, linker)
    batch = DetectionBatch(t_ns, xyz, links.heading, links.speed, links.track_id)
    notes: list[str] = []
    if declared is not None:
        start, end = declared
        spans.append((start, end))
        if len(t_ns) and (
            t_ns[0] - start > DECLARED_SLACK_NS or end - t_ns[-1] > DECLARED_SLACK_NS
        ):
            notes.append(
                f"{p.name}: the header declares recording from {_utc(start)} to {_utc(end)} UTC"
                f" but the detections run from {_utc(int(t_ns[0]))} to {_utc(int(t_ns[-1]))};"
                " the declared span is used as observed"
            )
    return TrackData(batch, merge_spans(spans), tuple(notes), None if own is None else own[order])


def read_tracks(
    path: str | Path, layout: str = "canonical", start_ns: int = 0, fps: float | None = None
) -> DetectionBatch:
    """Read a tracks file of ``layout`` into a time-sorted :class:`DetectionBatch`.

    ``start_ns`` shifts THÖR / THÖR-MAGNI / ETH / UCY / ATC times and is when frame 0 of an
    Edinburgh file was captured (Lincoln times are UNIX already and are not shifted); ``fps``
    is the ETH/UCY (default 25) or Edinburgh (default about 9) frame rate.
    """
    return read_track_data(path, layout, start_ns, fps).batch


def read_track_data(
    path: str | Path,
    layout: str = "canonical",
    start_ns: int = 0,
    fps: float | None = None,
    linker: LinkerConfig | None = None,
    units: str = "auto",
) -> TrackData:
    """A tracks file of ``layout`` read whole: the time-sorted detections plus what the file
    says about itself: the Lincoln layout's declared and sentinel spans (:func:`read_lincoln`,
    linked with ``linker``), and notes (Edinburgh point counts, THÖR-MAGNI's skipped rows and
    agents and its length unit, ``units``); the other layouts declare nothing (``observed``
    empty). ``start_ns`` and ``fps`` as in :func:`read_tracks`."""
    key = layout.lower()
    if key == "canonical":
        return TrackData(read_canonical(path))
    if key in ("atc", "thor"):
        return TrackData(read_atc(path, start_ns, key))
    if key in ("eth", "ucy"):
        return TrackData(read_eth(path, 25.0 if fps is None else fps, start_ns))
    if key == "lincoln":
        return read_lincoln(path, linker)
    if key == "edinburgh":
        return read_edinburgh(path, start_ns, EDINBURGH_FPS if fps is None else fps)
    if key == "thor-magni":
        return read_thor_magni(path, start_ns, units)
    raise TracksFormatError(f"unknown tracks layout {layout!r}", hint=f"use {', '.join(LAYOUTS)}")


def write_canonical_csv(batch: DetectionBatch, path: str | Path) -> None:
    """Write ``batch`` as aion's canonical tracks CSV (positions to 1 µm, angles to 1 nrad)."""
    names = ("t", "k", "x", "y", "z", "h", "s")
    table = np.empty(len(batch), dtype=[(f, "i8" if f in "tk" else "f8") for f in names])
    table["t"], table["k"] = batch.t_ns, batch.track_id
    table["x"], table["y"], table["z"] = batch.xyz.T
    table["h"], table["s"] = batch.heading, batch.speed
    np.savetxt(
        Path(path),
        table,
        fmt=["%d", "%d", "%.6f", "%.6f", "%.6f", "%.9f", "%.6f"],
        delimiter=",",
        header=CANONICAL_HEADER,
        comments="",
    )


# ----------------------------------------------------------------------------- logs

SPENCER_TRACKED = "spencer_tracking_msgs/msg/TrackedPersons"
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
DSG_UPDATE = "hydra_msgs/msg/DsgUpdate"
#: spencer convention: a variance above 99999 marks a velocity / orientation as "not set"
UNSET_VARIANCE = 1e6


@dataclass(frozen=True)
class TracksLogSummary:
    """What :func:`tracks_to_log` wrote: messages with detections, empty "still observing"
    messages over the ``observed`` spans, scene-graph messages, and the time span of all
    messages (``start_ns``..``end_ns``, inclusive)."""

    path: Path
    detection_messages: int
    detections: int
    graph_messages: int
    start_ns: int
    end_ns: int
    observed_messages: int = 0
    observed_spans: int = 0
    observed_ns: int = 0
    #: distinct track ids among the detections
    tracks: int = 0


#: interval of the empty detection messages over an observed span: far below any sane
#: observation window (aion's default is 600 s), so every window the span touches holds one
OBSERVED_INTERVAL_NS = 30 * 1_000_000_000


def observed_stamps(
    spans: Iterable[tuple[int, int]], interval_ns: int = OBSERVED_INTERVAL_NS
) -> I64:
    """Stamps of the empty detection messages that mark ``spans`` (half-open ``[start, end)``
    ns, merged first) as observed: ``start, start + interval, ...`` while before ``end``, and
    the span's last instant ``end - 1 ns``, so a window that overlaps a span only briefly at
    either end still gets a message. Sorted, unique."""
    if not interval_ns > 0:
        raise InputError(f"the observed-message interval must be > 0 ns, got {interval_ns}")
    parts = [
        np.append(np.arange(a, b, interval_ns, dtype=np.int64), np.int64(b - 1))
        for a, b in merge_spans(spans)
    ]
    return np.unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)


def _group_keys(t_ns: I64, group_ns: int, t0: int) -> I64:
    """The message each time-sorted row goes into: one message per distinct time, or per
    ``group_ns`` bin counted from ``t0`` (the first detection) when ``group_ns > 0``."""
    return t_ns if group_ns <= 0 else (t_ns - np.int64(t0)) // group_ns


def _group_bounds(t_ns: I64, group_ns: int, t0: int | None = None) -> tuple[I64, I64]:
    """Message stamps and split points of time-sorted rows (:func:`_group_keys`; a bin's
    message is stamped at its first detection)."""
    key = _group_keys(t_ns, group_ns, int(t_ns[0]) if t0 is None else t0)
    _, first = np.unique(key, return_index=True)
    return t_ns[first], first[1:]


def _orientation_velocity(batch: DetectionBatch) -> tuple[F64, F64, BoolA, BoolA]:
    """Yaw quaternions (x, y, z, w) from the headings and planar velocities from heading and
    speed, with masks of which are known (unknown: identity / zero, flagged by the caller)."""
    known_h = np.isfinite(batch.heading)
    known_v = known_h & np.isfinite(batch.speed)
    h = np.where(known_h, batch.heading, 0.0)
    quat = np.zeros((len(batch), 4))
    quat[:, 2], quat[:, 3] = np.sin(h / 2), np.cos(h / 2)
    s = np.where(known_v, batch.speed, 0.0)
    vel = np.zeros((len(batch), 3))
    vel[:, 0], vel[:, 1] = s * np.cos(h), s * np.sin(h)
    return quat, vel, known_h, known_v


# spencer_tracking_msgs/TrackedPerson on the wire: uint64 track_id, bool is_occluded, bool
# is_matched, uint64 detection_id, duration age, PoseWithCovariance, TwistWithCovariance.
# CDR aligns the uint64s to 8 (record 712 bytes, a multiple of 8); ROS 1 packs (706 bytes).
# The same offsets are what formats.detections.fast reads.
_TP_NAMES = (
    "track_id",
    "is_occluded",
    "is_matched",
    "detection_id",
    "age_sec",
    "age_nsec",
    "pose",
    "pose_cov",
    "twist",
    "twist_cov",
)
_TP_LAYOUT = {
    True: ((0, 8, 9, 16, 24, 28, 32, 88, 376, 424), 712, "<u4"),
    False: ((0, 8, 9, 10, 18, 22, 26, 82, 370, 418), 706, "<i4"),
}
_CDR_LE = b"\x00\x01\x00\x00"  # CDR little-endian encapsulation header


def _tracked_person_records(
    batch: DetectionBatch, cdr: bool, first_id: int = 0
) -> npt.NDArray[np.void]:
    """Every row's serialized TrackedPerson, built in one go as a structured array; detection
    ids count from ``first_id`` (the row's index in the whole log)."""
    offsets, itemsize, nsec_type = _TP_LAYOUT[cdr]
    formats = [
        "<u8",
        "u1",
        "u1",
        "<u8",
        "<i4",
        nsec_type,
        ("<f8", (7,)),
        ("<f8", (36,)),
        ("<f8", (6,)),
        ("<f8", (36,)),
    ]
    dtype = np.dtype(
        {"names": _TP_NAMES, "formats": formats, "offsets": offsets, "itemsize": itemsize}
    )
    quat, vel, known_h, known_v = _orientation_velocity(batch)
    rec = np.zeros(len(batch), dtype=dtype)
    rec["track_id"] = batch.track_id.astype(np.uint64)
    rec["is_matched"] = 1
    rec["detection_id"] = np.arange(first_id, first_id + len(batch), dtype=np.uint64)
    rec["pose"][:, :3] = batch.xyz
    rec["pose"][:, 3:] = quat
    rec["pose_cov"][~known_h, 35] = UNSET_VARIANCE
    rec["twist"][:, :3] = vel
    unset_v = np.flatnonzero(~known_v)
    for k in (0, 7, 14):  # the x, y, z velocity variances
        rec["twist_cov"][unset_v, k] = UNSET_VARIANCE
    return rec


def _tracked_persons_bytes(
    records: npt.NDArray[np.void], t_ns: int, frame_id: str, cdr: bool, seq: int
) -> bytes:
    """A whole serialized TrackedPersons message: header, count, then the records' bytes."""
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    frame = frame_id.encode()
    count = struct.pack("<I", len(records))
    if not cdr:  # ROS 1: seq, time, string without terminator, packed
        head = struct.pack("<IIII", seq, sec, nsec, len(frame)) + frame
        return head + count + records.tobytes()
    frame += b"\x00"
    head = struct.pack("<iII", sec, nsec, len(frame)) + frame
    head += b"\x00" * (-len(head) % 4) + count
    head += b"\x00" * (-len(head) % 8 if len(records) else 0)  # first uint64 aligned to 8
    return _CDR_LE + head + records.tobytes()


def _pose_array_message(
    t_ns: int, xyz: list[list[float]], quat: list[list[float]], frame_id: str
) -> dict[str, Any]:
    """A geometry_msgs/PoseArray dict (ROS 2 naming) for one stamp's rows."""
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    poses = [
        {
            "position": {"x": p[0], "y": p[1], "z": p[2]},
            "orientation": {"x": q[0], "y": q[1], "z": q[2], "w": q[3]},
        }
        for p, q in zip(xyz, quat, strict=True)
    ]
    return {
        "header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": frame_id},
        "poses": poses,
    }


def _graph_payload(graph_file: str | Path) -> bytes:
    """spark_dsg binary of a graph file, mesh included, as Hydra publishes it."""
    from formats.dsg import load_dsg_file

    payload: bytes = load_dsg_file(graph_file).to_binary(True)
    return payload


def tracks_to_log(
    batch: DetectionBatch,
    out_path: str | Path,
    graph_file: str | Path | None = None,
    container: str = "mcap",
    topic: str = "/people_tracker/tracked_persons",
    msgtype: str = SPENCER_TRACKED,
    frame_id: str = "map",
    group_ns: int = 0,
    graph_topic: str = "/hydra/backend/dsg",
    graph_period_s: float = 60.0,
    overwrite: bool = False,
    observed: Iterable[tuple[int, int]] = (),
) -> TracksLogSummary:
    """Write ``batch`` as a people-tracking log that ``aion build`` reads like a robot's.

    One ``msgtype`` message (spencer ``TrackedPersons`` with velocity from heading and speed,
    or ``PoseArray`` with the heading as yaw) per distinct timestamp, or per ``group_ns`` bin;
    positions are in ``frame_id`` (the map, so no ``/tf`` is needed). With ``graph_file``, a
    ``hydra_msgs/DsgUpdate`` carrying the whole graph (mesh included) is written at the first
    stamp and again every ``graph_period_s`` so a reader joining late still gets it.
    Unknown headings / speeds are marked with the spencer "unset" variance.

    ``observed`` lists the half-open ``[start, end)`` ns spans in which the sensor was
    recording. A fixed sensor's log counts as observed only in the windows in which it holds
    a message, so over these spans empty messages (same topic and type, no people) are
    written as a running tracker publishes them, at :func:`observed_stamps` (every
    :data:`OBSERVED_INTERVAL_NS`), merged in time order with the detection messages.
    Without spans only the detections are written: windows without one count as unobserved.
    The batch may be empty when spans are given (the sensor ran, nobody came).

    Times must lie in ``0 .. 2^63 - 1`` ns (:class:`formats.writers.LogTimeError`, raised
    before anything is written). The messages are built :data:`CHUNK_ROWS` rows at a time
    (:func:`stream_tracks_to_log` reads the file that way too).
    """
    if len(batch) == 0 and not merge_spans(observed):
        raise InputError("no detections to write", hint="the tracks file has no rows")
    data = batch.sorted_by_time()
    n, step = len(data), CHUNK_ROWS
    chunks = (data.select(np.arange(a, min(a + step, n))) for a in range(0, n, step))
    return _write_tracks(
        chunks, out_path, graph_file=graph_file, container=container, topic=topic,
        msgtype=msgtype, frame_id=frame_id, group_ns=group_ns, graph_topic=graph_topic,
        graph_period_s=graph_period_s, overwrite=overwrite, observed=observed,
    )


def stream_tracks_to_log(
    tracks: str | Path,
    out_path: str | Path,
    layout: str = "canonical",
    start_ns: int = 0,
    rows: int | None = None,
    **options: Any,
) -> TracksLogSummary:
    """:func:`tracks_to_log` of a canonical / ATC / THÖR file (:data:`STREAM_LAYOUTS`) read
    ``rows`` lines (default :data:`CHUNK_ROWS`) at a time: memory for one chunk, whatever the
    file's length, and the same log as reading the whole file. That needs the file in time
    order, chunk after chunk (rows within a chunk may be in any order); if a chunk starts
    before the previous one ended, the partial log is thrown away and the file is read whole
    (memory ~70 bytes per row) and sorted, as :func:`read_tracks` does. ``options``: those
    of :func:`tracks_to_log`."""
    chunks = (c.sorted_by_time() for c in track_chunks(tracks, layout, start_ns, rows))
    try:
        return _write_tracks(chunks, out_path, **options)
    except _UnsortedError:
        return tracks_to_log(read_tracks(tracks, layout, start_ns), out_path, **options)


class _UnsortedError(Exception):
    """A chunk starts before the previous one ended (streamed input out of time order)."""


def _check_log_times(t_ns: I64, what: str) -> None:
    """Log times are nanoseconds since 1970 in ``0 .. 2^63 - 1`` (int64 holds no more):
    a time before 1970 is a :class:`formats.writers.LogTimeError` naming it."""
    if len(t_ns) and int(t_ns.min()) < 0:
        from formats.writers import MAX_LOG_TIME_NS, LogTimeError

        first = int(t_ns.min())
        raise LogTimeError(
            f"{what} have times before 1970, the first at log time {first} ns "
            f"({_utc(first)} UTC): log times are nanoseconds since 1970 in "
            f"0..{MAX_LOG_TIME_NS} (1970-01-01 to 2262-04-11)",
            hint="shift the times (--start for layouts that count from 0) or drop those rows",
        )


@dataclass
class _Messages:
    """Writes the messages of a tracks log in time order: detection messages (a group of
    rows each), the empty "still observing" messages at ``marks`` (after a detection message
    of the same time), and the scene graph every ``period`` ns from the first message."""

    writer: Any
    kind: str
    topic: str
    frame_id: str
    marks: I64
    payload: bytes | None
    graph_topic: str
    period: int
    next_mark: int = 0
    seq: int = 0  # detection and mark messages written (their ROS 1 header seq)
    graph_next: int | None = None
    graphs: int = 0
    first_ns: int | None = None
    last_ns: int | None = None

    def rows(self, data: DetectionBatch, stamps: I64, splits: I64, first_id: int) -> None:
        """One message per group of ``data`` (time-sorted rows, groups split at ``splits``
        and stamped ``stamps``); ``first_id`` numbers the rows (TrackedPerson ids)."""
        cdr = self.writer.ros_version == 2
        if self.kind == SPENCER_TRACKED:
            records = _tracked_person_records(data, cdr, first_id)
        else:
            quat = _orientation_velocity(data)[0].tolist()
            xyz = data.xyz.tolist()
        bounds = np.concatenate([[0], splits, [len(data)]]).tolist()
        for t, a, b in zip(stamps.tolist(), bounds[:-1], bounds[1:], strict=True):
            self.marks_before(t)
            self._before(t)
            if self.kind == SPENCER_TRACKED:
                raw = _tracked_persons_bytes(records[a:b], t, self.frame_id, cdr, self.seq)
                self.writer.write_raw(self.topic, self.kind, raw, t)
            else:
                msg = _pose_array_message(t, xyz[a:b], quat[a:b], self.frame_id)
                self.writer.write(self.topic, self.kind, msg, t)
            self.seq += 1

    def marks_before(self, t: int | None) -> None:
        """The empty messages stamped before ``t`` (all that are left when None)."""
        end = len(self.marks) if t is None else int(np.searchsorted(self.marks, t, "left"))
        cdr = self.writer.ros_version == 2
        for m in self.marks[self.next_mark : end].tolist():
            self._before(m)
            if self.kind == SPENCER_TRACKED:
                empty = _tracked_persons_bytes(_NO_RECORDS[cdr], m, self.frame_id, cdr, self.seq)
                self.writer.write_raw(self.topic, self.kind, empty, m)
            else:
                self.writer.write(self.topic, self.kind, _pose_array_message(
                    m, [], [], self.frame_id), m)
            self.seq += 1
        self.next_mark = max(self.next_mark, end)

    def _before(self, t: int) -> None:
        """Bookkeeping before a message at ``t``: the scene graphs due by then."""
        from formats.writers import stamp

        if self.first_ns is None:
            self.first_ns = t
            self.graph_next = t if self.payload is not None else None
        self.last_ns = t
        while self.graph_next is not None and self.graph_next <= t:
            g = self.graph_next
            self.writer.write(
                self.graph_topic,
                DSG_UPDATE,
                {
                    "header": {"stamp": stamp(g), "frame_id": self.frame_id},
                    "layer_contents": self.payload,
                    "full_update": True,
                    "sequence_number": self.graphs,
                },
                g,
            )
            self.graphs += 1
            self.graph_next = g + self.period


_NO_RECORDS = {cdr: np.zeros(0, dtype=_tracked_person_records(DetectionBatch.empty(), cdr).dtype)
               for cdr in (True, False)}


def _write_tracks(
    chunks: Iterable[DetectionBatch],
    out_path: str | Path,
    graph_file: str | Path | None = None,
    container: str = "mcap",
    topic: str = "/people_tracker/tracked_persons",
    msgtype: str = SPENCER_TRACKED,
    frame_id: str = "map",
    group_ns: int = 0,
    graph_topic: str = "/hydra/backend/dsg",
    graph_period_s: float = 60.0,
    overwrite: bool = False,
    observed: Iterable[tuple[int, int]] = (),
) -> TracksLogSummary:
    """:func:`tracks_to_log` over time-sorted ``chunks`` (each sorted; a chunk starting
    before the previous one ended raises :class:`_UnsortedError`, the partial log thrown
    away). The rows of a chunk's last message are held back until the next chunk shows it is
    complete, so the messages are those of the concatenated rows."""
    from formats.raw import normalize_msgtype
    from formats.writers import LogWriter

    kind = normalize_msgtype(msgtype)
    if kind not in (SPENCER_TRACKED, POSE_ARRAY):
        raise InputError(
            f"cannot write tracks as {msgtype!r}", hint=f"use {SPENCER_TRACKED} or {POSE_ARRAY}"
        )
    if not graph_period_s > 0:
        raise InputError(f"graph period must be > 0 s, got {graph_period_s}")
    spans = merge_spans(observed)
    marks = observed_stamps(spans)
    _check_log_times(marks, "the observed spans")
    payload = _graph_payload(graph_file) if graph_file is not None else None
    rows = groups = 0
    track_ids = np.zeros(0, np.int64)
    with LogWriter(out_path, container, overwrite=overwrite) as writer:
        out = _Messages(
            writer, kind, topic, frame_id, marks, payload, graph_topic, round(graph_period_s * 1e9)
        )
        held: DetectionBatch | None = None  # the rows of the last, maybe unfinished, message
        t0: int | None = None
        for chunk in chunks:
            if len(chunk) == 0:
                continue
            _check_chunk(chunk, kind, held)
            t0 = int(chunk.t_ns[0]) if t0 is None else t0
            track_ids = np.union1d(track_ids, chunk.track_id)
            data = chunk if held is None else DetectionBatch.concat([held, chunk])
            keys = _group_keys(data.t_ns, group_ns, t0)
            cut = int(np.searchsorted(keys, keys[-1], "left"))  # the last message's rows
            if cut > 0:
                done = data.select(np.arange(cut))
                stamps, splits = _group_bounds(done.t_ns, group_ns, t0)
                out.rows(done, stamps, splits, rows)
                rows, groups = rows + cut, groups + len(stamps)
            held = data.select(np.arange(cut, len(data)))
        if held is not None:
            stamps, splits = _group_bounds(held.t_ns, group_ns, t0)
            out.rows(held, stamps, splits, rows)
            rows, groups = rows + len(held), groups + len(stamps)
        if rows == 0 and not spans:
            raise InputError("no detections to write", hint="the tracks file has no rows")
        out.marks_before(None)
    assert out.first_ns is not None
    assert out.last_ns is not None
    return TracksLogSummary(
        Path(out_path),
        groups,
        rows,
        out.graphs,
        out.first_ns,
        out.last_ns,
        observed_messages=len(marks),
        observed_spans=len(spans),
        observed_ns=sum(b - a for a, b in spans),
        tracks=len(track_ids),
    )


def _check_chunk(chunk: DetectionBatch, kind: str, held: DetectionBatch | None) -> None:
    """A chunk may be written: times in range, in order after what came before, track ids
    where TrackedPersons needs them."""
    if held is not None and int(chunk.t_ns[0]) < int(held.t_ns[-1]):
        raise _UnsortedError
    _check_log_times(chunk.t_ns, "the tracks")
    if kind == SPENCER_TRACKED and (chunk.track_id < 0).any():
        raise InputError(
            "TrackedPersons needs track ids, some rows have none (-1)",
            hint=f"write the rows as {POSE_ARRAY} instead",
        )
