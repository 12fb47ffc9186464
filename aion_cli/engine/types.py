"""Plain data classes that cross layer boundaries: arrays, never per-item Python objects.

All times are int64 nanoseconds since the UNIX epoch (UTC). All positions are float64 metres in
the map frame unless a docstring says otherwise.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]
I64 = npt.NDArray[np.int64]
U64 = npt.NDArray[np.uint64]
I32 = npt.NDArray[np.int32]
BoolA = npt.NDArray[np.bool_]


def _f64(a: npt.ArrayLike, shape_tail: tuple[int, ...] = ()) -> F64:
    arr = np.ascontiguousarray(a, dtype=np.float64)
    if shape_tail and arr.size == 0:
        arr = arr.reshape((0, *shape_tail))
    return arr


@dataclass(frozen=True)
class DetectionBatch:
    """People detections, one row per detection.

    ``heading`` is the walking direction in radians (atan2(vy, vx) in the map frame), NaN if
    unknown; ``speed`` is m/s, NaN if unknown; ``track_id`` is -1 if the source has no ids.
    """

    t_ns: I64
    xyz: F64
    heading: F64
    speed: F64
    track_id: I64

    def __post_init__(self) -> None:
        n = len(self.t_ns)
        if self.xyz.shape != (n, 3):
            raise ValueError(f"xyz must have shape ({n}, 3), got {self.xyz.shape}")
        for name in ("heading", "speed", "track_id"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"{name} must have length {n}")

    @classmethod
    def from_arrays(
        cls,
        t_ns: npt.ArrayLike,
        xyz: npt.ArrayLike,
        heading: npt.ArrayLike | None = None,
        speed: npt.ArrayLike | None = None,
        track_id: npt.ArrayLike | None = None,
    ) -> DetectionBatch:
        """Build a batch with dtype coercion; missing columns become NaN / -1."""
        t = np.ascontiguousarray(t_ns, dtype=np.int64).reshape(-1)
        n = len(t)
        p = _f64(xyz, (3,)).reshape(n, 3)
        h = np.full(n, np.nan) if heading is None else _f64(heading).reshape(n)
        s = np.full(n, np.nan) if speed is None else _f64(speed).reshape(n)
        k = (
            np.full(n, -1, dtype=np.int64)
            if track_id is None
            else np.ascontiguousarray(track_id, dtype=np.int64).reshape(n)
        )
        return cls(t, p, h, s, k)

    @classmethod
    def empty(cls) -> DetectionBatch:
        return cls.from_arrays(np.zeros(0, np.int64), np.zeros((0, 3)))

    @classmethod
    def concat(cls, batches: list[DetectionBatch]) -> DetectionBatch:
        if not batches:
            return cls.empty()
        return cls(
            np.concatenate([b.t_ns for b in batches]),
            np.concatenate([b.xyz for b in batches]),
            np.concatenate([b.heading for b in batches]),
            np.concatenate([b.speed for b in batches]),
            np.concatenate([b.track_id for b in batches]),
        )

    def __len__(self) -> int:
        return len(self.t_ns)

    def select(self, index: npt.ArrayLike) -> DetectionBatch:
        """Rows picked by a boolean mask or an index array."""
        idx = np.asarray(index)
        return DetectionBatch(
            self.t_ns[idx], self.xyz[idx], self.heading[idx], self.speed[idx], self.track_id[idx]
        )

    def sorted_by_time(self) -> DetectionBatch:
        order = np.argsort(self.t_ns, kind="stable")
        return self.select(order)


@dataclass(frozen=True)
class Layer:
    """One layer of scene-graph nodes (places, rooms or buildings).

    ``ids`` are spark_dsg NodeSymbol values (``(ord(category) << 56) | index``); ``parent`` is
    the id of the parent node one layer up (room for a place, building for a room), 0 if none;
    ``labels`` are human-readable names ("" if none).
    """

    ids: U64
    xyz: F64
    parent: U64
    labels: tuple[str, ...] = ()

    @classmethod
    def empty(cls) -> Layer:
        return cls(np.zeros(0, np.uint64), np.zeros((0, 3)), np.zeros(0, np.uint64), ())

    def __len__(self) -> int:
        return len(self.ids)


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh: ``vertices`` float64[v,3], ``colors`` float64[v,3] in 0..1 (may be
    empty), ``faces`` int32[f,3] vertex indices."""

    vertices: F64
    faces: I32
    colors: F64 = field(default_factory=lambda: np.zeros((0, 3)))


@dataclass(frozen=True)
class Trajectory:
    """Robot (sensor) positions over time in the map frame, sorted by ``t_ns``."""

    t_ns: I64
    xyz: F64

    @classmethod
    def empty(cls) -> Trajectory:
        return cls(np.zeros(0, np.int64), np.zeros((0, 3)))

    def __len__(self) -> int:
        return len(self.t_ns)


@dataclass(frozen=True)
class GraphSnapshot:
    """The navigational part of one scene graph at time ``t_ns``.

    ``places`` is the navigational layer (real places only: frontiers are left out);
    ``edges`` are int64[k,2] row indices into ``places`` (undirected, each pair once);
    ``rooms`` / ``buildings`` are the hierarchy above; ``mesh`` is the DSG's mesh if present;
    ``agents`` is the DSG's agent layer (optimized robot poses), a fallback robot trajectory.
    ``layer_name`` says which DSG layer the places came from ("places", "mesh_places", ...).
    """

    t_ns: int
    places: Layer
    edges: I64
    rooms: Layer = field(default_factory=Layer.empty)
    buildings: Layer = field(default_factory=Layer.empty)
    mesh: Mesh | None = None
    agents: Trajectory | None = None
    layer_name: str = "places"
    frame_id: str = "map"

    def restamped(self, t_ns: int) -> GraphSnapshot:
        """This snapshot at time ``t_ns``, every other field the same objects:
        ``dataclasses.replace(self, t_ns=t_ns)`` without its per-field work (a build
        restamps the reused snapshot of every repeated scene graph, issue 15: 1 against
        8 µs)."""
        out = object.__new__(GraphSnapshot)
        out.__dict__.update(self.__dict__)
        object.__setattr__(out, "t_ns", t_ns)
        return out


@dataclass(frozen=True)
class RowTake:
    """Rows ``rows`` of ``source`` (along axis 0), gathered block by block when written: a map
    member that never exists as one whole copy in memory (writing a map of 10^6 temporal rows
    would otherwise hold the state and a reordered copy of it at once). ``cast``: the dtype the
    rows are stored as (a lossless narrowing the caller has checked, e.g. integral counts).

    :func:`formats.mapfile.write_map` streams it; ``np.asarray`` materialises it."""

    source: np.ndarray
    rows: I64
    block_rows: int = 1 << 15
    cast: np.dtype[Any] | None = None

    @property
    def shape(self) -> tuple[int, ...]:
        return (int(self.rows.size), *self.source.shape[1:])

    @property
    def dtype(self) -> np.dtype[Any]:
        return self.source.dtype if self.cast is None else self.cast

    @property
    def nbytes(self) -> int:
        row = int(np.prod(self.source.shape[1:], dtype=np.int64)) * self.dtype.itemsize
        return int(self.rows.size) * row

    def blocks(self) -> Iterator[np.ndarray]:
        """C-contiguous blocks of consecutive output rows, in order."""
        for a in range(0, int(self.rows.size), self.block_rows):
            block = self.source[self.rows[a : a + self.block_rows]]
            yield np.ascontiguousarray(block if self.cast is None else block.astype(self.cast))

    def __array__(self, dtype: npt.DTypeLike | None = None, copy: bool | None = None) -> np.ndarray:
        out = self.source[self.rows]
        if self.cast is not None:
            out = out.astype(self.cast)
        return out if dtype is None else out.astype(dtype)
