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
- :func:`load_graph_file` reads Hydra's saved files (``dsg.json``, ``dsg_with_mesh.json``,
  ``.sparkdsg``, legacy header-less JSON).
- :func:`snapshot_from_dsg` converts an in-memory spark_dsg graph.

spark_dsg is imported inside the functions (heavy import, see docs/CONTRACTS.md).
"""

from __future__ import annotations

import contextlib
import ctypes
import datetime
import functools
import itertools
import os
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.errors import InputError, MessageDecodeError
from aion_cli.engine.types import GraphSnapshot, Layer, Mesh, Trajectory

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

PayloadLike = bytes | bytearray | memoryview | npt.NDArray[np.uint8]


class GraphFileError(InputError):
    """A scene-graph file is missing, unreadable or not a spark_dsg graph."""


class GraphLayerError(InputError):
    """The requested navigational layer is not in the scene graph."""


@dataclass(frozen=True)
class DecodedGraph:
    """A decoded payload and the spark_dsg format version that read it.

    ``version`` is ``"X.Y.Z"``; the installed spark_dsg's own version means ``from_binary``
    read the payload directly, any other value means the versioned-header fallback did.
    """

    snapshot: GraphSnapshot
    version: str


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
        with _native_output_silenced():
            return spark_dsg.DynamicSceneGraph.load(name)
    finally:
        os.unlink(name)


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
                graph = spark_dsg.DynamicSceneGraph.from_binary(data)
            else:
                graph = _load_with_header(data, v)
        except (ValueError, RuntimeError, IndexError, TypeError, MemoryError) as exc:
            # MemoryError: std::bad_alloc when a damaged length field asks for gigabytes
            failures.append(f"{v}: {_short(exc)}")
            continue
        return graph, v
    raise MessageDecodeError(
        f"cannot decode scene-graph payload ({len(data)} bytes); versions tried: "
        + "; ".join(failures),
        hint="the payload may be truncated or from spark_dsg < 1.0.2; "
        "pin a version with --dsg-version if you know it",
    )


def _short(exc: Exception) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return text[:120]


def decode_dsg(
    payload: PayloadLike, t_ns: int, version: str | None = None, layer: str | int | None = None
) -> DecodedGraph:
    """Decode a payload to a snapshot at ``t_ns`` and say which format version read it."""
    graph, used = read_dsg_payload(payload, version)
    try:
        snapshot = snapshot_from_dsg(graph, t_ns, layer)
    except UnicodeDecodeError as exc:  # spark_dsg reads a damaged node name without checking
        raise MessageDecodeError(
            f"scene-graph payload ({len(_as_bytes(payload))} bytes) holds a node name that is "
            f"not UTF-8 ({exc.reason} at byte {exc.start})",
            hint="the payload is damaged",
        ) from exc
    return DecodedGraph(snapshot, used)


def decode_dsg_update(
    payload: PayloadLike, t_ns: int, version: str | None = None, layer: str | int | None = None
) -> GraphSnapshot:
    """Decode a ``hydra_msgs/DsgUpdate.layer_contents`` payload into a :class:`GraphSnapshot`.

    Hydra always sends the whole graph (``full_update = true``), so each message is decoded on its
    own. Use :func:`decode_dsg` to also learn the payload version.
    """
    return decode_dsg(payload, t_ns, version, layer).snapshot


def load_dsg_file(path: str | Path) -> Any:
    """Load a spark_dsg graph file (``.json``, ``.bson``, ``.sparkdsg``), with clear errors."""
    import spark_dsg

    p = Path(path)
    if not p.is_file():
        raise GraphFileError(f"scene-graph file not found: {p}", hint="check the --graph path")
    suffix = p.suffix.lower()
    if suffix not in (".json", ".bson", ".sparkdsg"):
        raise GraphFileError(
            f"unsupported scene-graph file extension {p.suffix!r}: {p}",
            hint="Hydra saves graphs as dsg.json, dsg_with_mesh.json or .sparkdsg",
        )
    if p.stat().st_size == 0:
        raise GraphFileError(f"scene-graph file is empty: {p}")
    try:
        with _native_output_silenced():  # legacy (header-less) JSON files warn on stdout
            return spark_dsg.DynamicSceneGraph.load(str(p))
    except (RuntimeError, ValueError, IndexError, TypeError) as exc:
        raise GraphFileError(
            f"cannot read scene-graph file {p}: {_short(exc)}",
            hint="expected a spark_dsg graph saved by Hydra (dsg.json / .sparkdsg)",
        ) from exc


def load_graph_file(
    path: str | Path, t_ns: int = 0, layer: str | int | None = None
) -> GraphSnapshot:
    """Read a Hydra graph file into a snapshot stamped ``t_ns`` (files carry no time)."""
    return snapshot_from_dsg(load_dsg_file(path), t_ns, layer)


# --------------------------------------------------------------------------- conversion


def _layer_view(G: Any, layer_id: int, partition: int = 0) -> Any | None:
    return G.get_layer(layer_id, partition) if G.has_layer(layer_id, partition) else None


def _named_key(G: Any, name: str, default: tuple[int, int]) -> tuple[int, int]:
    key = G.get_layer_key(name)
    return (int(key.layer), int(key.partition)) if key is not None else default


def _choose_places(G: Any, layer: str | int | None) -> tuple[Any | None, str]:
    """Pick the navigational layer: 2D (mesh) places when present and non-empty, else places."""
    places_key = _named_key(G, "PLACES", (PLACES_LAYER, 0))
    mesh_key = _named_key(G, "MESH_PLACES", (PLACES_LAYER, MESH_PLACES_PARTITION))
    if layer is None:
        mesh = _layer_view(G, *mesh_key)
        if mesh is not None and mesh.num_nodes() > 0:
            return mesh, "mesh_places"
        return _layer_view(G, *places_key), "places"
    if isinstance(layer, str) and layer.lower() in ("places", "mesh_places"):
        key = places_key if layer.lower() == "places" else mesh_key
        name = layer.lower()
    elif isinstance(layer, int) or (isinstance(layer, str) and layer.strip().isdigit()):
        key, name = (int(layer), 0), f"layer_{int(layer)}"
    else:
        raise GraphLayerError(
            f"unknown scene-graph layer {layer!r}", hint="use places, mesh_places or a layer id"
        )
    view = _layer_view(G, *key)
    if view is None:
        known = ", ".join(str(k) for k in G.layer_keys)
        raise GraphLayerError(
            f"scene graph has no layer {layer!r} (key {key[0]}[{key[1]}]); layers: {known}"
        )
    return view, name


def _label(symbol: Any, attrs: Any) -> str:
    """A semantic name when the node has one, else the symbol (``R0``).

    spark_dsg fills ``name`` with ``str(symbol)`` (``R(0)``) by default, which is not a name.
    """
    short = symbol.str()
    name = getattr(attrs, "name", "") or ""
    return short if (not name or name == short or name == str(symbol)) else name


@dataclass
class _LayerScan:
    """One pass over a layer's nodes: the layer and, per kept node, its in-layer neighbours
    (``siblings``, which hold the layer's edges seen from each end)."""

    layer: Layer
    neighbours: list[set[int]]


def _scan(view: Any | None, skip_frontiers: bool = False, edges: bool = False) -> _LayerScan:
    """Collect ids, positions, parents, labels (and neighbour sets) of a layer in one pass.

    Each node's attributes object is fetched once; positions (views into graph memory) are
    copied into one array right away.
    """
    if view is None:
        return _LayerScan(Layer.empty(), [])
    nodes = list(view.nodes)
    attrs = [node.attributes for node in nodes]
    if skip_frontiers:
        keep = [getattr(a, "real_place", True) for a in attrs]
        if not all(keep):
            nodes = [n for n, k in zip(nodes, keep, strict=True) if k]
            attrs = [a for a, k in zip(attrs, keep, strict=True) if k]
    if not nodes:
        return _LayerScan(Layer.empty(), [])
    n = len(nodes)
    symbols = [node.id for node in nodes]
    ids = np.fromiter((s.value for s in symbols), dtype=np.uint64, count=n)
    xyz = np.concatenate([a.position for a in attrs]).astype(np.float64).reshape(-1, 3)
    parents = [node.get_parent() for node in nodes]  # None without a parent
    parent = np.fromiter((0 if p is None else p for p in parents), dtype=np.uint64, count=n)
    labels = tuple(map(_label, symbols, attrs))
    neighbours = [node.siblings() for node in nodes] if edges else []
    return _LayerScan(Layer(ids, xyz, parent, labels), neighbours)


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


def snapshot_from_dsg(G: Any, t_ns: int, layer: str | int | None = None) -> GraphSnapshot:
    """Convert a spark_dsg ``DynamicSceneGraph`` into the navigational :class:`GraphSnapshot`.

    ``layer``: ``None`` (mesh places when present and non-empty, else places), ``"places"``,
    ``"mesh_places"`` or an integer layer id. Frontier places (``real_place == False``) are left
    out; edges to them too. Parents are kept only when they are in the layer above.
    """
    view, name = _choose_places(G, layer)
    buildings = _nodes(_layer_view(G, *_named_key(G, "BUILDINGS", (BUILDINGS_LAYER, 0))))
    rooms = _keep_parents_in(
        _nodes(_layer_view(G, *_named_key(G, "ROOMS", (ROOMS_LAYER, 0)))), buildings
    )
    scan = _scan(view, skip_frontiers=True, edges=True)
    places = _keep_parents_in(scan.layer, rooms)
    return GraphSnapshot(
        t_ns=int(t_ns),
        places=places,
        edges=_edges(places.ids, scan.neighbours),
        rooms=rooms,
        buildings=buildings,
        mesh=_mesh(G),
        agents=_agents(G),
        layer_name=name,
    )
