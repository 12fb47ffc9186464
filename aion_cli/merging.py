"""Merging map files (``aion merge A.aion B.aion ... -o OUT.aion``; no click).

:func:`merge_map_files` reads the maps, checks that they can be merged, folds them in time
order with the engine's :func:`~aion_cli.engine.merge.merge_maps` and writes the result
atomically with a manifest that accounts for every log (:mod:`aion_cli.merge_write`). The rules:

* **Same model.** Every map must have been built with the same model parameters (time zone
  included; two names of one zone, ``Etc/UTC`` and ``UTC``, are one zone):
  :class:`~aion_cli.errors.ConfigError` naming the parameters that differ. The planner's
  (``plan_*``, read by ``aion plan`` only) may differ: the first map's are kept, with a note.
* **Provenance.** The output's ``inputs`` are every input map's logs (path, name, size,
  sha256), in time order. A log (by sha256) that two maps hold is refused, naming both maps
  and the log: its detections would be counted twice, and a log is never counted twice. The
  same map file given twice (by path or by content) is refused too, and so is ``-o`` naming
  one of the inputs, and so are two maps of one recording read from two log files (the same
  entries over the same span: :mod:`aion_cli.merge_twins`). ``merged_from`` lists the input
  map files (name, path, size, sha256) and ``lineage`` the lineage used.
* **Lineage** (:mod:`aion_cli.merge_lineage`). Node ids mean the same place only within one
  scene-graph session (:mod:`aion_cli.engine.rebind`). ``"same"``: the maps' node entries add
  by id (the engine's merge, exact for disjoint time but for the approximations its docstring
  lists; the notes say which applied). ``"different"``: every map first releases its node
  entries to the hash cells at their positions (the release rule, counts conserved), the
  cell-only maps merge by key, and the result binds to the target graph by the usual ownership
  rules, the target's nodes treated as stable at merge time (the merged map's log time).
  ``"auto"`` decides from the graphs: consecutive maps (in time order) share a lineage when
  more than half of the node ids both latest graphs hold lie within ``bind_radius`` of each
  other; a map without a scene graph beside maps with one makes the merge ``"different"`` (its
  cells then bind to the target graph); maps without any graph merge as hash cells
  (``"same"``). A ``--graph`` target is compared with the newest map's graph the same way: one
  that holds its node ids at other places is another session (Hydra numbers every session's
  places from p0), so the merge is ``"different"``, not a move of the maps' flows to the
  target's places of the same ids.
* **Target graph.** ``graph_file`` (a Hydra ``dsg.json`` / ``.sparkdsg``, read as ``aion
  build --graph FILE`` reads it) replaces the merged graph in either lineage (nodes it lacks
  release to hash cells, cells in reach of its nodes bind); without it, a ``"different"``
  merge binds to the newest input map's latest graph and a ``"same"`` one keeps it, but for
  maps whose spans overlap, which keep what one build of their logs does: of one session the
  union of their latest graphs, of two the newest of them (:mod:`aion_cli.merge_graph`).
* **One part map.** A part map (``aion build --part``) holds its days unscored; merged alone
  (``aion merge PART.aion -o MAP.aion``) its days are scored in time order, which makes it the
  map one build of its logs gives. An ordinary map alone is refused (nothing to merge).
* **Time.** Maps are ordered by their manifests' time spans (else their open windows). Maps
  whose times overlap or interleave merge (two robots at once, or one map's days between
  another's), with notes: windows both observed count twice, and each map scored its days
  without the other's (approximation 2).

The report's notes name the approximations of the engine's merge that apply
(:mod:`aion_cli.merge_notes`).

**Memory.** The checks above need only each map's head (manifest, graph, config:
:func:`aion_cli.mapquery.load_map_head`); the fold then reads one map's state at a time and
merges it in place into the map so far, so a merge of any number of maps holds two states.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from aion_cli.errors import InputError
from aion_cli.manifest import InputLog, Manifest
from aion_cli.merge_config import adopt_config, check_compatible
from aion_cli.merge_lineage import check_lineage, choose_lineage
from aion_cli.merge_names import naming_map, shared_names
from aion_cli.merge_report import MergeReport as MergeReport  # docs/API.md names it here
from aion_cli.merge_twins import check_same_recording
from aion_cli.merge_write import write_merged
from aion_cli.number_text import counted

if TYPE_CHECKING:
    from aion_cli.build_report import ProgressSink
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.state import MapState
    from aion_cli.engine.types import GraphSnapshot
    from aion_cli.mapquery import MapHead

_HINT = "give two or more map files (.aion) of disjoint time, or one part map"


@dataclass
class _Input:
    """An input map as the merge plans with it: its head (manifest, graph, config; read
    first) and provenance. Its state is read only when the fold reaches it
    (:meth:`load`), so a merge holds the maps it is merging, not all of them."""

    path: Path
    head: MapHead
    manifest: Manifest
    file: InputLog
    label: str = ""  # the path as given when another input has the same file name

    @property
    def name(self) -> str:
        """How messages name the map: its file name, or the path as given when another
        input shares the file name (a fleet's robot1/map.aion and robot2/map.aion)."""
        return self.label or self.path.name

    @property
    def graph(self) -> GraphSnapshot | None:
        return self.head.graph

    @property
    def detections(self) -> int:
        return self.head.accepted

    def start(self) -> int | None:
        """The map's first time: its manifest's span, else its open window's start."""
        from aion_cli.engine.windows import window_ns

        if self.manifest.start_ns is not None:
            return self.manifest.start_ns
        w = self.head.open_window
        return None if w is None else w * window_ns(self.head.config.window_s)

    def load(self) -> MapState:
        """The map's state, read whole (writable: the merge changes it; it is not kept)."""
        from aion_cli.mapquery import load_map

        with naming_map(self.path):
            loaded = load_map(self.path, writable=True)
        if loaded.manifest != self.head.manifest:
            raise InputError(
                f"{self.path} changed while it was being merged",
                hint="merge maps no other process is writing",
            )
        return loaded.state


def merge_map_files(
    paths: list[Path] | tuple[Path, ...],
    out: Path,
    graph_file: Path | None = None,
    lineage: str = "auto",
    progress: ProgressSink | None = None,
    nav_layer: str | None = None,
) -> MergeReport:
    """Merge the map files ``paths`` into ``out`` (see the module docstring); the report."""
    from aion_cli.build_report import NoProgress
    from aion_cli.formats.mapfile import check_map_suffix, check_map_target, map_lock

    sink = progress or NoProgress()
    paths = [Path(p) for p in paths]
    out = Path(out)
    check_lineage(lineage)
    if not paths:
        raise InputError("a merge needs at least two maps (or one part map)", hint=_HINT)
    _check_paths(paths, out)
    check_map_target(out)
    check_map_suffix(out)  # -o merged.json: a new map named as another kind of file
    target, graph_notes = _target_graph(graph_file, nav_layer)
    report = MergeReport(out)
    report.notes.extend(graph_notes)  # a lenient read, a file named as the other format
    with map_lock(out):  # one writer per map, from the checks to the write
        if out.exists():
            report.notes.append(f"{out.name} existed and is replaced")
        maps = _read(paths, sink)
        if len(maps) == 1 and not maps[0].head.part:
            raise InputError(
                f"{paths[0]} is a map already: a merge needs at least two maps (one part map, "
                "aion build --part, alone is made a map)",
                hint=_HINT,
            )
        config = check_compatible(maps, report.notes)
        maps.sort(key=lambda m: (m.start() is not None, m.start() or 0))
        inputs = _check_logs(maps)
        check_same_recording(maps)  # one recording in two log files (two sha256s)
        report.lineage, report.lineage_reason = choose_lineage(
            maps, lineage, report.notes, target, graph_file
        )
        merged = _fold(maps, report, sink, config)
        _bind_target(merged, maps, target, graph_file, report)
        write_merged(merged, maps, inputs, report)
    return report


# -- checks -------------------------------------------------------------------------------------


def _check_paths(paths: list[Path], out: Path) -> None:
    """Every input exists once; ``out`` is none of them; its folder exists."""
    from aion_cli.formats.mapfile import check_map_folder

    seen: dict[Path, Path] = {}
    for p in paths:
        if not p.exists():
            raise InputError(f"map file not found: {p}", hint="build one with `aion build LOG`")
        if p.is_dir():
            raise InputError(f"{p} is a folder, not a map file", hint=_HINT)
        if not p.is_file():  # a device or FIFO: hashing it would block or never end
            raise InputError(f"{p} is not a regular file, not a map file", hint=_HINT)
        real = p.resolve()
        if real in seen:
            raise InputError(f"the map {p} is given twice", hint="give each map once")
        seen[real] = p
        if out.resolve() == real or (out.exists() and os.path.samefile(out, p)):
            raise InputError(
                f"the output {out} is one of the input maps",
                hint="write the merged map to a new file",
            )
    check_map_folder(out)


def _target_graph(
    graph_file: Path | None, nav_layer: str | None
) -> tuple[GraphSnapshot | None, list[str]]:
    """The ``--graph FILE`` snapshot (read before any map, so a bad file fails first) and
    the notes of its read (as ``build --graph`` prints them); ``--nav-layer`` chooses its
    navigational layer, and without the file means nothing."""
    if graph_file is None:
        if nav_layer is not None:
            raise InputError(
                f"--nav-layer {nav_layer} chooses the layer of a --graph FILE, and none is given",
                hint="the maps' own graphs keep the layers they were built with",
            )
        return None, []
    from aion_cli.formats.dsg import load_graph
    from aion_cli.formats.dsg_files import check_graph_path

    check_graph_path(Path(graph_file), InputError)
    loaded = load_graph(graph_file, 0, nav_layer)
    return loaded.snapshot, loaded.notes()


def _read(paths: list[Path], sink: ProgressSink) -> list[_Input]:
    """Hash every map file and read its head (:func:`aion_cli.mapquery.load_map_head`)."""
    from aion_cli.formats.mapfile import check_writable_version
    from aion_cli.mapquery import load_map_head
    from aion_cli.provenance import provenance
    from aion_cli.query_only import refuse_learning

    sink.start("reading maps", len(paths), "maps")
    maps: list[_Input] = []
    first_of: dict[str, Path] = {}
    shared = shared_names(p.name for p in paths)
    for p in paths:
        file = InputLog.from_dict(provenance(p))
        if file.sha256 in first_of:
            raise InputError(
                f"{first_of[file.sha256]} and {p} are the same map (same sha256)",
                hint="give each map once",
            )
        first_of[file.sha256] = p
        with naming_map(p):
            head = load_map_head(p)
            check_writable_version(head.manifest.get("version"))
        manifest = Manifest.from_dict(head.manifest)
        refuse_learning(p, manifest.query_only, "merged")
        maps.append(_Input(p, head, manifest, file, str(p) if p.name in shared else ""))
        sink.advance(1)
    return maps


def _check_logs(maps: list[_Input]) -> tuple[InputLog, ...]:
    """Every map's logs, in time order; a log (by sha256) in two maps is an InputError."""
    owner: dict[str, tuple[_Input, InputLog]] = {}
    inputs: list[InputLog] = []
    for m in maps:
        for log in m.manifest.inputs:
            seen = owner.get(log.sha256)
            if seen is not None and seen[0] is not m:
                first = seen[1].name  # a copy under another name: say both names
                copy = "" if log.name == first else f"; a copy named {log.name} in {m.name}"
                raise InputError(
                    f"the log {first} (sha256 {log.sha256[:12]}{copy}) is in both "
                    f"{seen[0].name} and {m.name}: a log is never counted twice",
                    hint="merge maps built from different logs (aion info MAP lists a map's "
                    "logs), or build one map from all the logs",
                )
            owner[log.sha256] = (m, log)
            inputs.append(log)
    return tuple(inputs)


# -- merging ------------------------------------------------------------------------------------


def _fold(
    maps: list[_Input], report: MergeReport, sink: ProgressSink, config: ModelConfig | None
) -> MapState:
    """The maps merged in time order (released to hash cells first for ``"different"``),
    with a note for each approximation of the engine's merge that applies. Each map's state
    is read when its turn comes and merged in place (``merge_maps(consume=True)``): memory
    holds the merged map and the one being added, whatever the number of maps. ``config``:
    the config every map takes (fixed-sensor maps that differ only in their robot exposure
    settings, :func:`~aion_cli.merge_config.check_compatible`), None: they share theirs."""
    from aion_cli.build_plausibility import Ground, merge_ground_warning
    from aion_cli.engine.graph_arrays import file_graph_time
    from aion_cli.engine.merge import merge_maps
    from aion_cli.engine.rebind import release_all
    from aion_cli.engine.state import MapState
    from aion_cli.merge_notes import (
        ApproximationTally,
        day_notes,
        declared_gap_note,
        interleave,
        pair_notes,
        within_note,
    )
    from aion_cli.merge_observed import (
        fill_declared_gap,
        fill_declared_tail,
        merged_part_spans,
        unfilled_within,
    )

    spans = merged_part_spans([m.manifest for m in maps if m.head.part])
    tally = ApproximationTally(report.lineage)
    pairs: list[str] = []
    joins: list[str] = []
    grounds: list[tuple[str, Ground]] = []  # where each map holds its detections, as read
    sink.start("merging", len(maps), "maps")
    acc: MapState | None = None
    for k, m in enumerate(maps):
        state = m.load()
        if config is not None:
            adopt_config(state, config)
        grounds.append((m.name, Ground.of(state)))
        if report.lineage == "different":
            report.released += release_all(state)
        late = maps[k + 1] if k + 1 < len(maps) else None
        if late is not None and not late.head.part:  # a part's join scores that day once
            pairs.extend(pair_notes(m.name, m.manifest.end_ns, late.name, late.start()))
            if interleave(m.manifest.end_ns, late.start()):
                tally.interleaved()
        if k == 0 or state.deferred is None:
            tally.add(state)
        if k and state.deferred is None:  # the time between a map and an ordinary map
            gap = declared_gap_note(
                m.name, maps[k - 1].manifest, m.manifest, spans, state.window_ns
            )
            joins.extend([] if gap is None else [gap])
        if state.deferred is not None:
            within = unfilled_within(state, m.manifest, spans)
            joins.extend([within_note(m.name, within, state.window_ns)] if within else [])
            base = acc if acc is not None else MapState.empty(state.config)
            before = base.graph
            filled = fill_declared_gap(  # the declared windows before the part
                base, maps[k - 1].manifest if k else None, m.manifest, spans
            )
            if not k and filled:  # the merged map starts where they do, as one build's
                report.start_ns = int(base.observation.merged_fixed()[0][0])
            acc = _join_part(base, state, m.name, report, joins)
            if m.manifest.graph_source.startswith("file "):  # each part added the file anew
                acc.graph = file_graph_time(acc.graph, before)
        else:
            if acc is not None:  # a day both hold that the merge cannot join
                pairs.extend(day_notes(maps[k - 1].name, acc, m.name, state, m.start()))
            acc = state if acc is None else merge_maps(acc, state, consume=True)
        del state
        sink.advance(1)
    assert acc is not None  # a merge has one map at least
    if maps[-1].head.part and acc.deferred is None:  # the parts' spans after their logs
        report.end_ns = fill_declared_tail(acc, maps[-1].manifest, spans)
    if report.lineage == "different":
        report.notes.append(
            f"{report.released} node entries released to the hash cells at their places"
        )
    report.notes.extend(pairs + tally.notes(parts=report.parts > 0) + joins)
    away = merge_ground_warning(grounds, acc.config.bind_radius, by_id=report.lineage == "same")
    report.warnings.extend([] if away is None else [away])  # another place, another frame
    return acc


def _join_part(
    acc: MapState, part: MapState, name: str, report: MergeReport, notes: list[str]
) -> MapState:
    """A part map (``aion build --part``) joined onto the maps before it: its held days are
    scored against all of their history, as one build of every log would
    (:func:`aion_cli.engine.shards.join_shard`); a note when the join cannot be exact."""
    from aion_cli.engine.join_blockers import join_blocker
    from aion_cli.engine.shards import join_shard, overlap_blocker

    overlap = overlap_blocker(acc, part)
    if overlap is not None:
        raise InputError(
            f"the part map {name} overlaps the maps before it in time: {overlap}; a part "
            "joins only after them, nothing was written",
            hint="build the overlapping logs into one part (aion build LOG1 LOG2 --part -o "
            "PART.aion), or merge ordinary maps (windows both observed then count twice)",
        )
    reason = join_blocker(acc, part)
    if reason is not None:
        notes.append(f"{name} was joined, but not exactly as one build would: {reason}")
    report.parts += 1
    return join_shard(acc, part)


def _bind_target(
    merged: MapState,
    maps: list[_Input],
    target: GraphSnapshot | None,
    graph_file: Path | None,
    report: MergeReport,
) -> None:
    """Bind the merged map to its target graph (see the module docstring) and say where its
    graph comes from."""
    from aion_cli.engine.rebind import bind_to_graph
    from aion_cli.merge_graph import merged_graph

    if target is not None and graph_file is not None:
        report.graph_source = f"file {graph_file.name}"
    else:  # the newest graph, or one session's maps at once: their union (as one build)
        target, report.graph_source = merged_graph(maps, report.lineage, merged.graph)
    if target is None:
        return
    t_ns = merged.log_time_ns
    if t_ns is None:
        t_ns = max((m.manifest.end_ns for m in maps if m.manifest.end_ns is not None), default=0)
    before = len(merged.entries.node_rows())
    report.rebound = bind_to_graph(merged, target, t_ns)
    report.notes.append(
        f"{counted(report.rebound, 'hash cell')} bound to the "
        f"{counted(len(target.places), 'place')} of "
        f"{report.graph_source} (its places taken as stable at the merge time; "
        f"{before} node entries before, {len(merged.entries.node_rows())} after)"
    )
