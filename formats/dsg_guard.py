"""Defences of every spark_dsg parse against damaged input (see :mod:`formats.dsg`).

spark_dsg trusts the length fields of its binary format, so a flipped byte can ask for
gigabytes. :func:`binary_problem` walks a binary graph's token stream before spark_dsg sees it;
:func:`_memory_budget` caps the address space a parse may add. Neither knows spark_dsg's
schema or imports it: they are byte-level checks, kept apart from the decoding they guard
(:mod:`formats.dsg_payload`, :mod:`formats.dsg_files`).
"""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Iterator

import numpy as np
import numpy.typing as npt

#: Address space a spark_dsg parse may add to the process: this much, plus
#: GRAPH_MEMORY_FACTOR times the size of its input (a valid graph needs a few times its size).
GRAPH_MEMORY_BASE = 512 * 1024**2
GRAPH_MEMORY_FACTOR = 16


def _address_space() -> int | None:
    """This process's virtual memory size in bytes (Linux ``/proc/self/statm``), or None."""
    try:
        with open("/proc/self/statm", "rb") as fh:
            pages = int(fh.read().split()[0])
        return pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


@contextlib.contextmanager
def _memory_budget(nbytes: int) -> Iterator[int | None]:
    """Lower the soft address-space limit (``RLIMIT_AS``) to the current size plus
    :data:`GRAPH_MEMORY_BASE` + :data:`GRAPH_MEMORY_FACTOR` x ``nbytes`` for the block, and put
    it back after: an allocation spark_dsg makes from a damaged length fails (MemoryError)
    instead of taking gigabytes. Yields the budget in bytes (None where the process size
    cannot be read: no limit is set). An existing lower limit is kept."""
    try:
        import resource
    except ImportError:  # not a POSIX system
        yield None
        return
    current = _address_space()
    if current is None:
        yield None
        return
    budget = GRAPH_MEMORY_BASE + GRAPH_MEMORY_FACTOR * int(nbytes)
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = current + budget
    for bound in (soft, hard):
        if bound != resource.RLIM_INFINITY:
            limit = min(limit, bound)
    if limit == soft:
        yield budget
        return
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    try:
        yield budget
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


# spark_dsg's binary format, a msgpack subset (serialization/binary_serialization_utils.h):
# every value is a tag byte and a fixed-size body (the sizes below), except ARR32 (0xdd) and
# STR32 (0xdb): a uint32 count, then either ``count`` raw bytes (a string) or ``count``
# elements, each a value again (a vector; its reader resizes to ``count`` first). Dynamic
# arrays are 0x00 ... 0x01 around values. A file is its header's values, then the graph's.
_SCALAR_BODY = {
    0xC0: 0, 0xC2: 0, 0xC3: 0, 0x00: 0, 0x01: 0,  # nil, false, true, dynamic array start / end
    0xCC: 1, 0xD0: 1, 0xCD: 2, 0xD1: 2, 0xCA: 4, 0xCE: 4, 0xD2: 4, 0xCB: 8, 0xCF: 8, 0xD3: 8,
}
_VALUE_TAGS = frozenset([*_SCALAR_BODY, 0xDB, 0xDD])
_SCALAR_RUN = re.compile(
    rb"(?:[\xc0\xc2\xc3\x00\x01]|[\xcc\xd0].|[\xcd\xd1].{2}|[\xca\xce\xd2].{4}"
    rb"|[\xcb\xcf\xd3].{8})*",
    re.S,
)
#: An array this long is first tried as repetitions of one element layout (numpy, no loop).
_REPEAT_MIN = 32
#: Most branch points the exhaustive walk visits before it gives up (about 2 s).
_WALK_STEPS = 2_000_000


def binary_problem(data: bytes, start: int = 0) -> str | None:
    """What makes ``data[start:]`` (a spark_dsg binary graph: header and graph, or a bare
    payload) unreadable as spark_dsg's token stream, or None when some reading of it is valid
    to the last byte (or when deciding would take too long: then spark_dsg decides, under
    :func:`_memory_budget`).

    The token stream is walked without the graph's schema, so where an ARR32 is a string (raw
    bytes) or a vector (values) is not known: the walk tries both (depth first, each array
    position once). A first pass takes shortcuts (repeated element layouts and runs of one
    scalar type checked with numpy: the bulk of a mesh), accepting only what it verified;
    only if it fails does an exhaustive pass decide, naming the damage found farthest in."""
    if _walk(data, start, shortcuts=True) is None:
        return None
    return _walk(data, start, shortcuts=False)


def _walk(data: bytes, start: int, shortcuts: bool) -> str | None:
    buf = np.frombuffer(data, dtype=np.uint8)
    n = len(data)
    stack, seen = [start], set()
    worst, problem = -1, "no reading of the bytes reaches the end"
    steps = 0
    while stack:
        p = stack.pop()
        while True:
            if shortcuts:
                p = _same_scalar_run(buf, data, p)
            p = _SCALAR_RUN.match(data, p).end()  # type: ignore[union-attr]
            if p == n:
                return None
            steps += 1
            if steps > _WALK_STEPS:
                return None  # undecided: spark_dsg reads it under the memory budget
            tag = data[p]
            if tag not in (0xDB, 0xDD):
                if p > worst:
                    worst = p
                    problem = (f"byte {p} (0x{tag:02x}) is not a value" if tag not in _VALUE_TAGS
                               else f"the value at byte {p} is cut short by the end of the file")
                break
            if p in seen:
                break
            seen.add(p)
            count = int.from_bytes(data[p + 1 : p + 5], "little") if p + 5 <= n else -1
            rest = n - p - 5
            if count < 0 or count > rest:
                if p > worst:
                    worst = p
                    problem = (f"the array at byte {p} is cut short by the end of the file"
                               if count < 0 else f"the array at byte {p} claims {count:,} "
                               f"elements but only {rest:,} bytes follow")
                break
            as_bytes = p + 5 + count
            if tag == 0xDB or count == 0:
                p = as_bytes
            elif data[p + 5] in _VALUE_TAGS:  # values first, a string as the alternative
                stack.append(as_bytes)
                end = _repeated(buf, data, p + 5, count) if shortcuts else None
                p = p + 5 if end is None else end
            else:
                stack.append(p + 5)
                p = as_bytes
    return f"{problem} ({n:,} bytes)"


def _layout(data: bytes, p: int, tokens: int = 16) -> list[tuple[int, list[int]]]:
    """The first ``tokens`` values from ``p`` (vectors preferred over strings): for each
    prefix, its size and the offsets of its structural bytes (tags, array counts)."""
    out: list[tuple[int, list[int]]] = []
    offsets: list[int] = []
    q, n = p, len(data)
    for _ in range(tokens):
        if q >= n:
            break
        tag = data[q]
        if tag in _SCALAR_BODY:
            offsets.append(q - p)
            q += 1 + _SCALAR_BODY[tag]
        elif tag in (0xDB, 0xDD) and q + 5 <= n:
            offsets.extend(range(q - p, q - p + 5))
            count = int.from_bytes(data[q + 1 : q + 5], "little")
            raw = tag == 0xDB or count == 0 or (q + 5 < n and data[q + 5] not in _VALUE_TAGS)
            q += 5 + (count if raw else 0)
        else:
            break
        if q > n:
            break
        out.append((q - p, list(offsets)))
    return out


def _repeated(buf: npt.NDArray[np.uint8], data: bytes, p: int, count: int) -> int | None:
    """The end of ``count`` elements from ``p`` that all have the layout of the first (the
    same structural bytes at the same offsets; the bodies may differ), or None. Each prefix of
    the first values is tried as the element size; the compare is one numpy gather."""
    if count < _REPEAT_MIN:
        return None
    rest = len(data) - p
    for size, offsets in _layout(data, p):
        if size * count > rest:
            break
        rows = buf[p : p + size * count].reshape(count, size)[:, offsets]
        if (rows == rows[0]).all():
            return p + size * count
    return None


def _same_scalar_run(buf: npt.NDArray[np.uint8], data: bytes, p: int) -> int:
    """``p`` moved past runs of at least 64 values of one scalar type (a mesh's coordinates,
    colours, stamps), found with strided numpy compares of growing length."""
    n = len(data)
    while p < n and data[p] in _SCALAR_BODY:
        tag, size = data[p], 1 + _SCALAR_BODY[data[p]]
        start, block = p, 64
        while True:
            m = min(block, (n - p) // size)
            if m < 64:
                break
            tags = buf[p : p + m * size : size]
            off = np.flatnonzero(tags != tag)
            if len(off):
                if p > start or off[0] >= 64:
                    p += int(off[0]) * size
                break
            p += m * size
            block *= 8
        if p == start:
            break
    return p
