"""Readers of people-tracking datasets whose files are not a plain table of detections
(THÖR-MAGNI: :mod:`formats.thor_magni`).

- ``edinburgh``: the Edinburgh Informatics Forum tracks (``TRACK.Rn=[[x y frame];...];``,
  overhead-camera pixels at 24.7 mm, frame numbers at about 9 fps, no clock time:
  :func:`read_edinburgh`).
- ``lincoln``: the L-CAS corridor detections (UNIX seconds, no ids), every variant of the
  files told apart by content (:func:`read_lincoln`); the detections are linked into tracks by
  :mod:`aion_cli.engine.tracking` (pure numpy, like the differencing the ETH reader uses), and
  the spans the file declares or marks as recorded come back as observed.

Each reader returns a :class:`formats.track_types.TrackData` (detections, observed spans,
notes for the user); the plain tables (canonical, ATC, THÖR, ETH/UCY) are read by
:mod:`formats.track_csv`, whose parsing helpers these readers share.
"""

from __future__ import annotations

import io
import math
import re
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from aion_cli.engine.types import I64, DetectionBatch
from aion_cli.formats.track_csv import differenced
from aion_cli.formats.track_parse import (
    _check_file,
    _plain_columns,
    _seconds_to_ns,
    _Spec,
    check_encoding,
)
from aion_cli.formats.track_types import (
    NoTrackRowsError,
    TrackData,
    TracksFormatError,
    _utc,
    merge_spans,
)

if TYPE_CHECKING:
    from aion_cli.engine.tracking import LinkerConfig


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
    if not 0 < fps <= 10_000:  # also NaN and inf
        raise TracksFormatError(f"fps must be 0 .. 10,000, got {fps}")
    p = Path(path)
    if not p.is_file():
        raise TracksFormatError(f"tracks file not found: {p}")
    check_encoding(p)
    text = p.read_text(encoding="utf-8-sig", errors="replace")
    if not text.strip():
        raise NoTrackRowsError(f"{p}: no track rows", hint="the file is empty")
    found = list(_EDINBURGH_TRACK.finditer(text))
    entries = [m.start() for m in re.finditer(r"TRACK\.R", text)]
    if not found and all(line.lstrip().startswith("%") for line in text.splitlines()
                         if line.strip()):  # its "% Total number of trajectories" line only
        raise NoTrackRowsError(
            f"{p}: no track rows", hint="the file holds % comments, no TRACK entry (a sensor "
            "that recorded nobody: give its --observed spans)"
        )
    if not found:
        from aion_cli.formats.track_sniff import other_layout_hint

        raise TracksFormatError(
            f"{p}: no TRACK.Rn=[[x y frame];...]; entry",
            hint=other_layout_hint(p, "edinburgh") or _EDINBURGH_HINT,
        )
    if len(found) != len(entries):
        parsed = {m.start() for m in found}
        bad = next(pos for pos in entries if pos not in parsed)
        where = f"{p}: line {_line_of(text, bad)}: a TRACK entry that is not [[x y frame];...];"
        if bad == entries[-1] and not re.search(r"\]\s*\]\s*;", text[bad:]):  # the file ends in it
            raise TracksFormatError(
                f"{where} (the file ends inside it)",
                hint="the file looks cut short (a copy that did not finish): without its last "
                f"entry, the {len(found):,} TRACK entries before it can be read",
            )
        raise TracksFormatError(where, hint=_EDINBURGH_HINT)
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
    batch = differenced(t_ns, xyz, tid)
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
    # 2017-05-31_heading.csv: `t, id, x, y, z, heading_rad` (id always 0); z finite as x and
    # y (a NaN z was read as the detection's height, which aion build then dropped)
    "heading": _Spec(
        ("time_s", "id", "x_m", "y_m", "z_m", "heading_rad"),
        frozenset(),
        frozenset({0, 2, 3, 4}),
        ",",
        None,
        ignored_columns=frozenset({1}),
    ),
}
_LINCOLN_BY_FIELDS = {3: "xy", 4: "xy1", 6: "waypoint"}


def _first_data_line(path: Path) -> tuple[int, str]:
    """Line number and text of the first line that is neither blank nor a comment."""
    with path.open(encoding="utf-8-sig", errors="replace") as fh:
        for lineno, raw in enumerate(fh, start=1):
            line = raw.split("#", 1)[0].strip()
            if line:
                return lineno, line
    raise NoTrackRowsError(f"{path}: no track rows", hint="the file is empty")


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
    from aion_cli.formats.track_sniff import other_layout_hint

    raise TracksFormatError(
        f"{path}: line 1 has {len(fields)} columns: not a Lincoln corridor file",
        hint=other_layout_hint(path, "lincoln")
        or "Lincoln rows are `t x y`, `t x y 1.0`, `t x y a b WPn` or `t, id, x, y, z, heading`"
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
    # in int64 ns as the rows' times (a start of -1e19 s overflowed the notes' comparison)
    t0, t1 = _seconds_to_ns(np.array(pairs[0]), path=path).tolist()
    return t0, t1


def read_lincoln(path: str | Path, linker: LinkerConfig | None = None) -> TrackData:
    """A Lincoln (L-CAS) corridor file, any of its variants (``../shared/data/README.md``).

    The variant is told by content (:func:`_lincoln_variant`); only ``t x y`` (UNIX seconds,
    metres) are read from the 4- and 6-column files. The detections have no ids: they are
    linked into tracks (:func:`aion_cli.engine.tracking.link_tracks` with ``linker``), which
    gives the track ids, headings and speeds. The 2017-05-31 CSV's own heading column is kept
    as ``detector_heading`` but not used: on that file it is about 172° off the direction the
    linked tracks move for most walking detections, so it is not a walking direction in the
    positions' frame (the file's positions are the corridor turned by 171.4° against the other
    days' files, its headings are in theirs: ``docs/EVALUATION.md``).

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
    try:
        a = _plain_columns(p, spec, "lincoln")
    except NoTrackRowsError as exc:  # a header alone: recorded, nobody came
        exc.declared = () if declared is None else (declared,)
        raise
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
    if sentinel.any():  # rows of the file that are no detection: said, so the counts add up
        notes.append(
            f"{p.name}: {int(sentinel.sum()):,} rows at x = y = 0 are the sensor's \"running\" "
            "marks, not people: left out of the detections, each marks 1 s as observed"
        )
    if declared is not None:
        start, end = declared
        spans.append((start, end))
        if len(t_ns) and (
            t_ns[0] - start > DECLARED_SLACK_NS or end - t_ns[-1] > DECLARED_SLACK_NS
        ):
            notes.append(
                f"{p.name}: the header declares recording from {_utc(start)} to {_utc(end)} UTC"
                f" but the detections run from {_utc(int(t_ns[0]))} to {_utc(int(t_ns[-1]))};"
                " the declared span is used as observed (if the file is an excerpt of a longer"
                f" recording, convert its rows alone: tail -n +4 {p.name} > {p.stem}-rows"
                f"{p.suffix})"
            )
    return TrackData(batch, merge_spans(spans), tuple(notes), None if own is None else own[order])
