"""spark_dsg's binary graph format read with numpy: the parts of a DsgUpdate payload a
navigational snapshot needs, without building a spark_dsg graph.

Why: ``DynamicSceneGraph.from_binary`` builds every node as a C++ object (~18 ms for 5,000
places) and the per-node binding calls that read them back cost as much again; a live Hydra
sends such a graph every second. The format (spark_dsg 1.1.3,
``serialization/graph_binary_serialization.cpp``) is a msgpack subset of tagged values
(:mod:`formats.dsg_guard`): the layer keys, the attribute type names, the layer names and
the graph metadata, then every node as ``[layer, id, partition, attributes]`` (the attributes
are a type index, a metadata JSON string and the fields of that type, in the order of its
``serialization_info``), then every edge as ``[source, target, attributes]``, then a mesh flag
and the mesh.

Nodes and edges vary in size (strings, vectors), so they are read in *lock-step*: every
place where a record may start is found at once (:func:`_candidates`: the fixed bytes a
record begins with), all candidates are read field by field together (one numpy gather per
field: :mod:`formats.dsg_binary_fields`), and the real records are the chain that starts at
the first one and goes from each record's end to the next (:func:`_chain`); a candidate
inside another record's bytes is never on that chain.

**Only what spark_dsg itself would read, exactly.** The reader is stricter than spark_dsg:
every tag, fixed array length and matrix shape is checked, strings must be ``ARR32``, the
payload must end with the mesh, node ids must be unique, metadata must be JSON both parsers
accept, and only the attribute types listed in :data:`_PROGRAMS` are known. Anything else
(another version's layout, a damaged payload, an unknown type, a self-edge spark_dsg would
warn about) makes :func:`read_graph` return None and the caller decodes with spark_dsg, so
the fast path can only ever give what spark_dsg gives (``tests/formats/test_dsg_fast.py``
compares them on every graph the tests have). Reads are bounds-checked and no allocation is
larger than the payload's own bytes allow, so damaged lengths cannot ask for gigabytes.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aion_cli.formats.dsg_binary_fields import (
    PROGRAMS,
    Cursors,
    Values,
    booleans,
    run,
    scalar,
    words,
)

I64 = npt.NDArray[np.int64]
U64 = npt.NDArray[np.uint64]
U8 = npt.NDArray[np.uint8]
F64 = npt.NDArray[np.float64]
Bool = npt.NDArray[np.bool_]

#: The spark_dsg format version whose payload layout this module reads (a payload carries no
#: version; spark_dsg reads it as its own, so the fast path needs this spark_dsg installed).
BINARY_VERSION = "1.1.3"

_FALSE, _TRUE = 0xC2, 0xC3
_F32, _F64, _U8, _U32, _U64, _I32, _I64 = 0xCA, 0xCB, 0xCC, 0xCE, 0xCF, 0xD2, 0xD3
_ARR, _START, _END = 0xDD, 0x00, 0x01
_WIDTH = {_F32: 4, _F64: 8, _U8: 1, _U32: 4, _U64: 8, _I32: 4, _I64: 8}


class _OutsideError(Exception):
    """The payload is not one this reader vouches for (spark_dsg decodes it instead)."""


@dataclass(frozen=True)
class BinaryGraph:
    """What :func:`read_graph` read: layers, nodes (payload order), edges and the mesh.

    Node arrays are per node: ``layer``/``partition`` its key, ``ids`` its NodeSymbol value,
    ``kind`` the attribute class name (index into ``kinds``), ``xyz`` its position,
    ``name_start``/``name_len`` its ``name`` bytes in ``data`` (-1: the type has no name),
    ``real_place`` (True unless a ``PlaceNodeAttributes`` says otherwise) and ``stamp_ns``
    (an agent's timestamp, 0 for other types). ``mesh`` is None without a mesh, else
    ``(points float32[v,3], colors uint8[c,4], faces uint64[f,3])``. ``node_start`` /
    ``node_end`` are where each node record's bytes begin and end in ``data`` (consecutive:
    one record ends where the next begins), what :mod:`formats.dsg_delta` re-reads;
    ``node_body`` where each record's attribute fields begin (after its metadata text), from
    where :mod:`formats.dsg_delta` reads a record's new values in place."""

    data: U8
    layer_keys: list[tuple[int, int]]
    layer_names: dict[str, tuple[int, int]]
    kinds: list[str]
    layer: I64
    partition: I64
    ids: U64
    kind: I64
    xyz: F64
    name_start: I64
    name_len: I64
    real_place: Bool
    stamp_ns: I64
    edge_source: U64
    edge_target: U64
    mesh: tuple[npt.NDArray[np.float32], U8, U64] | None
    node_start: I64
    node_end: I64
    node_body: I64


# -- the whole payload ---------------------------------------------------------------------
class _Scalar:
    """Sequential reads of the few values before the nodes (Python ints)."""

    def __init__(self, data: memoryview, pos: int = 0) -> None:
        self.data = data
        self.pos = pos

    def take(self, tag: int) -> int:
        w = _WIDTH[tag]
        p = self.pos
        if p + 1 + w > len(self.data) or self.data[p] != tag:
            raise _OutsideError
        self.pos = p + 1 + w
        signed = tag in (_I32, _I64)
        return int.from_bytes(self.data[p + 1 : p + 1 + w], "little", signed=signed)

    def length(self) -> int:
        p = self.pos
        if p + 5 > len(self.data) or self.data[p] != _ARR:
            raise _OutsideError
        self.pos = p + 5
        return int.from_bytes(self.data[p + 1 : p + 5], "little")

    def text(self) -> bytes:
        n = self.length()
        if self.pos + n > len(self.data):
            raise _OutsideError
        self.pos += n
        return bytes(self.data[self.pos - n : self.pos])

    def key(self) -> tuple[int, int]:
        if self.length() != 2:
            raise _OutsideError
        return self.take(_I64), self.take(_U32)

    def byte(self, expected: int) -> None:
        if self.pos >= len(self.data) or self.data[self.pos] != expected:
            raise _OutsideError
        self.pos += 1


def _strings(s: _Scalar, limit: int = 256) -> list[str]:
    n = s.length()
    if n > limit:
        raise _OutsideError
    return [s.text().decode("ascii") for _ in range(n)]


def _candidates(buf: U8, arrays: I64, fixed: Sequence[tuple[int, int]]) -> I64:
    """The positions of ``arrays`` (ARR32 tags, or records' starts) at which the bytes of
    ``fixed`` are (offset, value; offsets from the position), with the whole span inside the
    buffer."""
    span = max(o for o, _ in fixed) + 1
    idx = arrays[arrays <= len(buf) - span]
    for off, byte in fixed:
        idx = idx[buf[idx + off] == byte]
    return idx.astype(np.int64)


def _chain(buf: U8, first: int, starts: I64, ends: I64, ok: Bool) -> tuple[I64, int]:
    """The records from ``first`` to the dynamic array's end byte, each starting where the one
    before ended: their candidate indices and the position of the end byte."""
    n = len(buf)
    if len(starts) and ok.all() and starts[0] == first and (ends[:-1] == starts[1:]).all():
        last = int(ends[-1])
        if last < n and buf[last] == _END:
            return np.arange(len(starts)), last
    # a candidate inside another record's bytes (or a record not found): follow the chain
    where = {int(s): i for i, s in enumerate(starts.tolist()) if ok[i]}
    out: list[int] = []
    pos = first
    while pos < n and buf[pos] != _END:
        i = where.get(pos)
        if i is None:
            raise _OutsideError
        out.append(i)
        pos = int(ends[i])
    if pos >= n:
        raise _OutsideError
    return np.asarray(out, dtype=np.int64), pos


def _metadata_ok(buf: U8, start: I64, length: I64) -> bool:
    """Whether nlohmann::json (spark_dsg) parses every metadata text: ``{}`` (checked at once,
    the usual value) and each distinct other text that Python's parser reads without
    NaN/Infinity constants or ``\\u`` escapes (lone surrogates: nlohmann refuses them)."""
    empty = (length == 2) & (buf[np.minimum(start, len(buf) - 1)] == ord("{"))
    empty &= buf[np.minimum(start + 1, len(buf) - 1)] == ord("}")
    rest = np.flatnonzero(~empty)
    texts = {bytes(buf[start[i] : start[i] + length[i]]) for i in rest.tolist()}
    return _json_ok(texts)


def _json_ok(texts: set[bytes]) -> bool:
    """Whether nlohmann::json would parse each text (see :func:`_metadata_ok`)."""
    for t in texts:
        if t == b"{}":
            continue
        try:
            s = t.decode("utf-8")
            if "\\u" in s:
                return False
            json.loads(s, parse_constant=_refuse)
        except Exception:  # any failure: spark_dsg decides
            return False
    return True


def _refuse(name: str) -> None:
    raise ValueError(name)


_NODE_HEAD = [(0, _ARR), (1, 4), (2, 0), (3, 0), (4, 0), (5, _I64), (14, _U64), (23, _U32)]
_NODE_HEAD += [(28, _U8), (30, _ARR)]
_EDGE_HEAD = [(0, _ARR), (1, 3), (2, 0), (3, 0), (4, 0), (5, _U64), (14, _U64), (23, _U8)]
_EDGE_HEAD += [(25, _ARR)]
_EDGE_FIELDS = [booleans(1) + scalar(_F64)]  # EdgeAttributes: weighted, weight
_EDGE_KINDS = ["EdgeAttributes"]


def _nodes(buf: U8, first: int, arrays: I64, kinds: list[str]) -> tuple[Values, int]:
    """Every node record from ``first`` (after the dynamic array's start byte; ``arrays``:
    the positions of every ARR32 tag from there): the values of :class:`BinaryGraph` per
    node (with ``start``/``end``, each record's bytes), and the position of the array's end
    byte."""
    cand = _candidates(buf, arrays, _NODE_HEAD)
    cols, ends, ok, meta = node_records(buf, cand, kinds)
    order, end = _chain(buf, first, cand, ends, ok)
    if not _metadata_ok(buf, meta[0][order], meta[1][order]):
        raise _OutsideError
    nodes = {name: values[order] for name, values in cols.items()}
    nodes["start"], nodes["end"] = cand[order], ends[order]
    nodes["body"] = meta[0][order] + meta[1][order]
    return nodes, end


def node_records(
    buf: U8, starts: I64, kinds: list[str]
) -> tuple[Values, I64, Bool, tuple[I64, I64]]:
    """The node records beginning at ``starts`` read in lock-step: their values (positions,
    names, ``real_place``, stamps, layer, id, partition and kind), where each ends, whether
    each read as a record, and where each one's metadata text lies (start, length). The
    fixed head bytes of a record (:data:`_NODE_HEAD`) are the caller's to have checked."""
    m = len(starts)
    c = Cursors(buf, starts + 30)
    kind = buf[starts + 29].astype(np.int64)
    meta = c.string()
    cols: Values = {
        "x": np.zeros(m), "y": np.zeros(m), "z": np.zeros(m),
        "name_start": np.full(m, -1, np.int64), "name_len": np.zeros(m, np.int64),
        "real_place": np.ones(m, bool), "stamp_ns": np.zeros(m, np.int64),
    }  # fmt: skip
    for k in np.flatnonzero(np.bincount(kind, minlength=1)).tolist():
        rows = kind == k
        program = PROGRAMS.get(kinds[k]) if k < len(kinds) else None
        if program is None:  # spark_dsg would make no attributes and read on out of step
            c.ok[rows] = False
            continue
        sub = c.subset(rows)
        out: Values = {}
        run(program, sub, out)
        c.merge(rows, sub)
        for name, values in out.items():
            cols[name][rows] = values
    cols["layer"] = _gather(buf, starts + 6, "<i8")
    cols["ids"] = _gather(buf, starts + 15, "<u8")
    cols["partition"] = _gather(buf, starts + 24, "<u4").astype(np.int64)
    cols["kind"] = kind
    return cols, c.pos, c.ok, meta


def heads_ok(buf: U8, starts: I64) -> bool:
    """Whether a node record's fixed head bytes (:data:`_NODE_HEAD`) are at every one of
    ``starts`` (the check :func:`_candidates` makes of every possible start)."""
    return len(_candidates(buf, starts, _NODE_HEAD)) == len(starts)


def _gather(buf: U8, pos: I64, dtype: str) -> npt.NDArray[np.generic]:
    return words(buf, dtype)[pos]


def _edges(buf: U8, first: int, arrays: I64) -> tuple[U64, U64, int]:
    """Every edge record from ``first``: sources, targets and the array's end byte."""
    cand = _candidates(buf, arrays[np.searchsorted(arrays, first) :], _EDGE_HEAD)
    c = Cursors(buf, cand + 25)
    meta_start, meta_len = c.string()
    run(_EDGE_FIELDS, c, {})
    order, end = _chain(buf, first, cand, c.pos, c.ok)
    at = cand[order]
    if (buf[at + 24] != 0).any():  # the type index: 0, EdgeAttributes
        raise _OutsideError
    if not _metadata_ok(buf, meta_start[order], meta_len[order]):
        raise _OutsideError
    source = _gather(buf, at + 6, "<u8").astype(np.uint64)
    return source, _gather(buf, at + 15, "<u8").astype(np.uint64), end


def _fixed_vector(
    buf: U8, pos: int, size: int, checks: Sequence[tuple[int, int]]
) -> tuple[U8, int]:
    """A vector of fixed-layout elements at ``pos``: its bytes as uint8[count, size]."""
    c = Cursors(buf, np.array([pos]))
    count = c.length()
    c.elements(count, size, checks)
    if not c.ok[0]:
        raise _OutsideError
    start = pos + 5
    n = int(count[0])
    return buf[start : start + n * size].reshape(n, size), start + n * size


def _mesh(buf: U8, pos: int) -> tuple[tuple[npt.NDArray[np.float32], U8, U64], int]:
    """The mesh: four flags, points (3 x FLOAT32), colors (4 x UINT8), stamps (UINT64),
    labels (UINT32), first-seen stamps (UINT64), faces (ARR32 of 3 x UINT64)."""
    c = Cursors(buf, np.array([pos]))
    booleans(4).run(c, {})
    if not c.ok[0]:
        raise _OutsideError
    pos = int(c.pos[0])
    pts, pos = _fixed_vector(buf, pos, 15, [(0, _F32), (5, _F32), (10, _F32)])
    cols, pos = _fixed_vector(buf, pos, 8, [(0, _U8), (2, _U8), (4, _U8), (6, _U8)])
    _, pos = _fixed_vector(buf, pos, 9, [(0, _U64)])
    _, pos = _fixed_vector(buf, pos, 5, [(0, _U32)])
    _, pos = _fixed_vector(buf, pos, 9, [(0, _U64)])
    face_checks = [(0, _ARR), (1, 3), (2, 0), (3, 0), (4, 0), (5, _U64), (14, _U64), (23, _U64)]
    faces, pos = _fixed_vector(buf, pos, 32, face_checks)
    points = pts.reshape(-1, 5)[:, 1:].copy().view("<f4").reshape(-1, 3)
    colors = cols.reshape(-1, 2)[:, 1].reshape(-1, 4).copy()
    idx = faces[:, 5:].reshape(-1, 3, 9)[:, :, 1:].copy().view("<u8").reshape(-1, 3)
    return (points, colors, idx), pos


def read_graph(payload: bytes | bytearray | memoryview | U8) -> BinaryGraph | None:
    """The parts of a spark_dsg 1.1.3 binary graph (a DsgUpdate payload, no file header) that
    a navigational snapshot needs, or None when the payload is not one this reader vouches
    for (see the module docstring): spark_dsg must decode it then."""
    buf = np.frombuffer(payload, dtype=np.uint8)
    try:
        return _read(buf, memoryview(buf.data))
    except _OutsideError:
        return None
    except (UnicodeDecodeError, ValueError, IndexError, OverflowError):
        return None


def _read(buf: U8, data: memoryview) -> BinaryGraph:
    s = _Scalar(data)
    keys = [s.key() for _ in range(s.length())]
    kinds = _strings(s)
    if _strings(s) != _EDGE_KINDS:
        raise _OutsideError
    names: dict[str, tuple[int, int]] = {}
    for _ in range(s.length()):
        name = s.text().decode("utf-8")
        names[name] = s.key()
    if not _json_ok({s.text()}):  # spark_dsg would warn (on stderr) that it is no JSON
        raise _OutsideError
    s.byte(_START)
    arrays = np.flatnonzero(buf[s.pos :] == _ARR) + s.pos  # where records may start
    nodes, pos = _nodes(buf, s.pos, arrays, kinds)
    ids = np.sort(nodes["ids"])  # (np.unique's hashing is 20x slower on 5,000 ids)
    if (ids[1:] == ids[:-1]).any():
        raise _OutsideError  # spark_dsg keeps the first key and the last attributes
    if pos + 1 >= len(buf) or buf[pos + 1] != _START:
        raise _OutsideError
    source, target, pos = _edges(buf, pos + 2, arrays)
    if (source == target).any():
        raise _OutsideError  # spark_dsg warns on stderr about a self-edge
    pos += 1
    mesh = None
    if pos < len(buf) and buf[pos] == _TRUE:
        mesh, pos = _mesh(buf, pos + 1)
    elif pos < len(buf) and buf[pos] == _FALSE:
        pos += 1
    if pos != len(buf):
        raise _OutsideError
    xyz = np.column_stack([nodes["x"], nodes["y"], nodes["z"]]).astype(np.float64)
    return BinaryGraph(
        buf, keys, names, kinds,
        nodes["layer"].astype(np.int64), nodes["partition"].astype(np.int64),
        nodes["ids"].astype(np.uint64), nodes["kind"].astype(np.int64),
        xyz.reshape(-1, 3), nodes["name_start"].astype(np.int64),
        nodes["name_len"].astype(np.int64), nodes["real_place"].astype(bool),
        nodes["stamp_ns"].astype(np.int64), source, target, mesh,
        nodes["start"].astype(np.int64), nodes["end"].astype(np.int64),
        nodes["body"].astype(np.int64),
    )  # fmt: skip
