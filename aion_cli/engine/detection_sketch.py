"""A small, mergeable sample of a build's detections that tells one recording read from two
log files apart from two recordings of one time or one place (:class:`DetectionSketch`).

Why: a map keeps no detection, and its logs may be gone when it is merged or continued, so
whether a new log (or another map's) holds detections it already counted can only be told
from what its manifest stores. A recording converted again (``aion convert`` to another
container, with other ``--observed`` spans or message type), copied, or cut at another start
holds the very detections of the first file: the same stamps and positions. So each
detection (stamp to the microsecond, position to the millimetre on each axis) is hashed to
64 bits, and the sketch keeps the detections whose hash is below ``2**(64 - level)``, the
level raised until at most :data:`SKETCH_SIZE` remain: the same detections are sampled
whatever file, cut or build they come from (the sample is a function of the detections, not
of their order), so a copy's sample is the original's over the time both hold. Two robots
at the same hours, or a place on another day, share no detection to the microsecond and
millimetre, and so no sample.

Array work per batch (no loop per detection); a sketch is at most :data:`SKETCH_SIZE`
(stamp, hash) pairs whatever the logs' length.
"""

from __future__ import annotations

import base64
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.row_masks import all_columns
from aion_cli.engine.types import F64, I64

#: samples kept at most (16 bytes each in the manifest)
SKETCH_SIZE = 128
#: alike samples two sketches need, at least, to be one recording (one detection equal by
#: chance, a message a split wrote into both files, is not a recording)
MIN_ALIKE = 2
#: the share of the fewer samples over the time both sketches hold that must be alike
ALIKE_SHARE = 0.5
#: the share of all the samples of the sketch with fewer that must be alike for one to
#: repeat the other: a copy, an excerpt (a cut), or the original of an excerpt. Logs that
#: share only part of their time (two files of one recording that overlap by minutes) hold
#: fewer: their people count twice in that time only, as when one build is given both
REPEAT_SHARE = 0.8

U64 = npt.NDArray[np.uint64]

_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def _mix_in_place(h: U64, scratch: U64) -> None:
    """splitmix64's finaliser on every element of ``h``, in place (wrapping uint64
    arithmetic; ``scratch``, as long, takes the shifts): ``h ^= h >> 30; h *= M1; h ^= h >>
    27; h *= M2; h ^= h >> 31`` without a new array per step (issue 15: a build hashes
    every detection)."""
    for shift, factor in ((30, _M1), (27, _M2)):
        np.right_shift(h, np.uint64(shift), out=scratch)
        h ^= scratch
        h *= factor
    np.right_shift(h, np.uint64(31), out=scratch)
    h ^= scratch


def detection_hashes(t_ns: I64, xyz: F64) -> tuple[I64, U64]:
    """The finite rows' stamps (ns) and 64-bit hashes of (stamp in µs, x, y, z in mm)."""
    t = np.asarray(t_ns, np.int64).reshape(-1)
    p = np.asarray(xyz, np.float64).reshape(-1, 3)
    ok = all_columns(np.abs(p) < 1e12)  # NaN and ±inf compare false: the finite rows
    if not ok.all():
        t, p = t[ok], p[ok]
    cols = [np.floor_divide(t, 1000), *np.rint(p * 1000.0).astype(np.int64).T]
    h = np.zeros(len(t), np.uint64)
    scratch = np.empty_like(h)
    for col in cols:  # four columns, each a whole array: h = _mix(h ^ (col + golden))
        np.add(col.view(np.uint64), _GOLDEN, out=scratch)
        h ^= scratch
        _mix_in_place(h, scratch)
    return t, h


def _below(h: U64, level: int) -> npt.NDArray[np.bool_]:
    """Whether each hash is below ``2**(64 - level)`` (kept at that level)."""
    if level <= 0:
        return np.ones(len(h), bool)
    return (h >> np.uint64(64 - level)) == 0


@dataclass
class DetectionSketch:
    """The sampled detections of one build (module docstring): their stamps ``t_ns`` and
    hashes ``h`` (sorted by hash, each once), the sampling ``level``, how many detections
    were hashed and the first and last stamp among them (the time the sample covers)."""

    level: int = 0
    t_ns: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    h: U64 = field(default_factory=lambda: np.zeros(0, np.uint64))
    detections: int = 0
    first_ns: int | None = None
    last_ns: int | None = None

    def __len__(self) -> int:
        return len(self.h)

    def add(self, t_ns: I64, xyz: F64) -> None:
        """Sample the detections ``t_ns``, ``xyz`` (rows with a non-finite position are not
        detections any map holds, and are left out)."""
        t, h = detection_hashes(t_ns, xyz)
        if len(t) == 0:
            return
        self.detections += len(t)
        lo, hi = int(t.min()), int(t.max())
        self.first_ns = lo if self.first_ns is None else min(self.first_ns, lo)
        self.last_ns = hi if self.last_ns is None else max(self.last_ns, hi)
        keep = _below(h, self.level)
        self._join(t[keep], h[keep])

    def merge(self, other: DetectionSketch) -> None:
        """Add ``other``'s sample (another part of the same build: a shard's)."""
        if other.first_ns is None or other.last_ns is None:
            return
        self.detections += other.detections
        self.first_ns = (
            other.first_ns if self.first_ns is None else min(self.first_ns, other.first_ns)
        )
        self.last_ns = other.last_ns if self.last_ns is None else max(self.last_ns, other.last_ns)
        self.level = max(self.level, other.level)
        self._join(other.t_ns, other.h)

    def _join(self, t: I64, h: U64) -> None:
        """Union with (``t``, ``h``) at the current level, raised until the sample fits."""
        t_all = np.concatenate([self.t_ns, t])
        h_all = np.concatenate([self.h, h])
        keep = _below(h_all, self.level)
        h_all, t_all = h_all[keep], t_all[keep]
        h_all, first = np.unique(h_all, return_index=True)
        t_all = t_all[first]
        while len(h_all) > SKETCH_SIZE:
            self.level += 1
            keep = _below(h_all, self.level)
            h_all, t_all = h_all[keep], t_all[keep]
        self.h, self.t_ns = h_all, t_all

    def to_dict(self) -> dict[str, Any]:
        """The sketch as the manifest stores it: ``samples`` is base64 of little-endian
        int64 pairs (stamp ns, hash)."""
        pairs = np.stack([self.t_ns, self.h.view(np.int64)], axis=1).astype("<i8")
        return {
            "level": self.level,
            "detections": self.detections,
            "first_ns": self.first_ns,
            "last_ns": self.last_ns,
            "samples": base64.b64encode(pairs.tobytes()).decode("ascii"),
        }

    @classmethod
    def from_dict(cls, d: Any) -> DetectionSketch | None:
        """A stored sketch; None for one that is damaged or of no detection (nothing to
        compare: a map without one is checked as before)."""
        try:
            raw = base64.b64decode(str(d["samples"]), validate=True)
            level, first, last = int(d["level"]), int(d["first_ns"]), int(d["last_ns"])
            detections = int(d["detections"])
        except (KeyError, TypeError, ValueError):
            return None
        if len(raw) % 16 or not 0 <= level <= 64 or last < first:
            return None
        pairs = np.frombuffer(raw, "<i8").reshape(-1, 2).astype(np.int64)
        return cls(
            level, pairs[:, 0].copy(), pairs[:, 1].view(np.uint64).copy(), detections, first, last
        )


#: detections a :class:`SketchFeed` holds before it hashes them (about 100 kB)
FEED_ROWS = 4096


class SketchFeed:
    """Detections on their way into ``sketch``, hashed a few thousand at a time instead of
    per batch (issue 15: a build hands the Mapper about 140 detections at a time, and
    :func:`detection_hashes` costs about 90 µs a call whatever its size). The sample is a
    function of the detections alone, not of their batches (the oldest stamp of a hash is
    kept either way: the batches are joined in their order), so the sketch is the same;
    :meth:`flush` before reading it."""

    def __init__(self, sketch: DetectionSketch, rows: int = FEED_ROWS) -> None:
        self.sketch = sketch
        self._rows = rows
        self._t: list[I64] = []
        self._xyz: list[F64] = []
        self._held = 0

    def add(self, t_ns: I64, xyz: F64) -> None:
        """Hold ``t_ns``, ``xyz`` (as :meth:`DetectionSketch.add`), hashing what is held
        once it reaches the feed's rows."""
        self._t.append(t_ns)
        self._xyz.append(xyz)
        self._held += len(t_ns)
        if self._held >= self._rows:
            self.flush()

    def flush(self) -> None:
        """Everything held into the sketch."""
        if not self._t:
            return
        t, xyz = self._t, self._xyz
        self._t, self._xyz, self._held = [], [], 0
        if len(t) == 1:
            self.sketch.add(t[0], xyz[0])
        else:
            self.sketch.add(np.concatenate(t), np.concatenate(xyz))


def alike(a: DetectionSketch, b: DetectionSketch) -> tuple[int, int]:
    """``(alike, compared)``: over the time both sketches cover, at the coarser one's level,
    how many samples both hold, and how many the sketch with fewer there holds."""
    if a.first_ns is None or a.last_ns is None or b.first_ns is None or b.last_ns is None:
        return 0, 0
    lo, hi = max(a.first_ns, b.first_ns), min(a.last_ns, b.last_ns)
    if hi < lo:
        return 0, 0
    level = max(a.level, b.level)

    def inside(s: DetectionSketch) -> U64:
        return s.h[_below(s.h, level) & (s.t_ns >= lo) & (s.t_ns <= hi)]

    ha, hb = inside(a), inside(b)
    return int(np.isin(ha, hb, assume_unique=True).sum()), min(len(ha), len(hb))


def one_recording(a: DetectionSketch, b: DetectionSketch) -> tuple[int, int] | None:
    """``(alike, samples)`` when one of ``a`` and ``b`` repeats the other: over the time both
    cover, at least :data:`MIN_ALIKE` samples alike and :data:`ALIKE_SHARE` of those
    compared (:func:`alike`), and those alike are :data:`REPEAT_SHARE` of all the samples
    (``samples``, at the coarser level) of the sketch with fewer; None otherwise."""
    same, compared = alike(a, b)
    if same < MIN_ALIKE or same < ALIKE_SHARE * compared:
        return None
    level = max(a.level, b.level)
    fewer = min(int(_below(a.h, level).sum()), int(_below(b.h, level).sum()))
    return (same, fewer) if same >= REPEAT_SHARE * fewer else None


def batch_alike(s: DetectionSketch, t_ns: I64, xyz: F64) -> tuple[int, int]:
    """``(alike, compared)`` of a sketch against a whole batch of detections (not sampled):
    of the sketch's samples within the batch's time, how many the batch holds. Where the
    batch repeats a recording the sketch sampled, every one of them."""
    t, h = detection_hashes(t_ns, xyz)
    if len(t) == 0:
        return 0, 0
    mine = s.h[(s.t_ns >= t.min()) & (s.t_ns <= t.max())]
    return int(np.isin(mine, h).sum()), len(mine)
