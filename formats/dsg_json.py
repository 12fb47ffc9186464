"""Lenient reading of spark_dsg JSON graph files that spark_dsg itself refuses.

spark_dsg loads a JSON graph all or nothing: one edge to a node that is not in the file
(``failed to add O(23) →  p(8928)``), a node or an edge given twice, a self-loop, and the whole
file is refused. Real files have such defects: ``apartment_igx_dsg.json`` (Hydra, legacy
header-less JSON) has six edges from objects to places that are not in the file.
:func:`read_lenient` parses the JSON itself, skips and counts every invalid item, and loads what
remains:

1. the repaired document through spark_dsg (every attribute, and the mesh, read exactly as
   spark_dsg reads them);
2. if spark_dsg refuses even that (an attribute it cannot parse, say), a graph built node by node
   from what aion uses: layer and partition, id, position, name, semantic label, a place's
   free-space ``distance`` and ``real_place`` flag, an agent's timestamp. Nodes and edges that
   spark_dsg still rejects are counted; the mesh is left out.

Only a file that is not JSON, not a graph document, or has no readable node is an error
(:class:`formats.dsg.GraphFileError`). The counts are reported to the user, never dropped
silently.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

#: What can be skipped, in the order it is reported: key -> (singular, plural).
SKIP_LABELS: dict[str, tuple[str, str]] = {
    "malformed_nodes": ("malformed node", "malformed nodes"),
    "nodes_without_position": ("node without a position", "nodes without a position"),
    "duplicate_nodes": ("duplicate node", "duplicate nodes"),
    "rejected_nodes": ("node spark_dsg rejected", "nodes spark_dsg rejected"),
    "malformed_edges": ("malformed edge", "malformed edges"),
    "dangling_edges": ("dangling edge", "dangling edges"),
    "edges_of_skipped_nodes": ("edge of a skipped node", "edges of skipped nodes"),
    "self_loops": ("self-loop edge", "self-loop edges"),
    "duplicate_edges": ("duplicate edge", "duplicate edges"),
    "rejected_edges": ("edge spark_dsg rejected", "edges spark_dsg rejected"),
}

_U64_MAX = 2**64 - 1
_U32_MAX = 2**32 - 1


@dataclass
class LenientGraph:
    """A graph read leniently and what was skipped to read it.

    ``rebuilt`` says the graph was built node by node (step 2 of the module docstring) because
    spark_dsg refused the repaired document too, for ``rebuild_reason``; then only the
    attributes aion uses were read and the mesh (``mesh_dropped``) was left out.
    """

    graph: Any
    skipped: dict[str, int] = field(default_factory=dict)
    rebuilt: bool = False
    rebuild_reason: str | None = None
    mesh_dropped: bool = False


def skipped_text(skipped: dict[str, int]) -> str:
    """``"6 dangling edges and 1 duplicate node skipped"`` (``"nothing skipped"`` when empty)."""
    parts = [
        f"{n:,} {SKIP_LABELS[k][0] if n == 1 else SKIP_LABELS[k][1]}"
        for k in SKIP_LABELS
        if (n := skipped.get(k, 0))
    ]
    if not parts:
        return "nothing skipped"
    text = parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
    return text + " skipped"


def _is_int(value: Any, lo: int = 0, hi: int = _U64_MAX) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and lo <= value <= hi


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _position(attrs: Any) -> list[float] | None:
    """The node's position as three finite numbers, else None."""
    pos = attrs.get("position") if isinstance(attrs, dict) else None
    if not isinstance(pos, list) or len(pos) != 3 or not all(map(_is_number, pos)):
        return None
    return [float(v) for v in pos]


def parse_document(path: Path) -> dict[str, Any]:
    """The file's JSON document; :class:`GraphFileError` when it is not a graph document."""
    from aion_cli.formats.dsg import GraphFileError

    hint = "expected a spark_dsg graph saved by Hydra (dsg.json / .sparkdsg)"
    try:
        text = path.read_bytes().decode("utf-8")
        doc = json.loads(text)
    except UnicodeDecodeError as exc:
        raise GraphFileError(
            f"cannot read scene-graph file {path}: not JSON text (byte {exc.start} is not UTF-8)",
            hint=hint,
        ) from exc
    except json.JSONDecodeError as exc:
        raise GraphFileError(
            f"cannot read scene-graph file {path}: not valid JSON ({_json_error(exc)})",
            hint="the file is truncated or damaged; " + hint,
        ) from exc
    except (RecursionError, MemoryError) as exc:
        raise GraphFileError(
            f"cannot read scene-graph file {path}: JSON too deeply nested or too large",
            hint=hint,
        ) from exc
    except OSError as exc:
        raise GraphFileError(f"cannot read scene-graph file {path}: {exc.strerror}") from exc
    if not isinstance(doc, dict) or not isinstance(doc.get("nodes"), list):
        raise GraphFileError(
            f"cannot read scene-graph file {path}: a JSON document without a 'nodes' list is "
            "not a spark_dsg graph",
            hint=hint,
        )
    if "edges" in doc and not isinstance(doc["edges"], list):
        raise GraphFileError(
            f"cannot read scene-graph file {path}: its 'edges' is not a list", hint=hint
        )
    return doc


def clean_items(doc: dict[str, Any]) -> tuple[list[Any], list[Any], dict[str, int]]:
    """The valid nodes and edges of ``doc`` (the original JSON objects) and the skip counts.

    A node needs an integer ``id`` (a NodeSymbol value) and ``layer`` and a position of three
    finite numbers; the first of several nodes with one id is kept. An edge needs integer
    ``source`` and ``target`` that are kept nodes, two different ones, and an unordered pair not
    seen before (spark_dsg graphs are undirected).
    """
    skipped = dict.fromkeys(SKIP_LABELS, 0)
    nodes: list[Any] = []
    kept: set[int] = set()
    present: set[int] = set()  # every well-formed node id in the file, kept or not
    for node in doc["nodes"]:
        if not (
            isinstance(node, dict)
            and _is_int(node.get("id"))
            and _is_int(node.get("layer"), 0, _U32_MAX)
            and _is_int(node.get("partition", 0), 0, _U32_MAX)
        ):
            skipped["malformed_nodes"] += 1
            continue
        nid = int(node["id"])
        present.add(nid)
        if _position(node.get("attributes")) is None:
            skipped["nodes_without_position"] += 1
        elif nid in kept:
            skipped["duplicate_nodes"] += 1
        else:
            kept.add(nid)
            nodes.append(node)
    edges: list[Any] = []
    pairs: set[tuple[int, int]] = set()
    for edge in doc.get("edges", []):
        if not (
            isinstance(edge, dict) and _is_int(edge.get("source")) and _is_int(edge.get("target"))
        ):
            skipped["malformed_edges"] += 1
            continue
        s, t = int(edge["source"]), int(edge["target"])
        if s not in kept or t not in kept:
            reason = "edges_of_skipped_nodes" if s in present and t in present else "dangling_edges"
            skipped[reason] += 1
        elif s == t:
            skipped["self_loops"] += 1
        elif (pair := (min(s, t), max(s, t))) in pairs:
            skipped["duplicate_edges"] += 1
        else:
            pairs.add(pair)
            edges.append(edge)
    return nodes, edges, skipped


def read_lenient(path: Path) -> LenientGraph:
    """Read the JSON graph file ``path`` leniently (see the module docstring)."""
    from aion_cli.formats.dsg import GraphFileError

    doc = parse_document(path)
    nodes, edges, skipped = clean_items(doc)
    if not nodes:
        reasons = {k: v for k, v in skipped.items() if v and k.endswith("nodes")}
        what = skipped_text(reasons).removesuffix(" skipped") if reasons else "no node at all"
        raise GraphFileError(
            f"cannot read scene-graph file {path}: no node can be read ({what})",
            hint="expected a spark_dsg graph saved by Hydra (dsg.json / .sparkdsg)",
        )
    repaired = {**doc, "nodes": nodes, "edges": edges}
    try:
        graph = _load_document(repaired)
    except (RuntimeError, ValueError, IndexError, TypeError) as exc:
        from aion_cli.formats.dsg import _short

        result = _rebuild(path, doc, nodes, edges, skipped)
        result.rebuild_reason = _short(exc)
        return result
    if stamps_beside_attributes(_header_version(doc)):
        restore_agent_stamps(graph, repaired)
    return LenientGraph(graph, {k: v for k, v in skipped.items() if v})


def _header_version(doc: dict[str, Any]) -> str | None:
    """``"1.1.3"`` from the document's ``SPARK_DSG_header`` (None without a valid one)."""
    header = doc.get("SPARK_DSG_header")
    version = header.get("version") if isinstance(header, dict) else None
    if not isinstance(version, dict):
        return None
    parts = [version.get(k) for k in ("major", "minor", "patch")]
    return ".".join(map(str, parts)) if all(_is_int(v) for v in parts) else None


def _load_document(doc: dict[str, Any]) -> Any:
    """spark_dsg's own reading of a JSON document (through a temporary file: spark_dsg's Python
    API loads graphs from paths only)."""
    import spark_dsg

    from aion_cli.formats.dsg import _native_output_silenced

    try:
        text = json.dumps(doc, allow_nan=False)
    except ValueError as exc:  # a NaN attribute: spark_dsg's JSON parser refuses it
        raise ValueError("a number in the file is not finite (NaN or Infinity)") from exc
    fd, name = tempfile.mkstemp(suffix=".json", prefix="aion-dsg-")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        with _native_output_silenced():  # legacy JSON makes spark_dsg warn on stdout
            return spark_dsg.DynamicSceneGraph.load(name)
    finally:
        os.unlink(name)


def _layer_keys(doc: dict[str, Any]) -> tuple[list[Any], dict[str, Any]] | None:
    """The document's own layer keys and names (spark_dsg >= 1.1 files), else None."""
    import spark_dsg

    names = doc.get("layer_names")
    if not isinstance(names, dict) or not names:
        return None
    keys: dict[tuple[int, int], Any] = {}
    named: dict[str, Any] = {}
    entries = list(names.items()) + [("", k) for k in doc.get("layer_keys") or []]
    for name, key in entries:
        if not (
            isinstance(key, dict)
            and _is_int(key.get("layer"), 0, _U32_MAX)
            and _is_int(key.get("partition", 0), 0, _U32_MAX)
        ):
            return None
        pair = (int(key["layer"]), int(key.get("partition", 0)))
        keys.setdefault(pair, spark_dsg.LayerKey(*pair))
        if name:
            named[str(name)] = keys[pair]
    return [keys[k] for k in sorted(keys)], named


def _rebuild(
    path: Path, doc: dict[str, Any], nodes: list[Any], edges: list[Any], skipped: dict[str, int]
) -> LenientGraph:
    """A graph built node by node from the attributes aion uses (step 2)."""
    import spark_dsg

    from aion_cli.formats.dsg import _native_output_silenced

    layout = _layer_keys(doc)
    graph = spark_dsg.DynamicSceneGraph(*layout) if layout else spark_dsg.DynamicSceneGraph()
    with _native_output_silenced():  # spark_dsg logs every rejected item on stdout
        for node in nodes:
            if not _add_node(spark_dsg, graph, node):
                skipped["rejected_nodes"] += 1
        for edge in edges:
            if not _add_edge(spark_dsg, graph, edge):
                skipped["rejected_edges"] += 1
    if graph.num_nodes() == 0:
        from aion_cli.formats.dsg import GraphFileError

        raise GraphFileError(
            f"cannot read scene-graph file {path}: spark_dsg rejected every node",
            hint="expected a spark_dsg graph saved by Hydra (dsg.json / .sparkdsg)",
        )
    return LenientGraph(
        graph,
        {k: v for k, v in skipped.items() if v},
        rebuilt=True,
        mesh_dropped=bool(doc.get("mesh")),
    )


def _attributes(spark_dsg: Any, node: dict[str, Any]) -> Any:
    """spark_dsg attributes of the node's ``type`` with the fields aion reads."""
    raw = node["attributes"]
    kind = raw.get("type")
    classes = {
        "PlaceNodeAttributes": spark_dsg.PlaceNodeAttributes,
        "Place2dNodeAttributes": spark_dsg.Place2dNodeAttributes,
        "RoomNodeAttributes": spark_dsg.RoomNodeAttributes,
        "ObjectNodeAttributes": spark_dsg.ObjectNodeAttributes,
        "AgentNodeAttributes": spark_dsg.AgentNodeAttributes,
    }
    attrs = classes.get(kind, spark_dsg.SemanticNodeAttributes)()
    attrs.position = np.asarray(_position(raw), dtype=np.float64)
    if isinstance(raw.get("name"), str) and hasattr(attrs, "name"):
        attrs.name = raw["name"]
    if _is_int(raw.get("semantic_label"), 0, _U32_MAX) and hasattr(attrs, "semantic_label"):
        attrs.semantic_label = raw["semantic_label"]
    if _is_int(raw.get("last_update_time_ns"), 0, 2**63 - 1):
        attrs.last_update_time_ns = raw["last_update_time_ns"]
    if kind == "PlaceNodeAttributes":
        if _is_number(raw.get("distance")):
            attrs.distance = float(raw["distance"])
        if isinstance(raw.get("real_place"), bool):
            attrs.real_place = raw["real_place"]
    if kind == "AgentNodeAttributes":
        stamp = _agent_stamp(node.get("timestamp", raw.get("timestamp")))
        if stamp is not None:  # legacy files keep it beside "attributes"
            attrs.timestamp = stamp
    return attrs


def _agent_stamp(stamp: Any) -> datetime.timedelta | None:
    """An agent's stamp (integer ns in the file) as spark_dsg's Python API holds it: a
    ``timedelta``, which keeps whole microseconds (spark_dsg gives stamps read from any file or
    payload so, and the numpy payload reader truncates alike); None if not a valid stamp."""
    if not _is_int(stamp, 0, 2**63 - 1):
        return None
    return datetime.timedelta(microseconds=stamp // 1000)


def stamps_beside_attributes(version: str | None) -> bool:
    """Whether a JSON file of spark_dsg format ``version`` (None: legacy, no version header)
    keeps agent stamps beside a node's attributes, as spark_dsg wrote them before 1.1.0."""
    if version is None:
        return True
    try:
        return tuple(int(v) for v in version.split(".")) < (1, 1, 0)
    except ValueError:
        return False


def restore_agent_stamps(graph: Any, doc: dict[str, Any]) -> int:
    """Give the agent nodes of ``graph`` (read by spark_dsg from ``doc``) the stamps ``doc``
    keeps beside their attributes; the number of nodes given one.

    Files written before spark_dsg 1.1.0 (every legacy file without a version header, such as
    Hydra's ``dsg.json`` of that time) keep an agent's ``timestamp`` in the node record, beside
    ``attributes``. spark_dsg 1.1.x reads that key only to put the node into its robot's
    partition and leaves every agent stamp 0, so the robot trajectory of such a file was read
    with all its poses at time 0 (``apartment_dsg.json``: 102 poses over 3.6-28.4 s)."""
    restored = 0
    for node in doc.get("nodes", []):
        if not (isinstance(node, dict) and "timestamp" in node and _is_int(node.get("id"))):
            continue
        stamp = _agent_stamp(node["timestamp"])
        found = graph.find_node(int(node["id"])) if stamp is not None else None
        if found is None or not hasattr(found.attributes, "timestamp"):
            continue
        found.attributes.timestamp = stamp
        restored += 1
    return restored


def _add_node(spark_dsg: Any, graph: Any, node: dict[str, Any]) -> bool:
    partition = int(node["partition"]) if "partition" in node else 0  # checked by clean_items
    if "partition" not in node and _is_int(node.get("prefix"), 0, _U32_MAX):
        partition = int(node["prefix"])  # legacy files: an agent's partition is its prefix
    try:
        attrs = _attributes(spark_dsg, node)
        return bool(graph.add_node(int(node["layer"]), int(node["id"]), attrs, int(partition)))
    except (RuntimeError, ValueError, TypeError, OverflowError):
        return False


def _add_edge(spark_dsg: Any, graph: Any, edge: dict[str, Any]) -> bool:
    info = spark_dsg.EdgeAttributes()
    raw = edge.get("info")
    if isinstance(raw, dict) and _is_number(raw.get("weight")):
        with contextlib.suppress(TypeError, ValueError):
            info.weight = float(raw["weight"])
            info.weighted = bool(raw.get("weighted", True))
    try:
        return bool(graph.insert_edge(int(edge["source"]), int(edge["target"]), info))
    except (RuntimeError, ValueError, TypeError, OverflowError):
        return False


def _json_error(exc: json.JSONDecodeError) -> str:
    """``"Unterminated string starting at line 1 column 5"``: json's messages that end in
    "at" (which it follows with ": line ...") take no second "at"."""
    msg = exc.msg if exc.msg.endswith(" at") else f"{exc.msg} at"
    return f"{msg} line {exc.lineno} column {exc.colno}"
