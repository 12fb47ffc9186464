"""Lock-step reading of spark_dsg binary records, and the fields of each attribute type.

:class:`Cursors` holds one read position per record (a node or an edge of a payload, see
:mod:`formats.dsg_binary`) and advances all of them field by field with numpy gathers; a
record whose bytes do not fit what is read (a wrong tag, a length out of bounds) gets
``ok = False``, never an exception, so one pass reads thousands of records of any sizes.

:data:`PROGRAMS` lists, per attribute class name, the fields spark_dsg 1.1.3 writes
(``serialization_info`` of ``node_attributes.cpp`` and the binary conversions of
``binary_conversions.h`` / ``binary_serialization.h``). A run of fixed-size fields is merged
into one :class:`Fixed` step (one gather checks all its tags); strings, vectors and matrices
are steps of their own. Only the values a snapshot needs are captured (position, name,
``real_place``, an agent's timestamp); every other field is checked and skipped.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

I64 = npt.NDArray[np.int64]
U8 = npt.NDArray[np.uint8]
Bool = npt.NDArray[np.bool_]
Values = dict[str, npt.NDArray[np.generic]]

NIL, FALSE, TRUE = 0xC0, 0xC2, 0xC3
F32, F64, U8_, U32, U64, I32, I64_ = 0xCA, 0xCB, 0xCC, 0xCE, 0xCF, 0xD2, 0xD3
ARR = 0xDD
WIDTH = {F32: 4, F64: 8, U8_: 1, U32: 4, U64: 8, I32: 4, I64_: 8}
#: A check value meaning "either bool tag" (FALSE or TRUE).
BOOL = -1


def words(buf: U8, dtype: str) -> npt.NDArray[np.generic]:
    """``buf`` seen as overlapping little-endian values of ``dtype``, one starting at every
    byte (stride 1): ``words(buf, "<u4")[p]`` is the uint32 at byte ``p``, so a gather of
    values at arbitrary offsets is one 1-D fancy index."""
    w = np.dtype(dtype).itemsize
    if len(buf) < w:
        return np.zeros(0, dtype=dtype)
    return np.ndarray((len(buf) - w + 1,), dtype=dtype, buffer=buf, strides=(1,))


class Cursors:
    """One read position per record, advanced together (see the module docstring)."""

    def __init__(
        self, buf: U8, pos: I64, views: dict[str, npt.NDArray[np.generic]] | None = None
    ) -> None:
        self.buf = buf
        self.n = len(buf)
        self.pos = np.asarray(pos, dtype=np.int64).copy()
        self.ok = np.ones(len(self.pos), dtype=bool)
        self.views = {} if views is None else views

    def __len__(self) -> int:
        return len(self.pos)

    def view(self, dtype: str) -> npt.NDArray[np.generic]:
        """The buffer as :func:`words` of ``dtype`` (made once per buffer and dtype)."""
        v = self.views.get(dtype)
        if v is None:
            v = self.views[dtype] = words(self.buf, dtype)
        return v

    def subset(self, rows: Bool) -> Cursors:
        sub = Cursors(self.buf, self.pos[rows], self.views)
        sub.ok = self.ok[rows].copy()
        return sub

    def merge(self, rows: Bool, sub: Cursors) -> None:
        self.pos[rows] = sub.pos
        self.ok[rows] = sub.ok

    def base(self, size: int) -> I64:
        """Where ``size`` bytes are read from each record: its position, or 0 for a record
        whose bytes end too early (it is no longer ok)."""
        self.ok &= self.pos + size <= self.n
        if self.n < size:
            self.ok[:] = False
        return np.where(self.ok, self.pos, 0)

    def value(self, base: I64, offset: int, dtype: str) -> npt.NDArray[np.generic]:
        """The ``dtype`` value at ``base + offset`` of every record (``base`` from
        :meth:`base`, which checked the bytes are there)."""
        return self.view(dtype)[base + offset]

    def length(self) -> I64:
        """An ARR32 header (a vector or string length): its count, 0 where not ok."""
        base = self.base(5)
        self.ok &= self.buf[base] == ARR
        count = self.value(base, 1, "<u4").astype(np.int64)
        self.pos += 5
        return np.where(self.ok, count, 0)

    def string(self) -> tuple[I64, I64]:
        """A string (ARR32 and raw bytes): ``(start, length)``."""
        count = self.length()
        self.ok &= self.pos + count <= self.n
        count = np.where(self.ok, count, 0)
        start = self.pos.copy()
        self.pos += count
        return start, count

    def elements(self, count: I64, size: int, checks: Sequence[tuple[int, int]]) -> None:
        """``count`` elements of ``size`` bytes per record, each with the bytes of ``checks``
        (offset, value) at its offsets: the tags of a fixed element layout, checked at once."""
        count = np.where(self.ok, count, 0)
        self.ok &= self.pos + count * size <= self.n
        count = np.where(self.ok, count, 0)
        total = int(count.sum())
        if total:
            owner = np.repeat(np.arange(len(count)), count)
            first = np.cumsum(count) - count
            starts = np.repeat(self.pos, count) + size * (np.arange(total) - first[owner])
            bad = np.zeros(total, dtype=bool)
            for offset, byte in checks:
                bad |= self.buf[starts + offset] != byte
            if bad.any():
                self.ok[np.unique(owner[bad])] = False
        self.pos += count * size

    def each(self, count: I64, step: Callable[[Cursors], None], least: int) -> None:
        """``count`` elements of variable size (``least`` bytes at least) per record: element
        k of every record at once. A count the bytes left cannot hold fails at once (a
        damaged length must not cost a loop of that many rounds)."""
        self.ok &= self.pos + count * least <= self.n
        count = np.where(self.ok, count, 0)
        for k in range(int(count.max()) if len(count) else 0):
            rows = (count > k) & self.ok
            if not rows.any():
                break
            sub = self.subset(rows)
            step(sub)
            self.merge(rows, sub)


@dataclass(frozen=True)
class Fixed:
    """Fixed-size fields: ``size`` bytes whose byte at each ``checks`` offset has its value
    (:data:`BOOL`: either bool tag); ``captures`` are ``(name, offset, dtype)`` values kept
    (dtype ``"bool"``: the bool tag at the offset is TRUE)."""

    size: int
    checks: tuple[tuple[int, int], ...]
    captures: tuple[tuple[str, int, str], ...] = ()

    def __add__(self, other: Fixed) -> Fixed:
        s = self.size
        return Fixed(
            s + other.size,
            self.checks + tuple((o + s, b) for o, b in other.checks),
            self.captures + tuple((n, o + s, d) for n, o, d in other.captures),
        )

    @functools.cached_property
    def _compare(self) -> tuple[I64, U8, U8]:
        """The checked offsets, a mask OR-ed into the bytes read (1 where either bool tag
        is fine: FALSE | 1 == TRUE) and the bytes expected then."""
        offsets = np.array([o for o, _ in self.checks], dtype=np.int64)
        either = np.array([b == BOOL for _, b in self.checks], dtype=bool)
        want = np.array([TRUE if b == BOOL else b for _, b in self.checks], dtype=np.uint8)
        return offsets, either.astype(np.uint8), want

    def run(self, c: Cursors, out: Values) -> None:
        base = c.base(self.size)
        offsets, either, want = self._compare
        rows = c.buf[base[:, None] + offsets]
        if either.any():
            rows |= either
        c.ok &= (rows == want).all(axis=1)
        for name, offset, dtype in self.captures:
            if dtype == "bool":
                out[name] = c.buf[base + offset] == TRUE
            else:
                out[name] = c.value(base, offset, dtype)
        c.pos += self.size


Step = Fixed | Callable[[Cursors, Values], None]


def scalar(tag: int, capture: str | None = None, dtype: str = "") -> Fixed:
    caps = ((capture, 1, dtype),) if capture else ()
    return Fixed(1 + WIDTH[tag], ((0, tag),), caps)


def scalars(*tags: int) -> Fixed:
    out = Fixed(0, ())
    for tag in tags:
        out = out + scalar(tag)
    return out


def booleans(n: int, capture: str | None = None) -> Fixed:
    """``n`` bools; ``capture`` keeps the first one's value."""
    caps = ((capture, 0, "bool"),) if capture else ()
    return Fixed(n, tuple((i, BOOL) for i in range(n)), caps)


def header(count: int) -> Fixed:
    """An ARR32 header of a fixed count (a fixed-size array follows)."""
    return Fixed(
        5, ((0, ARR), *((1 + i, b) for i, b in enumerate(count.to_bytes(4, "little"))))
    )


def position() -> Fixed:
    """A Vector3d (three FLOAT64, no array header) kept as ``x``, ``y``, ``z``."""
    caps = (("x", 1, "<f8"), ("y", 10, "<f8"), ("z", 19, "<f8"))
    return Fixed(27, ((0, F64), (9, F64), (18, F64)), caps)


def quaternion() -> Fixed:
    return header(4) + scalars(F64, F64, F64, F64)


def name(c: Cursors, out: Values) -> None:
    out["name_start"], out["name_len"] = c.string()


def fixed_matrix(tag: int, rows: int, cols: int) -> Fixed:
    """A fixed-size Eigen matrix (:func:`matrix` of exactly ``rows`` x ``cols``): its header,
    dimensions and entry tags are all fixed bytes."""
    dims = _constant(I64_, rows) + _constant(I64_, cols)
    return header(rows * cols + 2) + dims + scalars(*([tag] * (rows * cols)))


def _constant(tag: int, value: int) -> Fixed:
    """A scalar that must have one value (every byte of it checked)."""
    body = value.to_bytes(WIDTH[tag], "little")
    return Fixed(1 + len(body), ((0, tag), *((1 + i, b) for i, b in enumerate(body))))


def matrix(tag: int, rows: int | None = None, cols: int | None = None) -> Step:
    """An Eigen matrix: ARR32 of ``rows * cols + 2``, the two dimensions (INT64), the entries.
    A fixed-size matrix must have its size (spark_dsg reads a wrong one out of step)."""

    def step(c: Cursors, out: Values) -> None:
        length = c.length()
        dims: Values = {}
        Fixed(18, ((0, I64_), (9, I64_)), (("r", 1, "<i8"), ("k", 10, "<i8"))).run(c, dims)
        r, k = dims["r"].astype(np.int64), dims["k"].astype(np.int64)
        c.ok &= (r >= 0) & (k >= 0) & (r < 2**31) & (k < 2**31)
        if rows is not None:
            c.ok &= r == rows
        if cols is not None:
            c.ok &= k == cols
        count = np.where(c.ok, r, 0) * np.where(c.ok, k, 0)
        c.ok &= count + 2 == length
        c.elements(count, 1 + WIDTH[tag], [(0, tag)])

    return step


def vector(size: int, checks: Sequence[tuple[int, int]]) -> Step:
    def step(c: Cursors, out: Values) -> None:
        c.elements(c.length(), size, checks)

    return step


def scalar_vector(tag: int) -> Step:
    return vector(1 + WIDTH[tag], [(0, tag)])


def _nvi_layout(label: int) -> tuple[int, list[tuple[int, int]]]:
    """A NearestVertexInfo ``[[3 x INT32], [3 x FLOAT64], UINT64, label]`` whose label is
    NIL (67 bytes) or a UINT32 (71): its size and structural bytes."""
    f = header(4) + header(3) + scalars(I32, I32, I32) + header(3) + scalars(F64, F64, F64)
    f = f + scalar(U64) + Fixed(1, ((0, label),))
    return (67 if label == NIL else 71), list(f.checks)


_NVI_HEAD = header(4) + header(3) + scalars(I32, I32, I32) + header(3)
_NVI_HEAD = _NVI_HEAD + scalars(F64, F64, F64) + scalar(U64)


def _nvi_element(c: Cursors) -> None:
    _NVI_HEAD.run(c, {})
    label = c.buf[c.base(1)]
    nil = label == NIL
    c.pos += np.where(nil, 1, 0)
    if not nil.all():
        sub = c.subset(~nil)
        scalar(U32).run(sub, {})
        c.merge(~nil, sub)


def nearest_vertices(c: Cursors, out: Values) -> None:
    """A vector<NearestVertexInfo>: records whose elements all have one size are checked at
    once; the others (labels set on some elements only) element by element."""
    count = c.length()
    done = ~c.ok | (count == 0)
    for label in (NIL, U32):
        rows = ~done
        if not rows.any():
            break
        size, checks = _nvi_layout(label)
        trial = c.subset(rows)
        trial.elements(count[rows], size, checks)
        good = np.zeros(len(c), dtype=bool)
        good[rows] = trial.ok
        c.pos[good] = trial.pos[trial.ok]
        done |= good
    if not done.all():
        sub = c.subset(~done)
        sub.each(count[~done], _nvi_element, 67)
        c.merge(~done, sub)


def _probability(c: Cursors) -> None:
    c.string()
    scalar(F64).run(c, {})


def class_probabilities(c: Cursors, out: Values) -> None:
    """A map<string, double> (room class probabilities): entry k of every record at once."""
    c.each(c.length(), _probability, 14)


def compile_steps(steps: Sequence[Step]) -> list[Step]:
    """``steps`` with each run of :class:`Fixed` steps merged into one."""
    out: list[Step] = []
    for step in steps:
        if isinstance(step, Fixed) and out and isinstance(out[-1], Fixed):
            out[-1] = out[-1] + step
        else:
            out.append(step)
    return out


def run(steps: Sequence[Step], c: Cursors, out: Values) -> None:
    for step in steps:
        if isinstance(step, Fixed):
            step.run(c, out)
        else:
            step(c, out)


_NODE: list[Step] = [position(), scalar(U64), booleans(2)]  # last_update_time_ns, is_active,
# is_predicted (1.0.4 on)
_SEMANTIC: list[Step] = [
    *_NODE,
    name,
    scalars(U8_, U8_, U8_, U8_),  # color
    header(4) + scalar(I32) + scalars(F32, F32, F32, F32, F32, F32),  # bounding box ...
    fixed_matrix(F32, 3, 3),  # ... world_R_center
    scalar(U32),  # semantic_label
    matrix(F32),  # semantic_feature
]
_CONNECTIONS: list[Step] = [
    nearest_vertices,  # voxblox_mesh_connections
    scalar_vector(U64),  # pcl_mesh_connections
    scalar_vector(U8_),  # mesh_vertex_labels
    scalar_vector(U64),  # deformation_connections
]
#: The fields of each attribute class spark_dsg 1.1.3 writes, by registered name.
PROGRAMS: dict[str, list[Step]] = {
    name_: compile_steps(steps)
    for name_, steps in {
        "NodeAttributes": _NODE,
        "SemanticNodeAttributes": _SEMANTIC,
        "ObjectNodeAttributes": [*_SEMANTIC, scalar_vector(U64), booleans(1), quaternion()],
        "RoomNodeAttributes": [*_SEMANTIC, class_probabilities],
        "PlaceNodeAttributes": [
            *_SEMANTIC,
            scalars(F64, U32),  # distance, num_basis_points
            *_CONNECTIONS,
            booleans(2, capture="real_place"),  # real_place, active_frontier
            scalars(F64, F64, F64),  # frontier_scale
            quaternion(),  # orientation
            booleans(1),  # need_cleanup
            scalar(U64),  # num_frontier_voxels
            booleans(1),  # anti_frontier (1.1.3)
        ],
        "Place2dNodeAttributes": [
            *_SEMANTIC,
            vector(27, [(0, F64), (9, F64), (18, F64)]),  # boundary (Vector3d elements)
            scalars(F64, F64, F64),  # ellipse_centroid
            fixed_matrix(F64, 2, 2),  # ellipse_matrix_compress
            fixed_matrix(F64, 2, 2),  # ellipse_matrix_expand
            scalar_vector(U64),  # pcl_boundary_connections
            *_CONNECTIONS,
            booleans(2),  # need_cleanup_splitting, has_active_mesh_indices
        ],
        "AgentNodeAttributes": [
            *_NODE,
            scalar(I64_, "stamp_ns", "<i8"),  # timestamp (1.1.0 on)
            quaternion(),  # world_R_body
            scalar(U64),  # external_key
            matrix(U32, cols=1),  # dbow_ids
            matrix(F32, cols=1),  # dbow_values
        ],
    }.items()
}


@dataclass(frozen=True)
class ValueBytes:
    """The leading fixed-size fields of an attribute type (its program's first
    :class:`Fixed` step: a node's position and update time, an agent's stamp and pose): their
    ``size``, which of their bytes are values (``values[k]``: byte ``k`` is neither a tag nor
    a bool, whose bytes the step checks) and the values captured there."""

    size: int
    values: Bool
    captures: tuple[tuple[str, int, str], ...]


@functools.cache
def value_bytes(kind: str) -> ValueBytes | None:
    """:class:`ValueBytes` of attribute type ``kind`` (None: no program, or none that starts
    with fixed-size fields). A record whose bytes changed only there still reads as a record,
    field for field as before, with only those values new: what :mod:`formats.dsg_delta`
    reads in place."""
    program = PROGRAMS.get(kind)
    if not program or not isinstance(program[0], Fixed):
        return None
    step = program[0]
    values = np.ones(step.size, dtype=bool)
    values[[offset for offset, _ in step.checks]] = False
    for _, offset, dtype in step.captures:
        if dtype == "bool":
            values[offset] = False  # (checked as a bool already; kept out explicitly)
    values.flags.writeable = False
    return ValueBytes(step.size, values, step.captures)
