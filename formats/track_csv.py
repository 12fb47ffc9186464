"""Tables of tracks, one line per detection: parsing them, reading and writing them.

Layouts (``../shared/data/README.md``):

- ``canonical``: aion's own CSV, header ``t_ns,track_id,x,y,z,heading_rad,speed_mps``
  (``nan`` for an unknown heading or speed); :func:`write_canonical_csv` writes it.
- ``atc``: ATC shopping centre, header-less ``time_s (UNIX), person_id, x_m, y_m, speed_mps,
  motion_angle_rad``.
- ``thor``: THÖR, the same columns with time from 0; ``start_ns`` shifts it to an absolute time.
- ``eth`` / ``ucy``: whitespace-separated ``frame ped_id x y`` (the common ETH/UCY text format:
  25 fps frame numbers, a sample every 10 frames = 2.5 Hz); heading and speed are estimated by
  differencing each track (central where possible) as linked tracks are (:func:`differenced`).

Files are parsed with ``np.loadtxt`` (C speed: ATC's ~500k rows in well under a second). Only
when that fails is the file re-scanned line by line, to name the first bad line exactly. The
parsing (:class:`_Spec`, :func:`_load`, :func:`_plain_columns`, :func:`_seconds_to_ns`) lives
in :mod:`formats.track_parse`, shared with the dataset readers of :mod:`formats.datasets`.
:func:`track_chunks` streams the one-line-per-detection layouts (:data:`STREAM_LAYOUTS`)
:data:`CHUNK_ROWS` lines at a time.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.engine.tracking import difference_linked, difference_tracks
from aion_cli.engine.types import F64, I64, DetectionBatch
from aion_cli.formats.track_parse import (
    _check_file,
    _checked_plain,
    _fail,
    _load,
    _no_rows_hint,
    _plain_columns,
    _seconds_to_ns,
    _Spec,
)
from aion_cli.formats.track_types import NoTrackRowsError, TracksFormatError, repeated_rows

CANONICAL_HEADER = "t_ns,track_id,x,y,z,heading_rad,speed_mps"

#: columns of the header-less ATC / THÖR files
ATC_COLUMNS = ("time_s", "person_id", "x_m", "y_m", "speed_mps", "motion_angle_rad")
ETH_COLUMNS = ("frame", "ped_id", "x", "y")
CANONICAL_COLUMNS = tuple(CANONICAL_HEADER.split(","))


_SPECS: dict[str, _Spec] = {
    "canonical": _Spec(
        CANONICAL_COLUMNS, frozenset({0, 1}), frozenset({0, 1, 2, 3, 4}), ",", CANONICAL_HEADER
    ),
    # speed and motion angle finite too: a NaN or inf there was taken silently (an inf angle
    # with numpy's "invalid value encountered in remainder" on stderr); the datasets have none.
    # A negative speed too: it turned the row's velocity round (180 deg off its angle).
    "atc": _Spec(
        ATC_COLUMNS, frozenset({1}), frozenset({0, 1, 2, 3, 4, 5}), ",", None,
        nonnegative_columns=frozenset({4}),
    ),
    "eth": _Spec(ETH_COLUMNS, frozenset({1}), frozenset({0, 1, 2, 3}), None, None),
}


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
    # a zero speed with a zero angle is no direction measured (THÖR writes both for a person
    # standing still), not a walk due east
    heading[(a[:, 4] == 0.0) & (a[:, 5] == 0.0)] = np.nan
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
    :func:`formats.tracks.read_tracks` checks the whole file (the same errors, naming the first
    bad line of the file). A file without rows is a :class:`TracksFormatError`. Memory: one
    chunk, whatever the file's length."""
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
        raise NoTrackRowsError(f"{p}: no track rows", hint=_no_rows_hint(spec))


def _line_chunks(path: Path, spec: _Spec, layout: str, rows: int) -> Iterator[list[str]]:
    """The data lines of a file (after its header), ``rows`` at a time."""
    import itertools

    with path.open(encoding="utf-8-sig", errors="replace") as fh:  # as _load reads
        for _ in range(spec.skip):
            fh.readline()
        while lines := list(itertools.islice(fh, rows)):
            yield lines


def finite_difference(t_ns: I64, track_id: I64, xy: F64) -> tuple[F64, F64]:
    """Heading (rad) and speed (m/s) per row from each track's neighbouring samples.

    Central difference between the previous and next sample of the same track, one-sided at a
    track's ends; NaN for single-sample tracks or zero time steps. Vectorized over all rows.
    (:func:`aion_cli.engine.tracking.difference_tracks` with ``min_step = 0``.)
    """
    return difference_tracks(t_ns, track_id, xy)


def read_eth(
    path: str | Path, fps: float = 25.0, start_ns: int = 0, layout: str = "eth"
) -> DetectionBatch:
    """ETH/UCY ``frame ped_id x y`` (whitespace separated); ``t = start + frame / fps``.
    ``layout`` (``eth`` or ``ucy``, the same columns) is the name a refusal gives the file."""
    if not 0 < fps <= 10_000:  # also NaN and inf
        raise TracksFormatError(f"fps must be 0 .. 10,000, got {fps}")
    p = Path(path)
    a = _plain_columns(p, _SPECS["eth"], layout)
    t_ns = _seconds_to_ns(a[:, 0] / fps, start_ns, p)
    tid = a[:, 1].astype(np.int64)
    xyz = np.zeros((len(a), 3))
    xyz[:, :2] = a[:, 2:4]
    return differenced(t_ns, xyz, tid)


def differenced(t_ns: I64, xyz: F64, track_id: I64) -> DetectionBatch:
    """The time-sorted detections of tracks with headings and speeds by the id-less linker's
    rule (:func:`aion_cli.engine.tracking.difference_linked`: displacements of at least its
    ``min_step``, so a person standing in position noise has no heading, as a linked track's
    has none), where a row repeating an earlier row's time and track id
    (:func:`formats.track_types.repeated_rows`, left out when written) is no neighbour."""
    batch = DetectionBatch.from_arrays(t_ns, xyz, track_id=track_id)
    keep = ~repeated_rows(batch)[0]
    batch.heading[keep], batch.speed[keep] = difference_linked(
        t_ns[keep], track_id[keep], xyz[keep, :2]
    )
    return batch.sorted_by_time()


# ----------------------------------------------------------------------------- Edinburgh



# ----------------------------------------------------------------------------- writing


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
