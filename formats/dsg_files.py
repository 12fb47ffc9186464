"""Hydra's saved scene-graph files (``dsg.json``, ``.sparkdsg``...) -> spark_dsg graphs.

:func:`read_dsg_file` checks the path, walks a binary file first (:mod:`formats.dsg_guard`),
lets spark_dsg load it under the memory budget and falls back to the lenient JSON reader
(:mod:`formats.dsg_json`); :func:`load_graph` adds the navigational graph. Files differ from
DsgUpdate payloads (:mod:`formats.dsg_payload`) in carrying their version and in how they fail,
so they have a module of their own.
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aion_cli.engine.types import GraphSnapshot
from aion_cli.errors import InputError
from aion_cli.formats.dsg_guard import _memory_budget, binary_problem
from aion_cli.formats.dsg_layers import GraphLayerError
from aion_cli.formats.dsg_payload import _native_output_silenced, _short, spark_header
from aion_cli.formats.dsg_scan import NavGraph, navigation


class GraphFileError(InputError):
    """A scene-graph file is missing, unreadable or not a spark_dsg graph."""


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
    #: the suffix the file was read as, by its content (``.json`` for JSON text named
    #: ``.sparkdsg``); empty: its own
    read_as: str = ""

    @property
    def kind(self) -> str:
        """``"JSON"`` or ``"binary"``: what the file holds, whatever its name says."""
        return "JSON" if (self.read_as or self.path.suffix.lower()) == ".json" else "binary"

    @property
    def format(self) -> str:
        """``"spark_dsg JSON 1.1.3"``, ``"spark_dsg JSON (legacy, no version header)"``..."""
        if self.version is None:
            return f"spark_dsg {self.kind} (legacy, no version header)"
        return f"spark_dsg {self.kind} {self.version}"

    def notes(self) -> list[str]:
        """What the user must be told: a name that says another format than the file holds
        (``.bson`` holding JSON does not: spark_dsg saves it so), the lenient read and what
        it skipped."""
        named = []
        own = self.path.suffix.lower()
        if self.read_as and self.read_as != own and (own, self.read_as) != (".bson", ".json"):
            named.append(
                f"{self.path.name} holds a {self.kind} graph: read as a {self.read_as} file "
                "(spark_dsg reads a graph by its suffix)"
            )
        if self.reader != "lenient":
            return named
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
        return [*named, text]


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


def _file_version(path: Path, suffix: str) -> str | None:
    """The spark_dsg version in the file's header (None: a legacy file without one).

    Binary files start with the 29-byte header of :func:`spark_header`; JSON files with a
    version header start with ``"SPARK_DSG_header"`` (spark_dsg sorts keys, upper case first).
    """
    with contextlib.suppress(OSError), path.open("rb") as fh:
        head = fh.read(512)
        if suffix != ".json":
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


def check_graph_path(p: Path, error: type[InputError] = GraphFileError) -> None:
    """``error`` when ``p`` is no scene-graph file to read: a FIFO or device (``/dev/null``),
    a folder, a missing path, each said as it is (all three were "scene-graph file not
    found")."""
    from aion_cli.formats.raw import check_regular_input

    hint = "give the graph file Hydra saved (dsg.json, dsg_with_mesh.json or .sparkdsg)"
    check_regular_input(p, "scene-graph file", error, hint=hint)
    if p.is_dir():
        raise error(f"{p} is a folder, not a scene-graph file", hint=hint)
    if not p.is_file():
        raise error(f"scene-graph file not found: {p}", hint="check the path")


def _other_file_hint(p: Path, suffix: str) -> str:
    """The hint for a scene-graph file of another kind: an aion map or a log given where a
    graph file goes (``--graph office.aion``) is told where its graph comes from."""
    saved = "Hydra saves graphs as dsg.json, dsg_with_mesh.json or .sparkdsg"
    import shlex

    if suffix == ".aion":
        return (
            f"{p.name} is an aion map: `aion export {shlex.quote(str(p))} --format dsg -o "
            f"graph.json` writes its scene graph as a graph file ({saved})"
        )
    if suffix in (".mcap", ".bag", ".db3"):
        return (
            f"{p.name} is a log: aion build reads the scene graphs of the logs it is given "
            f"(LOG...); a graph file is what Hydra saved ({saved})"
        )
    return saved


def read_dsg_file(path: str | Path) -> GraphFile:
    """Read a spark_dsg graph file (``.json``, ``.bson``, ``.sparkdsg``), with clear errors.

    A JSON file spark_dsg refuses is read leniently (:func:`formats.dsg_json.read_lenient`);
    a binary file spark_dsg refuses, or a file that is not a graph at all, is a
    :class:`GraphFileError`.
    """
    import spark_dsg

    p = Path(path)
    check_graph_path(p)
    suffix = p.suffix.lower()
    if suffix not in (".json", ".bson", ".sparkdsg"):
        raise GraphFileError(
            f"unsupported scene-graph file extension {p.suffix!r}: {p}",
            hint=_other_file_hint(p, suffix),
        )
    size = p.stat().st_size
    if size == 0:
        raise GraphFileError(
            f"scene-graph file is empty: {p}",
            hint="the graph was not written; save it again from Hydra or spark_dsg",
        )
    suffix = _suffix_by_content(p, suffix)
    if suffix == ".sparkdsg":
        _check_binary_file(p)
    version = _file_version(p, suffix)
    budget: int | None = None
    try:
        # legacy (header-less) JSON files warn on stdout
        with (
            _native_output_silenced(),
            _memory_budget(size) as budget,
            _as_suffix(p, suffix) as name,
        ):
            graph = spark_dsg.DynamicSceneGraph.load(name)
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
    else:
        if suffix == ".json":
            _restore_legacy_stamps(p, graph, version)
        return GraphFile(p, graph, version=version, read_as=suffix)
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
        read_as=suffix,
    )


def _restore_legacy_stamps(path: Path, graph: Any, version: str | None) -> None:
    """The agent stamps spark_dsg leaves 0 in a JSON file written before spark_dsg 1.1.0
    (:func:`formats.dsg_json.restore_agent_stamps`), read from the file's own JSON. Files of
    other versions, and graphs without agent poses, are not parsed a second time."""
    from aion_cli.formats.dsg_json import restore_agent_stamps, stamps_beside_attributes

    if not stamps_beside_attributes(version):
        return
    if not any(int(v.partition) != 0 and v.num_nodes() for v in graph.layer_partitions):
        return
    import json

    try:
        doc = json.loads(path.read_bytes().decode("utf-8-sig"))
    except (OSError, ValueError, RecursionError, MemoryError) as exc:
        raise GraphFileError(
            f"cannot read scene-graph file {path}: its agent stamps cannot be read ({exc})"
        ) from exc
    if isinstance(doc, dict):
        restore_agent_stamps(graph, doc)


def _suffix_by_content(path: Path, suffix: str) -> str:
    """The suffix spark_dsg must be given for ``path`` (it chooses its reader by the name):
    ``suffix``, but ``.json`` for JSON text named ``.sparkdsg`` and ``.sparkdsg`` for a
    binary graph named ``.json`` (a renamed file was called damaged, or not UTF-8); JSON text
    may start with a UTF-8 byte-order mark (a ``.json`` file read so, leniently).

    A ``.bson`` file is read as ``.json`` (spark_dsg saves ``.bson`` as JSON text and reads
    it back as JSON), or as ``.sparkdsg`` when it holds a binary graph: read under its own
    name, its version header, the lenient reading of a file spark_dsg refuses and a legacy
    file's agent stamps were all missed (a legacy ``.bson`` gave every agent pose time 0)."""
    with open(path, "rb") as fh:
        head = fh.read(64)
    binary = head[:14] == spark_header("0.0.0")[:14]  # binary's header
    if suffix == ".bson":
        return ".sparkdsg" if binary else ".json"
    if suffix == ".sparkdsg" and head.removeprefix(b"\xef\xbb\xbf").lstrip()[:1] == b"{":
        return ".json"
    if suffix == ".json" and binary:
        return ".sparkdsg"
    return suffix


@contextlib.contextmanager
def _as_suffix(path: Path, suffix: str) -> Any:
    """The name spark_dsg is given for ``path`` read as ``suffix``: the path itself when it
    ends so, else a symbolic link with that suffix in a temporary folder, removed afterwards
    (spark_dsg chooses its reader by the suffix as written, and refuses ``DSG.JSON`` or
    ``map.SPARKDSG``)."""
    if path.suffix == suffix:
        yield str(path)
        return
    import tempfile

    with tempfile.TemporaryDirectory(prefix="aion-dsg-") as folder:
        link = Path(folder) / f"graph{suffix}"
        link.symlink_to(path.resolve())
        yield str(link)


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


def graph_payload(path: str | Path) -> tuple[bytes, int, tuple[str, ...]]:
    """spark_dsg binary of a graph file, mesh included, as Hydra publishes it, for a log that
    ``aion convert`` writes, the number of agent poses left out of it and what the user must
    be told of the reading (:meth:`GraphFile.notes`: a file read leniently, what was skipped,
    as ``build --graph`` and ``info`` say it). A graph Hydra saved
    carries its own robot's trajectory in the agent layer, stamped at the times of its own
    recording; a dataset has no robot, and a build would take those poses as the sensor's
    observation instead of the log's messages and ``--observed`` spans (a fixed sensor), so
    the partitions of the agent layer are removed."""
    from aion_cli.formats.dsg_layers import AGENTS_LAYER

    file = read_dsg_file(path)
    graph = file.graph
    key = graph.get_layer_key("AGENTS")
    layer = int(key.layer) if key is not None else AGENTS_LAYER
    dropped = 0
    for view in list(graph.layer_partitions):
        if int(view.id) == layer and int(view.partition) != 0:
            dropped += int(view.num_nodes())
            graph.remove_layer(layer, view.partition)
    payload: bytes = graph.to_binary(True)
    return payload, dropped, tuple(file.notes())
