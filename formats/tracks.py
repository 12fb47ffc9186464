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

Files are parsed with ``np.loadtxt`` (C speed: ATC's ~500k rows in well under a second). Only
when that fails is the file re-scanned line by line, to name the first bad line exactly.
:func:`tracks_to_log` turns a batch (plus optionally a Hydra graph) into an MCAP or bag that
``aion build`` reads like any robot log.
"""

from __future__ import annotations

import math
import struct
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from aion_cli.engine.errors import InputError
from aion_cli.engine.types import F64, I64, BoolA, DetectionBatch

CANONICAL_HEADER = "t_ns,track_id,x,y,z,heading_rad,speed_mps"
Layout = Literal["canonical", "atc", "thor", "eth", "ucy"]
LAYOUTS: tuple[str, ...] = ("canonical", "atc", "thor", "eth", "ucy")

#: columns of the header-less ATC / THÖR files
ATC_COLUMNS = ("time_s", "person_id", "x_m", "y_m", "speed_mps", "motion_angle_rad")
ETH_COLUMNS = ("frame", "ped_id", "x", "y")
CANONICAL_COLUMNS = tuple(CANONICAL_HEADER.split(","))


class TracksFormatError(InputError):
    """A tracks file has the wrong layout, non-numeric data, or no rows."""


@dataclass(frozen=True)
class _Spec:
    """How to parse one layout: column names, which must be integers or finite, delimiter."""

    columns: tuple[str, ...]
    int_columns: frozenset[int]
    finite_columns: frozenset[int]
    delimiter: str | None
    header: str | None


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
            if spec.header is not None and lineno == 1:
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
                skiprows=1 if spec.header else 0,
                ndmin=ndmin,
                encoding="utf-8-sig",
            )
    except (ValueError, UnicodeDecodeError, OverflowError) as exc:
        raise _fail(path, spec, layout, str(exc)) from exc
    if data.size == 0:
        raise TracksFormatError(f"{path}: no track rows", hint="the file is empty")
    return data


def _plain_columns(path: Path, spec: _Spec, layout: str) -> F64:
    data = _load(path, spec, layout, np.float64, ndmin=2)
    if data.shape[1] != len(spec.columns):
        raise _fail(path, spec, layout, f"expected {len(spec.columns)} columns")
    arr: F64 = data
    bad = ~np.isfinite(arr[:, sorted(spec.finite_columns)]).all(axis=1)
    ints = arr[:, sorted(spec.int_columns)]
    if bad.any() or (ints != np.round(ints)).any():
        raise _fail(path, spec, layout)
    return arr


def _seconds_to_ns(t_s: F64, start_ns: int = 0) -> I64:
    """Seconds -> int64 ns, rounded to the microsecond (the files carry ms at best)."""
    return np.round(t_s * 1e6).astype(np.int64) * 1000 + np.int64(start_ns)


# ----------------------------------------------------------------------------- readers


def read_canonical(path: str | Path) -> DetectionBatch:
    """Read aion's canonical tracks CSV (exact int64 ``t_ns``)."""
    p = Path(path)
    spec = _SPECS["canonical"]
    dtype = np.dtype([(name, "i8" if k in (0, 1) else "f8") for k, name in enumerate(spec.columns)])
    rec = _load(p, spec, "canonical", dtype, ndmin=1)
    xyz = np.stack([rec["x"], rec["y"], rec["z"]], axis=1)
    if not np.isfinite(xyz).all():
        raise _fail(p, spec, "canonical")
    return DetectionBatch.from_arrays(
        rec["t_ns"], xyz, rec["heading_rad"], rec["speed_mps"], rec["track_id"]
    ).sorted_by_time()


def read_atc(path: str | Path, start_ns: int = 0, layout: str = "atc") -> DetectionBatch:
    """ATC / THÖR CSV: ``time_s, person_id, x_m, y_m, speed_mps, motion_angle_rad``.

    ``start_ns`` is added to the times (THÖR times start at 0; ATC's are UNIX seconds).
    Headings are wrapped to [-π, π).
    """
    p = Path(path)
    a = _plain_columns(p, _SPECS["atc"], layout)
    xyz = np.zeros((len(a), 3))
    xyz[:, :2] = a[:, 2:4]
    heading = np.mod(a[:, 5] + np.pi, 2 * np.pi) - np.pi
    return DetectionBatch.from_arrays(
        _seconds_to_ns(a[:, 0], start_ns), xyz, heading, a[:, 4], a[:, 1].astype(np.int64)
    ).sorted_by_time()


def finite_difference(t_ns: I64, track_id: I64, xy: F64) -> tuple[F64, F64]:
    """Heading (rad) and speed (m/s) per row from each track's neighbouring samples.

    Central difference between the previous and next sample of the same track, one-sided at a
    track's ends; NaN for single-sample tracks or zero time steps. Vectorized over all rows.
    """
    n = len(t_ns)
    order = np.lexsort((t_ns, track_id))
    tid = track_id[order]
    same_prev = np.zeros(n, dtype=bool)
    same_prev[1:] = tid[1:] == tid[:-1]
    same_next = np.zeros(n, dtype=bool)
    same_next[:-1] = same_prev[1:]
    idx = np.arange(n)
    prev = np.where(same_prev, idx - 1, idx)
    nxt = np.where(same_next, idx + 1, idx)
    ts = t_ns[order]
    p = xy[order]
    dt = (ts[nxt] - ts[prev]).astype(np.float64) * 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        v = (p[nxt] - p[prev]) / dt[:, None]
    v[dt <= 0] = np.nan
    heading = np.empty(n)
    speed = np.empty(n)
    heading[order] = np.arctan2(v[:, 1], v[:, 0])
    speed[order] = np.hypot(v[:, 0], v[:, 1])
    return heading, speed


def read_eth(path: str | Path, fps: float = 25.0, start_ns: int = 0) -> DetectionBatch:
    """ETH/UCY ``frame ped_id x y`` (whitespace separated); ``t = start + frame / fps``."""
    if not fps > 0:
        raise TracksFormatError(f"fps must be > 0, got {fps}")
    p = Path(path)
    a = _plain_columns(p, _SPECS["eth"], "eth")
    t_ns = _seconds_to_ns(a[:, 0] / fps, start_ns)
    tid = a[:, 1].astype(np.int64)
    heading, speed = finite_difference(t_ns, tid, a[:, 2:4])
    xyz = np.zeros((len(a), 3))
    xyz[:, :2] = a[:, 2:4]
    return DetectionBatch.from_arrays(t_ns, xyz, heading, speed, tid).sorted_by_time()


def read_tracks(
    path: str | Path, layout: str = "canonical", start_ns: int = 0, fps: float = 25.0
) -> DetectionBatch:
    """Read a tracks file of ``layout`` into a time-sorted :class:`DetectionBatch`.

    ``start_ns`` shifts THÖR / ETH / ATC times; ``fps`` is the ETH/UCY frame rate.
    """
    key = layout.lower()
    if key == "canonical":
        return read_canonical(path)
    if key in ("atc", "thor"):
        return read_atc(path, start_ns, key)
    if key in ("eth", "ucy"):
        return read_eth(path, fps, start_ns)
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
    """What :func:`tracks_to_log` wrote."""

    path: Path
    detection_messages: int
    detections: int
    graph_messages: int
    start_ns: int
    end_ns: int


def _group_bounds(t_ns: I64, group_ns: int) -> tuple[I64, I64]:
    """Message stamps and split points of time-sorted rows: one message per distinct time, or
    per ``group_ns`` bin (stamped at the bin's first detection) when ``group_ns > 0``."""
    key = t_ns if group_ns <= 0 else (t_ns - t_ns[0]) // group_ns
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


def _tracked_person_records(batch: DetectionBatch, cdr: bool) -> npt.NDArray[np.void]:
    """Every row's serialized TrackedPerson, built in one go as a structured array."""
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
    rec["detection_id"] = np.arange(len(batch), dtype=np.uint64)
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
) -> TracksLogSummary:
    """Write ``batch`` as a people-tracking log that ``aion build`` reads like a robot's.

    One ``msgtype`` message (spencer ``TrackedPersons`` with velocity from heading and speed,
    or ``PoseArray`` with the heading as yaw) per distinct timestamp, or per ``group_ns`` bin;
    positions are in ``frame_id`` (the map, so no ``/tf`` is needed). With ``graph_file``, a
    ``hydra_msgs/DsgUpdate`` carrying the whole graph (mesh included) is written at the first
    stamp and again every ``graph_period_s`` so a reader joining late still gets it.
    Unknown headings / speeds are marked with the spencer "unset" variance.
    """
    from formats.raw import normalize_msgtype
    from formats.writers import LogWriter, stamp

    kind = normalize_msgtype(msgtype)
    if kind not in (SPENCER_TRACKED, POSE_ARRAY):
        raise InputError(
            f"cannot write tracks as {msgtype!r}", hint=f"use {SPENCER_TRACKED} or {POSE_ARRAY}"
        )
    if len(batch) == 0:
        raise InputError("no detections to write", hint="the tracks file has no rows")
    if kind == SPENCER_TRACKED and (batch.track_id < 0).any():
        raise InputError(
            "TrackedPersons needs track ids, some rows have none (-1)",
            hint=f"write the rows as {POSE_ARRAY} instead",
        )
    if not graph_period_s > 0:
        raise InputError(f"graph period must be > 0 s, got {graph_period_s}")
    data = batch.sorted_by_time()
    stamps, splits = _group_bounds(data.t_ns, group_ns)
    starts = np.concatenate([[0], splits]).tolist()
    ends = np.concatenate([splits, [len(data)]]).tolist()
    payload = _graph_payload(graph_file) if graph_file is not None else None
    graph_times: list[int] = []
    if payload is not None:
        period = round(graph_period_s * 1e9)
        graph_times = list(range(int(stamps[0]), int(stamps[-1]) + 1, period))
    with LogWriter(out_path, container, overwrite=overwrite) as writer:
        cdr = writer.ros_version == 2
        if kind == SPENCER_TRACKED:
            records = _tracked_person_records(data, cdr)
        else:
            quat = _orientation_velocity(data)[0].tolist()
            xyz = data.xyz.tolist()
        g = 0
        for k, (t, a, b) in enumerate(zip(stamps.tolist(), starts, ends, strict=True)):
            while g < len(graph_times) and graph_times[g] <= t:
                writer.write(
                    graph_topic,
                    DSG_UPDATE,
                    {
                        "header": {"stamp": stamp(graph_times[g]), "frame_id": frame_id},
                        "layer_contents": payload,
                        "full_update": True,
                        "sequence_number": g,
                    },
                    graph_times[g],
                )
                g += 1
            if kind == SPENCER_TRACKED:
                raw = _tracked_persons_bytes(records[a:b], t, frame_id, cdr, k)
                writer.write_raw(topic, kind, raw, t)
            else:
                writer.write(topic, kind, _pose_array_message(t, xyz[a:b], quat[a:b], frame_id), t)
    return TracksLogSummary(
        Path(out_path), len(stamps), len(data), len(graph_times), int(stamps[0]), int(stamps[-1])
    )
