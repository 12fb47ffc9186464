"""The adapters' common output, :class:`FrameDetections`, and the small helpers every adapter
shares: stable hashing of string ids, stamp selection and frame-name tables.

Adapters return arrays for many messages at once (one row per detection), in the frame each
message names; TF and heading estimation happen later, on whole arrays.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from aion_cli.formats.raw import normalize_frame

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]

#: Track ids are int64 >= 0; unsigned ids above this are masked into range.
ID_MASK = np.uint64(0x7FFF_FFFF_FFFF_FFFF)


def hash_id(value: str | bytes) -> int:
    """A stable non-negative int64 for a string (or raw bytes) id: the first 8 bytes of
    blake2b, little-endian, top bit cleared. Empty ids mean "no id" and map to -1, so the
    same person name always gives the same track id across runs and machines."""
    raw = value.encode("utf-8") if isinstance(value, str) else bytes(value)
    if not raw:
        return -1
    digest = hashlib.blake2b(raw, digest_size=8).digest()
    return int.from_bytes(digest, "little") & 0x7FFF_FFFF_FFFF_FFFF


def hash_ids(values: Sequence[bytes]) -> I64:
    """:func:`hash_id` over many ids, hashing each distinct value once."""
    cache: dict[bytes, int] = {}
    out = np.empty(len(values), dtype=np.int64)
    for i, v in enumerate(values):
        h = cache.get(v)
        if h is None:
            h = cache[v] = hash_id(v)
        out[i] = h
    return out


def unsigned_ids(u: npt.NDArray[np.uint64]) -> I64:
    """uint64 ids as int64 >= 0 (the top bit is cleared so -1 stays free for "no id")."""
    return (np.asarray(u, dtype=np.uint64) & ID_MASK).astype(np.int64)


def stamps_or_log_time(sec: I64, nsec: I64, log_time_ns: I64) -> tuple[I64, int]:
    """Header stamps in ns, falling back to the log time where the stamp is zero (unset by
    the publisher). Returns the times and how many fell back: those whose time the log time
    changed (a stamp of 0 logged at 0, the first frame of a dataset whose clock starts at
    1970-01-01, is that time either way, and no fallback to report)."""
    t = np.asarray(sec, np.int64) * 1_000_000_000 + np.asarray(nsec, np.int64)
    log = np.asarray(log_time_ns, np.int64)
    zero = t == 0
    return np.where(zero, log, t), int((zero & (log != 0)).sum())


class FrameTable:
    """Interns frame names (normalised, leading '/' stripped) to small integer indices."""

    def __init__(self) -> None:
        self.names: list[str] = []
        self._index: dict[str, int] = {}

    def index(self, frame_id: str) -> int:
        name = normalize_frame(frame_id)
        i = self._index.get(name)
        if i is None:
            i = self._index[name] = len(self.names)
            self.names.append(name)
        return i

    def indices(self, frame_ids: Iterable[str]) -> I64:
        return np.fromiter((self.index(f) for f in frame_ids), dtype=np.int64)


@dataclass(frozen=True)
class FrameDetections:
    """Detections decoded from a list of messages, one row per detection, in message frames.

    - ``t_ns``: header stamp (or, where the stamp is zero, the log time; ``stamp_fallbacks``
      counts those rows), ``xyz``: position in the message's frame,
    - ``velocity``: float64[n,3], NaN where the message has none,
    - ``yaw``: orientation yaw (rad) from the pose quaternion, NaN where there is none,
    - ``track_id``: int64, -1 where the source has no ids (string ids hashed by
      :func:`hash_id`),
    - ``frame_id``: int64 index into ``frames`` (frame names, leading '/' stripped),
    - ``msg_index``: index of the source message in the list given to ``decode``,
    - ``n_messages``: how many messages were decoded, ``filtered``: rows dropped on purpose
      (class filter, marker DELETE actions, ...), by reason.
    """

    t_ns: I64
    xyz: F64
    velocity: F64
    yaw: F64
    track_id: I64
    frame_id: I64
    frames: tuple[str, ...]
    msg_index: I64
    n_messages: int = 0
    stamp_fallbacks: int = 0
    filtered: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = len(self.t_ns)
        if self.xyz.shape != (n, 3) or self.velocity.shape != (n, 3):
            raise ValueError(f"xyz and velocity must have shape ({n}, 3)")
        for name in ("yaw", "track_id", "frame_id", "msg_index"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"{name} must have length {n}")

    def __len__(self) -> int:
        return len(self.t_ns)

    @classmethod
    def empty(cls, n_messages: int = 0) -> FrameDetections:
        z = np.zeros(0, np.int64)
        return cls(z, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), z, z, (), z, n_messages)

    def frame_names(self) -> list[str]:
        """The frame name of every row."""
        return [self.frames[i] for i in self.frame_id.tolist()]

    def select(self, index: npt.ArrayLike) -> FrameDetections:
        """Rows picked by a boolean mask or index array (message counters kept)."""
        idx = np.asarray(index)
        return FrameDetections(
            self.t_ns[idx], self.xyz[idx], self.velocity[idx], self.yaw[idx],
            self.track_id[idx], self.frame_id[idx], self.frames, self.msg_index[idx],
            self.n_messages, self.stamp_fallbacks, dict(self.filtered),
        )

    @classmethod
    def concat(
        cls, parts: Sequence[FrameDetections], offset_messages: bool = True
    ) -> FrameDetections:
        """Rows of every part in order; frame tables merged. With ``offset_messages`` message
        indices are shifted so they stay unique (part k's by the messages of the parts before
        it); without, they are kept (parts that index one shared message list)."""
        if not parts:
            return cls.empty()
        table = FrameTable()
        frame_ids: list[I64] = []
        msg_ids: list[I64] = []
        filtered: dict[str, int] = {}
        offset = 0
        for p in parts:
            remap = table.indices(p.frames) if p.frames else np.zeros(0, np.int64)
            frame_ids.append(remap[p.frame_id] if len(p) else p.frame_id)
            msg_ids.append(p.msg_index + offset if offset_messages else p.msg_index)
            offset += p.n_messages
            for k, v in p.filtered.items():
                filtered[k] = filtered.get(k, 0) + v
        return cls(
            np.concatenate([p.t_ns for p in parts]),
            np.concatenate([p.xyz for p in parts]).reshape(-1, 3),
            np.concatenate([p.velocity for p in parts]).reshape(-1, 3),
            np.concatenate([p.yaw for p in parts]),
            np.concatenate([p.track_id for p in parts]),
            np.concatenate(frame_ids).astype(np.int64),
            tuple(table.names),
            np.concatenate(msg_ids).astype(np.int64),
            offset,
            sum(p.stamp_fallbacks for p in parts),
            filtered,
        )


#: A pose yaw counts only when its quaternion's norm is at least this: leg detectors and other
#: bare-position publishers leave the orientation all zero ("unset"), and a quaternion of
#: near-zero norm (a half-filled or noise-level one) is not a rotation anyone meant, so
#: neither may pose as a walking direction. Larger norms are scaled rotations (the yaw formula
#: is scale-free).
MIN_QUAT_NORM = 0.5


def quat_yaw(q: F64) -> F64:
    """Yaw (rotation about z, rad) of quaternions float64[n,4] in (x, y, z, w) order; NaN
    unless the quaternion is finite with a usable norm (at least :data:`MIN_QUAT_NORM`: an
    all-zero, unset quaternion never yields a heading)."""
    q = np.asarray(q, dtype=np.float64).reshape(-1, 4)
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    # w²+x²-y²-z² instead of 1-2(y²+z²): the same for unit quaternions, scale-free otherwise.
    yaw = np.arctan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)
    usable = np.einsum("ij,ij->i", q, q) >= MIN_QUAT_NORM**2  # False for NaN too
    return np.where(usable & np.isfinite(yaw), yaw, np.nan)
