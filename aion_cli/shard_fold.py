"""One shard of a parallel build, and the fold that joins the shards into one map.

The worker side (:func:`build_shard`): a :class:`ShardTask` — a group of logs, or a time part
of one, with the build's options and config — learnt as a sequential build reads it, its
closed days held unscored (:mod:`aion_cli.engine.shards`), into a :class:`ShardResult`. The
parent side (:func:`fold`, :func:`learn_rest`): each result joined onto the map of every shard
before it, in time order, or its logs learnt again in sequence onto that map where a join
would not be exact (:class:`Folded` keeps the map so far, the notes saying which and why, and
the stream's rules a later shard continues).

Why apart from :mod:`aion_cli.parallel_build` (which plans the shards and runs them): the
local process pool (:mod:`aion_cli.process_pool`) and a Dask cluster
(:mod:`aion_cli.dask_build`) run these same tasks and folds, each in its own way.
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aion_cli.build_report import BuildReport, ProgressSink
from aion_cli.time_shards import part_fields

if TYPE_CHECKING:
    from collections.abc import Callable

    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.state import MapState
    from aion_cli.pipeline import BuildOptions, _Build
    from aion_cli.tf_feed import StaticTf


@dataclass(frozen=True)
class ShardTask:
    """One shard: its logs (in time order), whether its days are held for the join, and the
    build's options and config (every shard learns with the same); a time shard also has its
    part ``[lo, hi)`` of log time and whether it is its logs' first part
    (:mod:`aion_cli.time_shards`); and the orientation rule's state it starts from
    (:mod:`aion_cli.shard_yaws`)."""

    index: int
    logs: tuple[Path, ...]
    deferred: bool
    opts: BuildOptions
    config: ModelConfig
    part: tuple[int, int] | None = None
    first_part: bool = True
    # detection topics whose pose orientations varied before the shard (aion_cli.shard_yaws)
    yaw_seen: dict[str, float] = field(default_factory=dict)
    # the static transforms of all the build's logs (aion_cli.tf_feed.read_static_tf)
    static_tf: StaticTf = ()
    # the continued map's recordings (aion_cli.recording_twins): a shard out of time order
    # that repeats one of them is refused as such
    recordings: tuple[dict[str, Any], ...] = ()
    # no map and no logs before the shard's logs (ShardStart.opens_map)
    opens_map: bool = False
    # the names of the continued map's inputs: a shard out of time order is refused with the
    # command that builds them and the logs at once (aion_cli.log_order.out_of_order_error)
    map_inputs: tuple[str, ...] = ()
    # the continued map's open window's start (None: a new map): the shard's detections and
    # scene graphs before it are refused, as a sequential build refuses them
    map_open_ns: int | None = None


@dataclass
class ShardResult:
    """A built shard: its map state and build report, with the worker's cost."""

    index: int
    state: MapState | None
    report: BuildReport
    seconds: float = 0.0
    peak_rss_mb: float = 0.0
    worker: str = ""
    #: the shard's logs' first and last message, and its agent layers' first and last robot
    #: pose (``StreamStep.times_apart``): the parent checks them all together
    times_apart: tuple[tuple[int, int] | None, tuple[int, int] | None] = (None, None)

    def without_state(self) -> ShardResult:
        """The result's summary, once its state is folded (states are the large part)."""
        return dataclasses.replace(self, state=None)


@dataclass
class Folded:
    """The map so far and what the fold noted (shards rebuilt in sequence, and why)."""

    state: MapState | None
    notes: list[str] = field(default_factory=list)
    reports: list[BuildReport] = field(default_factory=list)
    seconds: float = 0.0  # spent folding (joins, and shards learnt in sequence)
    # per detection topic: the orientation rule's state after the shards so far (the one yaw
    # seen, NaN once they varied; aion_cli.detection_feed.DetectionFeeder.yaw_rule)
    yaws: dict[str, float] = field(default_factory=dict)
    # the scene-graph version and layer pinned so far (aion_cli.graph_feed.GraphFeed.pins)
    pins: tuple[str | None, str | None] = (None, None)
    # per shard learnt again in sequence because its scene graph bound cells, or moved
    # places, otherwise than one pass: why (engine.join_blockers.JoinBlock.cause)
    graph_causes: list[str] = field(default_factory=list)

    @property
    def graph_fallbacks(self) -> int:
        """How many shards were learnt again because of their scene graph."""
        return len(self.graph_causes)

    def then(self, state: MapState | None, report: BuildReport, note: str | None = None) -> Folded:
        """The fold after one more shard (its state and report; ``note``: how it went)."""
        yaws = {**self.yaws, **{t: last for t, (_, last) in report.yaw_rule.items()}}
        pins = (
            self.pins[0] if self.pins[0] is not None else report.graph_pins[0],
            self.pins[1] if self.pins[1] is not None else report.graph_pins[1],
        )
        notes = [*self.notes, note] if note else self.notes
        return Folded(
            state, notes, [*self.reports, report], self.seconds, yaws, pins,
            list(self.graph_causes),
        )


def _shard_build(
    task: ShardTask, progress: ProgressSink, before: Folded | None = None, **part: Any
) -> _Build:
    """The build of one shard's logs (the parent hashed them), with ``part`` telling
    :class:`~aion_cli.pipeline._Build` how it starts (``deferred``, or ``start`` state) and
    ``before`` the fold whose stream a shard learnt in sequence continues."""
    from aion_cli.build_options import ShardStart
    from aion_cli.pipeline import _Build

    opts = dataclasses.replace(
        task.opts, logs=task.logs, continue_from=None, workers=1, scheduler=None
    )
    at = ShardStart(
        task.part, task.first_part, yaw_seen=task.yaw_seen, static_tf=task.static_tf,
        opens_map=task.opens_map,
    )
    if before is not None:
        at = dataclasses.replace(at, yaw_seen=before.yaws, graph_pins=before.pins)
    build = _Build(opts, progress, shard=True, at=at, **part)
    build.set_logs(task.logs)
    return build


def build_shard(task: ShardTask, progress: ProgressSink | None = None) -> ShardResult:
    """Learn one shard's logs (in a worker process or a Dask task)."""
    from aion_cli.build_report import NoProgress

    begin = time.perf_counter()
    build = _shard_build(task, progress or NoProgress(), deferred=task.deferred)
    state = build.learn(task.config).state
    return ShardResult(
        task.index,
        state,
        build.report,
        time.perf_counter() - begin,
        _peak_rss_mb(),
        f"{os.uname().nodename}:{os.getpid()}",
        build.times_apart(),
    )


def fold(
    folded: Folded,
    result: ShardResult,
    task: ShardTask,
    on_graph_change: Callable[[], None] | None = None,
) -> Folded:
    """Join one shard onto the map so far (in time order), or rebuild its logs onto it in
    sequence where a join would not be exact. ``on_graph_change`` is called before such a
    rebuild when the shard's own scene graph bound cells, or moved places, otherwise than one
    pass would have (not because it overlaps the map in time): a Hydra graph that grows or is
    corrected, which will change for the shards after it too (the local pool stops its
    workers then)."""
    from aion_cli.detection_feed import yaw_rule_blocker
    from aion_cli.engine.graph_arrays import file_graph_time
    from aion_cli.engine.join_blockers import join_blocker
    from aion_cli.engine.shards import join_shard, overlap_blocker
    from aion_cli.graph_notes import pins_blocker

    state = result.state
    if state is None:
        raise ValueError("this shard's state was folded already")
    if folded.state is None:
        if state.deferred is not None:
            raise ValueError("the first shard of a new map is built as an ordinary map")
        return folded.then(state, result.report)
    _check_order(folded.state, result, task)
    # another navigational layer first: its places differ from the map's, which the
    # ownership checks would otherwise report as a graph that changed
    pins = pins_blocker(folded.pins, result.report.graph_pins)
    ownership = None if pins is not None else join_blocker(folded.state, state)
    blocker = (
        pins or ownership or yaw_rule_blocker(folded.yaws, result.report.yaw_rule, task.yaw_seen)
    )
    if blocker is None:
        before = folded.state.graph
        joined = join_shard(folded.state, state)
        if result.report.graph_source.startswith("file "):  # each shard added the file anew
            joined.graph = file_graph_time(joined.graph, before)
        return folded.then(joined, result.report)
    graph_changed = (
        ownership is not None
        and state.graph is not None
        and overlap_blocker(folded.state, state) is None
    )
    if graph_changed and on_graph_change is not None:
        on_graph_change()
    what = _names(task.logs)
    if task.part is not None:
        what = f"the part of {what} from {part_fields(task.part)['from']}"
    plural = len(task.logs) > 1 and task.part is None
    note = (
        f"{what} {'were' if plural else 'was'} learnt in sequence onto the map (not joined in "
        f"parallel): {blocker}"
    )
    rebuilt = rebuild_onto(folded.state, task, folded)
    out = folded.then(rebuilt.state, rebuilt.report, note)
    if graph_changed and ownership is not None:
        out.graph_causes.append(ownership.cause)
    return out


def learn_rest(
    folded: Folded,
    tasks: list[ShardTask],
    total: int,
    done: dict[int, ShardResult] | None = None,
    on_folded: Callable[[int], None] | None = None,
) -> Folded:
    """The shards ``tasks`` (the last of ``total``), once a shard had to be learnt again in
    sequence because the scene graph changed between shards (a Hydra graph that grows or is
    corrected binds cells as it goes): the later shards' graphs change too, so they are
    learnt here in sequence, each onto the map so far (the map of one pass), instead of
    being built apart first and then again. A shard already built (``done``, by index) is
    folded as usual; ``on_folded(index)`` after each. The local pool runs this in the parent
    once it stopped its workers, a Dask build as one task on the cluster."""
    begin = time.perf_counter()
    done = {} if done is None else done
    learnt = 0
    for task in tasks:
        result = done.pop(task.index, None)
        if result is not None:
            folded = fold(folded, result, task)
        else:
            if folded.state is None:
                raise ValueError("the rest of a fold needs the map so far")
            rebuilt = rebuild_onto(folded.state, task, folded)
            folded = folded.then(rebuilt.state, rebuilt.report)
            learnt += 1
        if on_folded is not None:
            on_folded(task.index)
    if learnt:
        verb, whose = ("was", "its graph") if learnt == 1 else ("were", "their graphs")
        folded.notes.append(
            f"the scene graph changed between shards: the last {learnt} of {total} shards "
            f"{verb} learnt in sequence without waiting for the workers ({whose} would have "
            "changed too)"
        )
    folded.seconds += time.perf_counter() - begin
    return folded


def _check_order(acc: MapState, result: ShardResult, task: ShardTask) -> None:
    """The shard's detections and scene graphs (their own times, ``report.data_starts``;
    not its first message, which may be a transform) judged as a sequential build judges its
    batches: before a continued map's open window (``task.map_open_ns``) they are refused
    (``_check_after_map``); before the open window of the map so far, with the logs' own
    clock a simulation's from 0, the clock is the reason (``_check_clocks``)."""
    from aion_cli.log_order import other_clock_error

    starts = result.report.data_starts
    if not starts:
        return
    if task.map_open_ns is not None:
        _check_after_map(result, task, task.map_open_ns)
    first = min(starts.values())
    if acc.open_window is None or len(task.opts.logs) < 2:
        return
    open_start = acc.open_window * acc.window_ns
    if first < open_start:
        clocks = other_clock_error(_names(task.logs), result.report.start_ns, open_start, first)
        if clocks is not None:  # the logs' clock from 0, the map's windows from stamps
            raise clocks


def _check_after_map(result: ShardResult, task: ShardTask, open_start: int) -> None:
    """The shard's detections or scene graphs before a continued map's open window (from
    ``open_start``): refused, with the command that builds the map's inputs and the logs at
    once (:func:`aion_cli.log_order.out_of_order_error`), or as a recording the map holds."""
    from aion_cli.log_order import other_clock_error, out_of_order_error

    early = {what: t for what, t in result.report.data_starts.items() if t < open_start}
    if not early:
        return
    what = "detection" if "detection" in early else min(early, key=early.__getitem__)
    clocks = other_clock_error(_names(task.logs), result.report.start_ns, open_start, early[what])
    if clocks is not None:  # the logs' clock from 0, the map's windows from stamps
        raise clocks
    continued = task.opts.continue_from
    name = continued.name if continued is not None else "the map"
    if "detection" in early:
        from aion_cli.recording_twins import check_continued

        check_continued(task.recordings, name, _names(task.logs), result.report.sketch)
    raise out_of_order_error(
        f"the {what}s of {_names(task.logs)}", early[what], open_start, name, task.map_inputs,
        task.opts.logs, task.config.timezone,
    )


def rebuild_onto(state: MapState, task: ShardTask, before: Folded | None = None) -> ShardResult:
    """The shard's logs learnt onto ``state`` in sequence, exactly as one pass continues
    (``before``: the fold so far, whose stream's rules it continues: the orientation rule's
    state and the scene graphs' pins)."""
    from aion_cli.build_report import NoProgress

    build = _shard_build(task, NoProgress(), before, start=state)
    state = build.learn(task.config).state
    return ShardResult(task.index, state, build.report, times_apart=build.times_apart())


def _names(logs: tuple[Path, ...]) -> str:
    names = [p.name for p in logs[:3]] + (["..."] if len(logs) > 3 else [])
    return ", ".join(names)


def _peak_rss_mb() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
