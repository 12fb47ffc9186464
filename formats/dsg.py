"""Hydra / spark_dsg scene graphs -> :class:`GraphSnapshot`.

Three entry points:

- :func:`decode_dsg_update` decodes the ``layer_contents`` payload of a ``hydra_msgs/DsgUpdate``
  message. ROS payloads carry no version header and spark_dsg's binary format is positional, so a
  payload written by an older spark_dsg makes ``from_binary`` throw. We then retry through the
  versioned-header fallback (``../shared/reference/notes-formats.md`` §1.4): put a 29-byte
  ``SPARK_DSG`` file header naming an older version in front of the payload, write it to a
  temporary ``.sparkdsg`` and ``DynamicSceneGraph.load`` it. A wrong version fails loudly, so
  trying versions newest first is safe. :func:`decode_dsg` also reports which version worked so a
  caller can pin it for the rest of a log (each failed try costs a parse and a warning line that
  spark_dsg prints itself).
- :func:`load_graph` reads Hydra's saved files (``dsg.json``, ``dsg_with_mesh.json``,
  ``.sparkdsg``, legacy header-less JSON); a JSON file spark_dsg refuses is read leniently
  (:mod:`formats.dsg_json`) and the result says what was skipped.
- :func:`navigation` (behind all of them, and :func:`snapshot_from_dsg`) turns any spark_dsg graph
  into the navigational :class:`GraphSnapshot`.

**One navigational layer rule for every command that reads a scene graph** (build, simulate and
the evaluation through it, info; predict / plan / export read the graph stored in the map):
layers are spark_dsg *keys*, a layer id and a partition (``3[1]``). Without a choice, the 2D
places are taken when the graph has any — the layer the graph names ``MESH_PLACES`` (spark_dsg
1.1.x: partition 1 of layer 3, ``3[1]``; older Hydra graphs: layer 20) — else ``PLACES``
(layer 3). ``--nav-layer NAME|KEY`` (``MESH_PLACES``, ``PLACES``, any name the graph gives a
layer, ``3[1]``, ``20``) overrides it; :func:`parse_nav_layer` checks its syntax.

spark_dsg is imported inside the functions (heavy import, see docs/CONTRACTS.md).

**Damaged input.** spark_dsg trusts the length fields of its binary format: a vector is
resized to the length it reads before its elements are, so one flipped length byte asks for
gigabytes (``std::bad_alloc``, or gigabytes really touched). Two defences:

- :func:`binary_problem` walks a ``.sparkdsg`` file's token stream (spark_dsg's msgpack subset,
  see the function) before spark_dsg sees it: an array that claims more elements than bytes
  follow, a cut-short value or a byte that is no value is a :class:`GraphFileError` naming
  the byte, exit 2. A valid file always passes (the walk accepts when *any* reading of the
  bytes is valid); a 110 MB graph with a 10^6-vertex mesh takes ~0.5 s.
- every spark_dsg parse (files and DsgUpdate payloads, which are too many to walk) runs under
  :func:`_memory_budget`: the process's address space may grow by at most
  :data:`GRAPH_MEMORY_BASE` + :data:`GRAPH_MEMORY_FACTOR` x the input's size, so a damaged
  length becomes a MemoryError (a decode error) instead of a machine out of memory.
"""

from __future__ import annotations

import contextlib
import ctypes
import datetime
import functools
import itertools
import operator
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.node_ids import INDEX_BITS, INDEX_MASK
from aion_cli.engine.types import GraphSnapshot, Layer, Mesh, Trajectory
from aion_cli.errors import InputError, MessageDecodeError

#: Older payload versions tried, newest first, when the installed spark_dsg cannot read a payload.
#: Before 1.0.2 (kimera_dsg era) spark_dsg itself refuses to read.
FALLBACK_VERSIONS: tuple[str, ...] = (
    "1.1.2",
    "1.1.1",
    "1.1.0",
    "1.0.6",
    "1.0.5",
    "1.0.4",
    "1.0.3",
    "1.0.2",
)

#: Layer ids of the hierarchy (spark_dsg ``DsgLayers``), used when a graph has no layer names.
PLACES_LAYER = 3
ROOMS_LAYER = 4
BUILDINGS_LAYER = 5
AGENTS_LAYER = 2
MESH_PLACES_PARTITION = 1
#: Where Hydra put its 2D (mesh) places before spark_dsg 1.1 had layer partitions.
LEGACY_MESH_PLACES_LAYER = 20
#: Layer names of keys a graph does not name itself (spark_dsg ``DsgLayers`` defaults).
DEFAULT_LAYER_NAMES: dict[tuple[int, int], str] = {
    (1, 0): "SEGMENTS",
    (2, 0): "OBJECTS",
    (PLACES_LAYER, 0): "PLACES",
    (PLACES_LAYER, MESH_PLACES_PARTITION): "MESH_PLACES",
    (ROOMS_LAYER, 0): "ROOMS",
    (BUILDINGS_LAYER, 0): "BUILDINGS",
    (LEGACY_MESH_PLACES_LAYER, 0): "MESH_PLACES",
}
NAV_LAYER_HINT = (
    "give a layer name (MESH_PLACES, PLACES) or key (3, 3[1], 20) with --nav-layer; "
    "`aion info GRAPH_FILE` lists a graph's layers"
)

PayloadLike = bytes | bytearray | memoryview | npt.NDArray[np.uint8]


class GraphFileError(InputError):
    """A scene-graph file is missing, unreadable or not a spark_dsg graph."""


class GraphLayerError(InputError):
    """The requested navigational layer is not in the scene graph."""


@dataclass(frozen=True)
class NavLayer:
    """The layer key a navigational graph came from, and its name.

    ``name`` is the upper-case spark_dsg name (the graph's own, else the default of the key;
    ``""`` for a key nobody names); ``legacy`` marks MESH_PLACES found at layer 20.
    """

    layer: int
    partition: int = 0
    name: str = ""
    legacy: bool = False

    @property
    def key(self) -> str:
        """spark_dsg's notation: ``3`` for partition 0, ``3[1]`` otherwise."""
        return str(self.layer) if self.partition == 0 else f"{self.layer}[{self.partition}]"

    @property
    def snapshot_name(self) -> str:
        """The ``GraphSnapshot.layer_name`` (and predict's layer column): ``mesh_places``,
        ``places``, another name in lower case, or ``layer_<key>``."""
        return self.name.lower() if self.name else f"layer_{self.key}"

    def __str__(self) -> str:
        return f"{self.name} ({self.key})" if self.name else self.key


@dataclass(frozen=True)
class NavGraph:
    """The navigational part of one spark_dsg graph, and how it was found.

    ``frontiers`` counts the frontier places (``real_place`` false) left out; ``clearance``
    (only when asked for) is each place's free-space ``distance`` attribute, 0 where the node
    type has none (2D places).
    """

    snapshot: GraphSnapshot
    layer: NavLayer
    frontiers: int = 0
    clearance: npt.NDArray[np.float64] | None = None


@dataclass(frozen=True)
class DecodedGraph:
    """A decoded payload and the spark_dsg format version that read it.

    ``version`` is ``"X.Y.Z"``; the installed spark_dsg's own version means ``from_binary``
    read the payload directly, any other value means the versioned-header fallback did.
    ``layer`` is the navigational layer taken.
    """

    snapshot: GraphSnapshot
    version: str
    layer: NavLayer = NavLayer(PLACES_LAYER, 0, "PLACES")


@functools.cache
def installed_version() -> str:
    """The spark_dsg version whose binary format ``from_binary`` reads natively (cached: the
    package metadata lookup costs milliseconds and runs once per scene-graph message)."""
    return metadata.version("spark-dsg")


def spark_header(version: str) -> bytes:
    """The 29-byte ``SPARK_DSG`` file header naming ``version`` (``"X.Y.Z"``).

    Layout (verified from a saved ``.sparkdsg``): STR32 "SPARK_DSG", STR32 "main", then the three
    version numbers as UINT8.
    """
    major, minor, patch = _parse_version(version)
    return (
        b"\xdd"
        + (9).to_bytes(4, "little")
        + b"SPARK_DSG"
        + b"\xdd"
        + (4).to_bytes(4, "little")
        + b"main"
        + bytes((0xCC, major, 0xCC, minor, 0xCC, patch))
    )


def _parse_version(version: str) -> tuple[int, int, int]:
    parts = version.strip().split(".")
    try:
        nums = tuple(int(p) for p in parts)
    except ValueError:
        nums = ()
    if len(nums) != 3 or not all(0 <= n <= 255 for n in nums):
        raise MessageDecodeError(
            f"invalid spark_dsg version {version!r}",
            hint="give a version as X.Y.Z, e.g. 1.1.1",
        )
    return nums[0], nums[1], nums[2]


def _as_bytes(payload: PayloadLike) -> bytes:
    """spark_dsg's ``from_binary`` accepts only ``bytes``; rosbags hands out uint8 arrays."""
    if isinstance(payload, bytes):
        return payload
    if isinstance(payload, np.ndarray):
        return np.ascontiguousarray(payload, dtype=np.uint8).tobytes()
    return bytes(payload)


def _candidate_versions(payload: bytes) -> list[str]:
    """Versions to try, most likely first.

    Byte 5 of a payload is the type tag of the first layer entry: an array (0xdd, a layer key)
    from 1.1.2 on, an INT64 (0xd3, a layer id) before. Versions of the other family are still
    tried, last, in case the sniff is fooled.
    """
    native = installed_version()
    ordered = [native, *[v for v in FALLBACK_VERSIONS if v != native]]
    if len(payload) > 5 and payload[5] == 0xD3:
        early = [v for v in ordered if _parse_version(v) <= (1, 1, 1)]
        return early + [v for v in ordered if v not in early]
    return ordered


@contextlib.contextmanager
def _native_output_silenced() -> Iterator[None]:
    """Send file descriptors 1 and 2 to /dev/null for the block.

    spark_dsg's C++ logger prints "Loading file with outdated encoding" on *stdout* for every
    load of an older version, which would corrupt ``--format json`` output (and flood the
    terminal: one line per scene-graph message). aion reports the version it used instead.
    """
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:
        yield
        return
    saved: list[tuple[int, int]] = []
    try:
        for fd in (1, 2):
            with contextlib.suppress(OSError):
                saved.append((fd, os.dup(fd)))
                os.dup2(devnull, fd)
        yield
    finally:
        with contextlib.suppress(Exception):
            ctypes.CDLL(None).fflush(None)  # C stdio buffers still hold the C++ output
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


def _load_with_header(payload: bytes, version: str) -> Any:
    """``DynamicSceneGraph.load`` of ``header(version) + payload`` via a temporary file."""
    import spark_dsg

    fd, name = tempfile.mkstemp(suffix=".sparkdsg", prefix="aion-dsg-")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(spark_header(version))
            fh.write(payload)
        with _native_output_silenced(), _memory_budget(len(payload)):
            return spark_dsg.DynamicSceneGraph.load(name)
    finally:
        os.unlink(name)


# --------------------------------------------------------------------------- damaged input

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


def read_dsg_payload(payload: PayloadLike, version: str | None = None) -> tuple[Any, str]:
    """Decode a DsgUpdate payload into a spark_dsg graph; return ``(graph, version)``.

    ``version`` pins one format version (no fallback). Undecodable payloads raise
    :class:`MessageDecodeError` listing every version tried and its error.
    """
    import spark_dsg

    data = _as_bytes(payload)
    native = installed_version()
    versions = [version.strip()] if version is not None else _candidate_versions(data)
    if version is not None:
        _parse_version(version)
    failures: list[str] = []
    for v in versions:
        try:
            if v == native:
                with _memory_budget(len(data)):
                    graph = spark_dsg.DynamicSceneGraph.from_binary(data)
            else:
                graph = _load_with_header(data, v)
        except (ValueError, RuntimeError, IndexError, TypeError, MemoryError) as exc:
            # MemoryError: std::bad_alloc when a damaged length field asks for gigabytes
            # (past the _memory_budget of the parse)
            why = _short(exc)
            if isinstance(exc, MemoryError) or "bad_alloc" in why:
                why = "asks for more memory than a payload of its size may take (a damaged length?)"
            failures.append(f"{v}: {why}")
            continue
        return graph, v
    raise MessageDecodeError(
        f"cannot decode scene-graph payload ({len(data)} bytes); versions tried: "
        + "; ".join(failures),
        hint="the payload may be truncated or from spark_dsg < 1.0.2; "
        "pin a version with --dsg-version if you know it",
    )


def _short(exc: Exception) -> str:
    """The first line of an error, whitespace runs collapsed, at most 120 characters."""
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return " ".join(text.split())[:120]


def decode_dsg(
    payload: PayloadLike, t_ns: int, version: str | None = None, layer: str | int | None = None
) -> DecodedGraph:
    """Decode a payload to a snapshot at ``t_ns`` and say which format version read it."""
    graph, used = read_dsg_payload(payload, version)
    try:
        nav = navigation(graph, t_ns, layer)
    except UnicodeDecodeError as exc:  # spark_dsg reads a damaged node name without checking
        raise MessageDecodeError(
            f"scene-graph payload ({len(_as_bytes(payload))} bytes) holds a node name that is "
            f"not UTF-8 ({exc.reason} at byte {exc.start})",
            hint="the payload is damaged",
        ) from exc
    return DecodedGraph(nav.snapshot, used, nav.layer)


def decode_dsg_update(
    payload: PayloadLike, t_ns: int, version: str | None = None, layer: str | int | None = None
) -> GraphSnapshot:
    """Decode a ``hydra_msgs/DsgUpdate.layer_contents`` payload into a :class:`GraphSnapshot`.

    Hydra always sends the whole graph (``full_update = true``), so each message is decoded on its
    own. Use :func:`decode_dsg` to also learn the payload version.
    """
    return decode_dsg(payload, t_ns, version, layer).snapshot


@dataclass(frozen=True)
class GraphFile:
    """A scene-graph file read into a spark_dsg graph, and how.

    ``reader`` is ``"spark_dsg"``, or ``"lenient"`` when spark_dsg refused the (JSON) file for
    ``refused`` and :mod:`formats.dsg_json` read it, skipping what ``skipped`` counts;
    ``rebuilt`` means only the attributes aion uses were read. ``version`` is the file's
    spark_dsg format version (``"1.1.3"``), None for a legacy JSON without a version header.
    """

    path: Path
    graph: Any
    reader: str = "spark_dsg"
    refused: str | None = None
    skipped: dict[str, int] = field(default_factory=dict)
    rebuilt: bool = False
    rebuild_reason: str | None = None
    mesh_dropped: bool = False
    version: str | None = None

    @property
    def format(self) -> str:
        """``"spark_dsg JSON 1.1.3"``, ``"spark_dsg JSON (legacy, no version header)"``..."""
        kind = "JSON" if self.path.suffix.lower() == ".json" else "binary"
        if self.version is None:
            return f"spark_dsg {kind} (legacy, no version header)"
        return f"spark_dsg {kind} {self.version}"

    def notes(self) -> list[str]:
        """What the user must be told: the lenient read and what it skipped."""
        if self.reader != "lenient":
            return []
        from aion_cli.formats.dsg_json import skipped_text

        text = (
            f"{self.path.name}: spark_dsg refused it ({self.refused}); read leniently: "
            f"{skipped_text(self.skipped)}"
        )
        if self.rebuilt:
            text += (
                f"; spark_dsg refused the repaired file too ({self.rebuild_reason}), so only "
                "positions, names, labels, place distances and agent stamps were read"
            )
            if self.mesh_dropped:
                text += " (the mesh was left out)"
        return [text]


@dataclass(frozen=True)
class LoadedGraph:
    """A scene-graph file and its navigational graph (what every command reads from a file)."""

    file: GraphFile
    nav: NavGraph

    @property
    def snapshot(self) -> GraphSnapshot:
        return self.nav.snapshot

    def notes(self) -> list[str]:
        return self.file.notes()


def _file_version(path: Path) -> str | None:
    """The spark_dsg version in the file's header (None: a legacy file without one).

    Binary files start with the 29-byte header of :func:`spark_header`; JSON files with a
    version header start with ``"SPARK_DSG_header"`` (spark_dsg sorts keys, upper case first).
    """
    with contextlib.suppress(OSError), path.open("rb") as fh:
        head = fh.read(512)
        if path.suffix.lower() != ".json":
            if len(head) >= 29 and head[:14] == spark_header("0.0.0")[:14]:
                return f"{head[24]}.{head[26]}.{head[28]}"
            return None
        m = re.search(
            rb'"SPARK_DSG_header"\s*:\s*\{.*?"major"\s*:\s*(\d+)\s*,\s*"minor"\s*:\s*(\d+)'
            rb'\s*,\s*"patch"\s*:\s*(\d+)',
            head,
            re.DOTALL,
        )
        if m:
            return ".".join(g.decode() for g in m.groups())
    return None


def read_dsg_file(path: str | Path) -> GraphFile:
    """Read a spark_dsg graph file (``.json``, ``.bson``, ``.sparkdsg``), with clear errors.

    A JSON file spark_dsg refuses is read leniently (:func:`formats.dsg_json.read_lenient`);
    a binary file spark_dsg refuses, or a file that is not a graph at all, is a
    :class:`GraphFileError`.
    """
    import spark_dsg

    p = Path(path)
    if not p.is_file():
        raise GraphFileError(f"scene-graph file not found: {p}", hint="check the path")
    suffix = p.suffix.lower()
    if suffix not in (".json", ".bson", ".sparkdsg"):
        raise GraphFileError(
            f"unsupported scene-graph file extension {p.suffix!r}: {p}",
            hint="Hydra saves graphs as dsg.json, dsg_with_mesh.json or .sparkdsg",
        )
    size = p.stat().st_size
    if size == 0:
        raise GraphFileError(f"scene-graph file is empty: {p}")
    if suffix == ".sparkdsg":
        _check_binary_file(p)
    version = _file_version(p)
    budget: int | None = None
    try:
        # legacy (header-less) JSON files warn on stdout
        with _native_output_silenced(), _memory_budget(size) as budget:
            return GraphFile(p, spark_dsg.DynamicSceneGraph.load(str(p)), version=version)
    except (RuntimeError, ValueError, IndexError, TypeError, MemoryError) as exc:
        if suffix != ".json":
            why = _short(exc)
            if isinstance(exc, MemoryError) or "bad_alloc" in why:
                limit = f" {budget / 1024**3:.1f} GiB" if budget else ""
                why = f"it asks for more than the{limit} of memory a graph of its size may take"
            raise GraphFileError(
                f"cannot read scene-graph file {p}: {why} (damaged?)",
                hint="expected a spark_dsg graph saved by Hydra (dsg.json / .sparkdsg)",
            ) from exc
        refused = _short(exc)
    from aion_cli.formats.dsg_json import read_lenient

    got = read_lenient(p)
    return GraphFile(
        p,
        got.graph,
        reader="lenient",
        refused=refused,
        skipped=got.skipped,
        rebuilt=got.rebuilt,
        rebuild_reason=got.rebuild_reason,
        mesh_dropped=got.mesh_dropped,
        version=version,
    )


def _check_binary_file(path: Path) -> None:
    """:class:`GraphFileError` for a ``.sparkdsg`` file whose bytes are no valid spark_dsg
    token stream (:func:`binary_problem`), before spark_dsg reads it."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise GraphFileError(f"cannot read scene-graph file {path}: {exc.strerror}") from exc
    problem = binary_problem(data)
    if problem is not None:
        raise GraphFileError(
            f"cannot read scene-graph file {path}: it is damaged: {problem}",
            hint="the file is truncated or corrupt; save the graph again from Hydra or spark_dsg",
        )


def load_dsg_file(path: str | Path) -> Any:
    """The spark_dsg graph of a file (:func:`read_dsg_file` without the reading report)."""
    return read_dsg_file(path).graph


def load_graph(
    path: str | Path, t_ns: int = 0, layer: str | int | None = None, clearance: bool = False
) -> LoadedGraph:
    """Read a Hydra graph file and its navigational graph, stamped ``t_ns`` (files carry no
    time). ``layer`` is ``--nav-layer`` (None: choose by name); ``clearance`` also collects
    each place's ``distance`` (the simulator's free space)."""
    file = read_dsg_file(path)
    try:
        nav = navigation(file.graph, t_ns, layer, clearance)
    except GraphLayerError as exc:
        raise GraphLayerError(f"{file.path.name}: {exc.message}", hint=exc.hint) from exc
    return LoadedGraph(file, nav)


def load_graph_file(
    path: str | Path, t_ns: int = 0, layer: str | int | None = None
) -> GraphSnapshot:
    """Read a Hydra graph file into a snapshot stamped ``t_ns`` (files carry no time)."""
    return load_graph(path, t_ns, layer).snapshot


# --------------------------------------------------------------------------- conversion


def _layer_view(G: Any, layer_id: int, partition: int = 0) -> Any | None:
    return G.get_layer(layer_id, partition) if G.has_layer(layer_id, partition) else None


def _named_key(G: Any, name: str, default: tuple[int, int]) -> tuple[int, int]:
    key = G.get_layer_key(name)
    return (int(key.layer), int(key.partition)) if key is not None else default


_KEY_RE = re.compile(r"^(\d+)(?:\[(\d+)\])?$")
_NAME_RE = re.compile(r"^[A-Z][A-Z0-9_]*$")


def parse_nav_layer(layer: str | int | None) -> tuple[int, int] | str | None:
    """The request behind ``--nav-layer``: None (choose by name), a layer key
    ``(layer, partition)`` (``"3[1]"``, ``"20"``, ``3``) or an upper-case layer name
    (``"mesh_places"`` -> ``"MESH_PLACES"``). Bad syntax is a :class:`GraphLayerError`."""
    if layer is None:
        return None
    if isinstance(layer, int) and not isinstance(layer, bool):
        text = str(layer)
    elif isinstance(layer, str):
        text = layer.strip().replace(" ", "")
    else:
        raise GraphLayerError(f"bad navigational layer {layer!r}", hint=NAV_LAYER_HINT)
    m = _KEY_RE.match(text)
    if m:
        key = (int(m.group(1)), int(m.group(2) or 0))
        if max(key) >= 2**32:
            raise GraphLayerError(f"navigational layer key {layer!r} is out of range")
        return key
    name = text.upper().replace("-", "_")
    if _NAME_RE.match(name):
        return name
    raise GraphLayerError(f"bad navigational layer {layer!r}", hint=NAV_LAYER_HINT)


def _graph_names(G: Any) -> dict[str, tuple[int, int]]:
    """The graph's own layer names (spark_dsg >= 1.1 graphs carry them)."""
    names = getattr(G, "layer_names", None) or {}
    return {str(n): (int(k.layer), int(k.partition)) for n, k in dict(names).items()}


def _name_of(G: Any, key: tuple[int, int]) -> tuple[str, bool]:
    """The name of a key (the graph's own first, MESH_PLACES / PLACES preferred) and whether it
    is the legacy MESH_PLACES layer 20."""
    names = _graph_names(G)
    named = [n for n, k in names.items() if k == key]
    for preferred in ("MESH_PLACES", "PLACES", "OBJECTS"):  # OBJECTS and AGENTS share layer 2
        if preferred in named:
            return preferred, False
    if named:
        return sorted(named)[0], False
    name = DEFAULT_LAYER_NAMES.get(key, "")
    if name in names:  # the graph gives this name to another key
        return "", False
    return name, key == (LEGACY_MESH_PLACES_LAYER, 0) and name == "MESH_PLACES"


def _nav(G: Any, key: tuple[int, int]) -> NavLayer:
    name, legacy = _name_of(G, key)
    return NavLayer(key[0], key[1], name, legacy)


def _has(G: Any, key: tuple[int, int]) -> bool:
    return bool(G.has_layer(key[0], key[1]))


def _mesh_place_keys(G: Any) -> list[tuple[int, int]]:
    """Where a graph may keep its 2D places: the key it names MESH_PLACES, ``3[1]`` and the
    legacy layer 20 (the defaults only when the graph does not name them otherwise)."""
    keys = []
    named = _graph_names(G).get("MESH_PLACES")
    if named is not None:
        keys.append(named)
    for key in ((PLACES_LAYER, MESH_PLACES_PARTITION), (LEGACY_MESH_PLACES_LAYER, 0)):
        if key not in keys and _name_of(G, key)[0] == "MESH_PLACES":
            keys.append(key)
    return keys


def graph_layers(G: Any) -> list[tuple[str, str, int]]:
    """Every layer and partition of a graph as ``(key, name, nodes)``, sorted by key."""
    views = list(G.layers) + list(G.layer_partitions)
    rows = {}
    for v in views:
        key = (int(v.id), int(v.partition))
        name = _name_of(G, key)[0]
        if not name and key[1] != 0 and key[0] == _named_key(G, "AGENTS", (AGENTS_LAYER, 0))[0]:
            name = "AGENTS"  # one partition per robot
        rows[key] = (NavLayer(*key).key, name, int(v.num_nodes()))
    return [rows[k] for k in sorted(rows)]


def layers_text(G: Any) -> str:
    """``"3 PLACES (437 nodes), 3[1] MESH_PLACES (96 nodes), ..."`` for messages."""
    return ", ".join(
        f"{key}{' ' + name if name else ''} ({n:,} node{'' if n == 1 else 's'})"
        for key, name, n in graph_layers(G)
    )


def _missing_layer(G: Any, what: str) -> GraphLayerError:
    return GraphLayerError(
        f"scene graph has no layer {what}; its layers: {layers_text(G) or 'none'}",
        hint=NAV_LAYER_HINT,
    )


def choose_nav_layer(G: Any, layer: str | int | None = None) -> NavLayer:
    """The navigational layer of graph ``G`` (see the module docstring for the rule).

    ``layer`` is ``--nav-layer``: None, a name or a key (:func:`parse_nav_layer`). A requested
    layer the graph does not have is a :class:`GraphLayerError` listing the graph's layers.
    """
    request = parse_nav_layer(layer)
    places = _named_key(G, "PLACES", (PLACES_LAYER, 0))
    if request is None:
        for key in _mesh_place_keys(G):
            if _has(G, key) and G.get_layer(*key).num_nodes() > 0:
                return _nav(G, key)
        return _nav(G, places)
    if isinstance(request, tuple):
        if not _has(G, request):
            raise _missing_layer(G, NavLayer(*request).key)
        return _nav(G, request)
    if request == "MESH_PLACES":
        keys = _mesh_place_keys(G)
        found = [k for k in keys if _has(G, k)]
        if not found:
            raise _missing_layer(
                G, "MESH_PLACES (" + " or ".join(NavLayer(*k).key for k in keys) + ")"
            )
        nonempty = [k for k in found if G.get_layer(*k).num_nodes() > 0]
        return _nav(G, (nonempty or found)[0])
    named = _graph_names(G).get(request)
    if named is None and request == "PLACES":
        named = places
    if named is None:
        default = [k for k, n in DEFAULT_LAYER_NAMES.items() if n == request]
        named = default[0] if default else None
    if named is None:
        raise _missing_layer(G, f"named {request}")
    if not _has(G, named):
        raise _missing_layer(G, f"{request} ({NavLayer(*named).key})")
    return NavLayer(named[0], named[1], request)


#: NodeSymbol layout (spark_dsg ``NodeSymbol``): the category character in the top byte of the
#: uint64, the index in the lower 56 bits.
_SYMBOL_INDEX_BITS = INDEX_BITS  # the one NodeSymbol layout (aion_cli.engine.node_ids)
_SYMBOL_INDEX_MASK = INDEX_MASK
_ID = operator.attrgetter("id.value")
_ATTRIBUTES = operator.attrgetter("attributes")
_POSITION = operator.attrgetter("position")
_NAME = operator.attrgetter("name")
_REAL_PLACE = operator.attrgetter("real_place")
_PARENT = operator.methodcaller("get_parent")
_SIBLINGS = operator.methodcaller("siblings")


def _symbol_strings(value: int) -> tuple[str, str]:
    """``(symbol.str(), str(symbol))`` of a NodeSymbol value, as spark_dsg prints them.

    spark_dsg (``NodeSymbol::str`` and ``operator<<``): a category that is a letter gives
    ``p12`` and ``p(12)``; any other category byte gives the index alone and the whole value.
    Computed arithmetically for ASCII categories (``isalpha`` of the C library is the ASCII
    letters there in every locale); spark_dsg is asked for the rest (bytes >= 128, where the
    C locale decides)."""
    category, index = value >> _SYMBOL_INDEX_BITS, value & _SYMBOL_INDEX_MASK
    if category >= 128:
        import spark_dsg

        symbol = spark_dsg.NodeSymbol(value)
        return symbol.str(), str(symbol)
    char = chr(category)
    if char.isascii() and char.isalpha():
        return f"{char}{index}", f"{char}({index})"
    return str(index), str(value)


def _labels(ids: npt.NDArray[np.uint64], names: list[Any]) -> tuple[str, ...]:
    """The label of every node of a layer — its semantic name when it has one, else the
    symbol's short form (``R0``); spark_dsg may fill ``name`` with the long form ``R(0)``,
    which is no name either — from the ids and the ``name`` attributes (``""`` where a node
    has none), without a spark_dsg call per node.

    A layer of one letter category (the usual case) is one comprehension over the indices;
    other layers go through :func:`_symbol_strings` node by node."""
    n = len(ids)
    if n == 0:
        return ()
    uniq = np.unique(ids >> np.uint64(_SYMBOL_INDEX_BITS))
    if len(uniq) == 1 and int(uniq[0]) < 128 and chr(int(uniq[0])).isalpha():
        char = chr(int(uniq[0]))
        index = list(map(str, (ids & np.uint64(_SYMBOL_INDEX_MASK)).tolist()))
        shorts = [char + i for i in index]
        if not any(names):
            return tuple(shorts)
        return tuple(
            name if (name and name != short and name != f"{char}({i})") else short
            for name, short, i in zip(names, shorts, index, strict=True)
        )
    out = []
    for value, name in zip(ids.tolist(), names, strict=True):
        short, long = _symbol_strings(value)
        out.append(name if (name and name != short and name != long) else short)
    return tuple(out)


def _all_have(attrs: list[Any], name: str) -> bool:
    """Whether every attributes object's *type* defines ``name`` (one check per distinct type,
    so one ``attrgetter`` pass may replace a ``getattr`` with a default per node)."""
    return all(hasattr(tp, name) for tp in set(map(type, attrs)))


@dataclass
class _LayerScan:
    """One pass over a layer's nodes: the layer and, per kept node, its in-layer neighbours
    (``siblings``, which hold the layer's edges seen from each end), the number of frontier
    nodes left out and (when asked) each kept node's ``distance``."""

    layer: Layer
    neighbours: list[set[int]]
    frontiers: int = 0
    clearance: npt.NDArray[np.float64] | None = None


def _scan(
    view: Any | None, skip_frontiers: bool = False, edges: bool = False, clearance: bool = False
) -> _LayerScan:
    """Collect ids, positions, parents, labels (and neighbour sets) of a layer in one pass.

    spark_dsg has no bulk accessors, so the cost is the number of binding calls: one per node
    and field (node, attributes, id, position, parent, name, ``real_place``, siblings), each
    made by ``map`` over ``operator`` getters (no Python frame per node); labels come from the
    ids arithmetically (:func:`_labels`), positions are copied into one array at once. Those
    ~9 binding calls per node are the floor: a 5,000-place layer takes ~16-17 ms of CPU (was
    ~17-20 ms with two more binding calls and a Python function per node, docs/BENCHMARKS.md).
    """
    none = np.zeros(0) if clearance else None
    if view is None:
        return _LayerScan(Layer.empty(), [], 0, none)
    nodes = list(view.nodes)
    attrs = list(map(_ATTRIBUTES, nodes))
    frontiers = 0
    if skip_frontiers and attrs:
        if _all_have(attrs, "real_place"):
            keep = list(map(_REAL_PLACE, attrs))
        else:
            keep = [getattr(a, "real_place", True) for a in attrs]
        if not all(keep):
            frontiers = len(keep) - sum(map(bool, keep))
            nodes = list(itertools.compress(nodes, keep))
            attrs = list(itertools.compress(attrs, keep))
    if not nodes:
        return _LayerScan(Layer.empty(), [], frontiers, none)
    n = len(nodes)
    ids = np.fromiter(map(_ID, nodes), dtype=np.uint64, count=n)
    xyz = np.concatenate(list(map(_POSITION, attrs))).astype(np.float64).reshape(-1, 3)
    parents = list(map(_PARENT, nodes))  # None without a parent
    parent = np.fromiter((0 if p is None else p for p in parents), dtype=np.uint64, count=n)
    if _all_have(attrs, "name"):
        names = list(map(_NAME, attrs))
    else:
        names = [getattr(a, "name", "") or "" for a in attrs]
    labels = _labels(ids, names)
    neighbours = list(map(_SIBLINGS, nodes)) if edges else []
    dist = None
    if clearance:
        dist = np.fromiter((float(getattr(a, "distance", 0.0)) for a in attrs), np.float64, n)
    return _LayerScan(Layer(ids, xyz, parent, labels), neighbours, frontiers, dist)


def _nodes(view: Any | None, skip_frontiers: bool = False) -> Layer:
    """Collect ids, positions, parents and labels of a layer in one pass."""
    return _scan(view, skip_frontiers).layer


def _keep_parents_in(layer: Layer, parents: Layer) -> Layer:
    """Parents outside the layer above (e.g. objects or missing nodes) become 0."""
    valid = np.isin(layer.parent, parents.ids)
    if valid.all():
        return layer
    return Layer(
        layer.ids, layer.xyz, np.where(valid, layer.parent, 0).astype(np.uint64), layer.labels
    )


def _edges(ids: npt.NDArray[np.uint64], neighbours: list[set[int]]) -> npt.NDArray[np.int64]:
    """Intralayer edges as unique sorted row-index pairs from each node's neighbour set (every
    edge appears from both ends); edges to dropped nodes are left out. Ids map to rows with
    ``searchsorted`` over the sorted ids."""
    if len(ids) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    counts = np.fromiter(map(len, neighbours), dtype=np.int64, count=len(neighbours))
    other = np.fromiter(
        itertools.chain.from_iterable(neighbours), dtype=np.uint64, count=int(counts.sum())
    )
    src = np.repeat(np.arange(len(ids), dtype=np.int64), counts)
    order = np.argsort(ids)
    sorted_ids = ids[order]
    pos = np.searchsorted(sorted_ids, other).clip(0, len(ids) - 1)
    found = sorted_ids[pos] == other
    dst = order[pos[found]].astype(np.int64)
    src = src[found]
    lo, hi = np.minimum(src, dst), np.maximum(src, dst)
    keep = lo != hi
    key = np.unique(lo[keep] * len(ids) + hi[keep])
    return np.column_stack([key // len(ids), key % len(ids)]).astype(np.int64).reshape(-1, 2)


def _mesh(G: Any) -> Mesh | None:
    if not G.has_mesh():
        return None
    m = G.mesh
    if m is None or m.num_vertices() == 0:
        return None
    vertices = np.asarray(m.get_vertices(), dtype=np.float64)
    faces = np.asarray(m.get_faces(), dtype=np.int32).reshape(3, -1)
    colors = vertices[3:6].T if vertices.shape[0] >= 6 else np.zeros((0, 3))
    return Mesh(
        np.ascontiguousarray(vertices[:3].T),
        np.ascontiguousarray(faces.T),
        np.ascontiguousarray(colors),
    )


def _timedelta_ns(td: datetime.timedelta) -> int:
    """Exact integer ns of a timedelta (spark_dsg gives agent stamps as timedelta)."""
    return ((td.days * 86_400 + td.seconds) * 1_000_000 + td.microseconds) * 1000


def _agents(G: Any) -> Trajectory | None:
    """The first robot's agent partition (lowest partition id, robot 'a') as a trajectory."""
    agents_layer = _named_key(G, "AGENTS", (AGENTS_LAYER, 0))[0]
    views = sorted(
        (v for v in G.layer_partitions if v.id == agents_layer and v.partition != 0),
        key=lambda v: int(v.partition),
    )
    views = [v for v in views if v.num_nodes() > 0]
    if not views:
        return None
    attrs = [node.attributes for node in views[0].nodes]
    stamps = [a.timestamp for a in attrs]
    us = None
    if all(type(st) is datetime.timedelta for st in stamps):
        # timedelta has microsecond resolution: timedelta64[us] holds it exactly
        us = np.array(stamps, dtype="timedelta64[us]").astype(np.int64)
    lim = np.iinfo(np.int64).max // 1000
    if us is not None and (len(us) == 0 or (-lim <= us.min() and us.max() <= lim)):
        t_arr = us * 1000
    else:  # other stamp types, or ns outside int64 (raises like a Python int would)
        t_arr = np.array(
            [_timedelta_ns(st) if isinstance(st, datetime.timedelta) else int(st) for st in stamps],
            dtype=np.int64,
        )
    xyz = np.concatenate([a.position for a in attrs]).astype(np.float64).reshape(-1, 3)
    order = np.argsort(t_arr, kind="stable")
    return Trajectory(t_arr[order], xyz[order])


def navigation(
    G: Any, t_ns: int, layer: str | int | None = None, clearance: bool = False
) -> NavGraph:
    """The navigational graph of a spark_dsg ``DynamicSceneGraph`` (a saved file or a decoded
    DsgUpdate payload alike) and the layer it came from.

    ``layer``: ``--nav-layer`` (None: MESH_PLACES when present and non-empty, else PLACES; see
    :func:`choose_nav_layer`). Frontier places (``real_place == False``) are left out; edges to
    them too. Parents are kept only when they are in the layer above.
    """
    nav = choose_nav_layer(G, layer)
    view = _layer_view(G, nav.layer, nav.partition)
    buildings = _nodes(_layer_view(G, *_named_key(G, "BUILDINGS", (BUILDINGS_LAYER, 0))))
    rooms = _keep_parents_in(
        _nodes(_layer_view(G, *_named_key(G, "ROOMS", (ROOMS_LAYER, 0)))), buildings
    )
    scan = _scan(view, skip_frontiers=True, edges=True, clearance=clearance)
    places = _keep_parents_in(scan.layer, rooms)
    snapshot = GraphSnapshot(
        t_ns=int(t_ns),
        places=places,
        edges=_edges(places.ids, scan.neighbours),
        rooms=rooms,
        buildings=buildings,
        mesh=_mesh(G),
        agents=_agents(G),
        layer_name=nav.snapshot_name,
    )
    return NavGraph(snapshot, nav, scan.frontiers, scan.clearance)


def snapshot_from_dsg(G: Any, t_ns: int, layer: str | int | None = None) -> GraphSnapshot:
    """The navigational :class:`GraphSnapshot` of a spark_dsg graph (:func:`navigation`)."""
    return navigation(G, t_ns, layer).snapshot
