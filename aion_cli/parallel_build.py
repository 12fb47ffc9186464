"""Parallel builds: ``aion build LOG... --workers N`` and ``--scheduler ADDRESS`` (Dask).

The plan (:func:`plan_shards`): the logs, ordered by time, are cut into *shards*, groups of
logs that share no time window (logs that overlap, or touch within a window or a few seconds,
stay together: a single pass interleaves their messages). With fewer such groups than workers,
a long log (or group) is cut further at quiet moments into *time shards* of its log time
(:mod:`aion_cli.time_shards`), which join like separate logs. Each shard is built in a worker
process (or a Dask task, which reads the logs by path) exactly as a sequential build reads it,
except that its closed days are held unscored (:mod:`aion_cli.engine.shards`); the first shard
of a new map is built as an ordinary map. The parent then folds the shards into one map in time
order (:func:`aion_cli.shard_fold.fold`): each is joined onto the map of every shard before it,
which scores its held days against all of that history, so the result equals the sequential
build.

Where a shard cannot be joined exactly (:func:`aion_cli.engine.join_blockers.join_blocker`: its
ownership changed after one of its days closed, it has no scene graph of its own while the
map has one, ...), the fold rebuilds that shard's logs in sequence onto the map so far (a
note says which and why): the result is exact either way, only slower. Builds that need all
logs at once (``--derive-graph``) run sequentially, as do builds whose logs form one shard
that has no quiet moment to cut it at.

Ctrl-C (or any error) stops every worker; nothing is written until the fold is complete, so
the previous map stays intact. Progress shows every worker's own bar.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from aion_cli.build_options import MAX_WORKERS
from aion_cli.build_report import check_usable, unread_detections
from aion_cli.errors import InputError
from aion_cli.shard_fold import Folded, ShardResult, ShardTask
from aion_cli.shard_reports import (
    built_twice_note,
    combine_reports,
    counts_of,
    declared_beside_robot,
)
from aion_cli.time_shards import part_fields

if TYPE_CHECKING:

    from aion_cli.build_report import BuildReport
    from aion_cli.detection_counts import DetectionCounts
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.state import MapState
    from aion_cli.pipeline import BuildOptions, _Build
    from aion_cli.tf_feed import StaticTf

K = TypeVar("K")
"""What names a log in :func:`plan_shards`: its path, or a recording's position."""

#: logs closer than this in time stay in one shard (headings link tracks across small gaps)
TOUCH_NS = 10 * 10**9


def worker_count(requested: int) -> int:
    """``--workers``: 0 means one per core."""
    if not 0 <= requested <= MAX_WORKERS:
        raise InputError(
            f"--workers must be 0 (one per core) .. {MAX_WORKERS}, got {requested}"
        )
    return requested or (os.cpu_count() or 1)


def plan_shards(spans: list[tuple[K, int, int]], window_ns: int) -> list[tuple[K, ...]]:
    """Groups of logs (the groups in time order) that share no time window: ``spans`` are
    (log, first, last message time). A log joins the group before it when it starts before
    that group's last window ends or within :data:`TOUCH_NS` of its end. Each group keeps its
    logs in the order of ``spans`` (the order given): one pass breaks ties between messages
    of one log time by that order, and a shard must too (two robots' logs from the same
    instant, whose TF messages share their stamps, gave another map in a shard that put the
    shorter log first)."""
    groups: list[list[int]] = []
    group_end = 0
    by_time = sorted(range(len(spans)), key=lambda k: (spans[k][1], spans[k][2], str(spans[k][0])))
    for k in by_time:
        _, start, end = spans[k]
        if groups:
            window_end = (group_end // window_ns + 1) * window_ns
            if start < window_end or start - group_end <= TOUCH_NS:
                groups[-1].append(k)
                group_end = max(group_end, end)
                continue
        groups.append([k])
        group_end = end
    return [tuple(spans[k][0] for k in sorted(g)) for g in groups]


class ParallelBuild:
    """The parallel part of one ``aion build`` run (see the module docstring)."""

    def __init__(self, build: _Build, config: ModelConfig) -> None:
        self.build = build
        self.config = config
        self.opts: BuildOptions = build.opts
        self.groups: list[tuple[Path, ...]] = []  # per shard: its logs
        self.parts: list[tuple[int, int] | None] = []  # per shard: its time part, if cut

    def run(self) -> MapState:
        """The learnt map state (the caller writes it); the report is filled in."""
        opts, report = self.opts, self.build.report
        logs = self.build.logs
        if opts.derive_graph and opts.graph_file is None:  # with --graph: ignored, noted
            if opts.workers >= 2 or opts.scheduler is not None:  # asked for, not the default
                report.notes.append("--derive-graph needs every log at once: built in sequence")
            return self.build.learn(self.config).state
        workers = 1 if opts.scheduler is not None else worker_count(opts.workers)
        if workers < 2 and opts.scheduler is None:
            return self.build.learn(self.config).state
        previous = self.build.previous.state if self.build.previous is not None else None
        if previous is not None and previous.deferred is not None:
            # a part map holds its closed days unscored, and a shard joins only an ordinary
            # map (engine.shards.join_shard), so the logs are learnt onto it in sequence:
            # a part continued day by day with the default --workers stopped on an
            # internal error
            if opts.workers >= 2 or opts.scheduler is not None:  # asked for, not the default
                report.notes.append(
                    "--map is a part map (--part): its held days join no shard, so the logs "
                    "were learnt onto it in sequence in this process"
                )
            return self.build.learn(self.config).state
        window = _window_ns(self.config)
        spans: list[tuple[Path, int, int]] = []
        whole: frozenset[int] = frozenset()  # groups kept together across sessions
        if len(logs) < 2:
            groups = [tuple(logs)]
        else:
            spans, empty = self._spans(logs)
            groups = plan_shards(spans, window)
            if empty and groups:
                groups[0] = groups[0] + tuple(empty)
            from aion_cli.shard_graphs import kept_together

            groups, note, whole = kept_together(groups, opts, self.config.stable_move_tolerance)
            if note:
                report.notes.append(note)
        from aion_cli.time_shards import split_groups

        if opts.observed:
            # declared spans count within each file's own time, first to last message, which
            # a time shard of the file cannot see whole: files are shards, never cut
            whole = frozenset(range(len(groups)))
        # unasked (--workers not given), a log left whole is no news: the notes say why
        # only when parallel workers were asked for
        asked = opts.workers >= 2 or opts.scheduler is not None
        shards, notes = split_groups(
            groups, opts, window, workers, self.config.stable_move_tolerance, whole, asked
        )
        report.notes.extend(notes)
        if opts.observed and len(shards) < 2 and asked:
            report.notes.append(
                "--observed: a log is not cut into time shards (its declared spans count "
                "from its first message to its last): built in sequence"
            )
        # (else a note says why)
        if len(shards) < 2 and not notes and not whole and asked:
            report.notes.append(
                ("one log" if len(logs) < 2 else "the logs overlap in time (one shard)")
                + ": built in sequence, not in parallel (no quiet moment to cut it at: a "
                "window start with no detection message in the 10 s before it; "
                "docs/SCALING.md)"
            )
        if len(shards) < 2:
            if opts.scheduler is not None:  # asked for a cluster: say it was not used
                report.notes.append(
                    f"--scheduler {opts.scheduler}: not contacted, the build is one shard and "
                    "ran in this process"
                )
            return self.build.learn(self.config).state
        self.groups = [group for group, _, _ in shards]
        self.parts = [part for _, part, _ in shards]
        seeds, kd_trees, static_tf = _plan_streams(list(logs), self.build, shards, spans)
        fills = self._observed_fills(spans, window)
        before = self.build.previous_manifest
        recordings = before.recordings if before is not None else ()
        tasks = [
            ShardTask(
                i, group, previous is not None or i > 0,
                opts if fill is None else dataclasses.replace(opts, observed_fill=fill),
                self.config, part, first, seed, static_tf, recordings,
                opens_map=previous is None and group == shards[0][0],
                map_inputs=tuple(e.name for e in before.inputs) if before is not None else (),
                map_open_ns=_open_start(previous),
            )
            for i, ((group, part, first), seed, fill) in enumerate(
                zip(shards, seeds, fills, strict=True)
            )
        ]
        if opts.scheduler is not None:
            from aion_cli.dask_build import run_on_cluster

            folded, results = run_on_cluster(opts.scheduler, tasks, previous, self.build.progress)
        else:
            # imported once here, so the forked workers start with them (scipy.sparse: every
            # shard absorbs its days with it; scipy.spatial, where scene graphs need KD-trees:
            # a shard looking for cells near places not yet stable, and the joins here; one
            # import before the fork instead of one per worker and one more here, and none
            # where nothing needs it: a robot's sensor range and a bind check's new cells are
            # measured without one, engine.sensor_reach and engine.nearest.BindIndex)
            import scipy.sparse

            if kd_trees:
                import scipy.spatial  # noqa: F401

            import aion_cli.detection_feed
            import aion_cli.formats.logs  # noqa: F401
            from aion_cli.process_pool import run_in_processes

            folded, results = run_in_processes(
                tasks, min(workers, len(tasks)), previous, self.build.progress
            )
        if declared_beside_robot(folded.reports):
            report.notes.append(
                "--observed beside a robot's logs: one pass ignores the declared spans (the "
                "robot's poses say what was observed), which the shards of the fixed sensor's "
                "logs applied, so the logs were learnt again in sequence"
            )
            return self.build.learn(self.config).state
        self._report(folded, results, len(tasks), workers)
        assert folded.state is not None
        return folded.state

    def _observed_fills(
        self, spans: list[tuple[Path, int, int]], window: int
    ) -> list[tuple[int | None, int | None] | None]:
        """Per shard, how far its ``--observed`` spans may fill beyond its own logs
        (``BuildOptions.observed_fill``; None: not at all, without ``--observed``): each
        shard fills up to the window of its last message (the last shard: its logs' own
        last), the next from the window after it, the first from where a continued map's
        logs stopped; so the shards together fill the time between the groups of logs as
        one pass does (with ``--observed`` a shard is whole files: :meth:`run`)."""
        if not self.opts.observed:
            return [None] * len(self.groups)
        end_of = {path: end for path, _, end in spans}
        ends = [max((end_of[p] for p in group if p in end_of), default=None)
                for group in self.groups]
        previous = self.build.previous_manifest
        reach = previous.recording_reach if previous is not None else None
        fills: list[tuple[int | None, int | None] | None] = []
        lo = None if reach is None else reach + 1
        for i, end in enumerate(ends):
            last = i == len(ends) - 1
            hi = None if last or end is None else end // window
            fills.append((lo, hi))
            if hi is not None:
                lo = hi + 1
        return fills

    def _spans(self, logs: tuple[Path, ...]) -> tuple[list[tuple[Path, int, int]], list[Path]]:
        """Each log's first and last message time (from its index or summary; a rosbag2 bag
        of several storage files, one path, from its first file's first to its last file's
        last), and the logs without messages (they go with the first shard, whose build notes
        them)."""
        from aion_cli.formats.logs import open_logs

        with open_logs(list(logs), self.opts.log_format) as logset:
            files = list(zip(logset.recordings, logset.files, strict=True))
        spans: list[tuple[Path, int, int]] = []
        empty: list[Path] = []
        for position, path in enumerate(logs):
            own = [f for recording, f in files if recording == position]
            if not own:  # a path another one reads already is left out before; guard anyway
                raise ValueError(f"{path} opened no log of its own")
            busy = [f for f in own if f.message_count > 0]
            if busy:
                spans.append(
                    (path, min(int(f.start_ns) for f in busy), max(int(f.end_ns) for f in busy))
                )
            else:
                empty.append(path)
        return spans, empty

    def _report(
        self, folded: Folded, results: list[ShardResult], shards: int, workers: int
    ) -> None:
        """The shards' reports as one (the sequential build's fields) plus the cost per
        worker, and the checks a sequential build makes over all its logs."""
        report = self.build.report
        combine_reports(report, folded.reports)
        starts = [p.start_ns for p in folded.reports if p.start_ns is not None]
        ends = [p.end_ns for p in folded.reports if p.end_ns is not None]
        self.build.join_span(min(starts, default=None), max(ends, default=None))
        report.notes.extend(folded.notes)
        self._overlap(folded.reports)
        from aion_cli.times_apart import apart_warnings, joined

        messages = joined([r.times_apart[0] for r in results])
        agents = joined([r.times_apart[1] for r in results])
        report.warnings.extend(
            apart_warnings(self.opts, messages, agents, report.observation, self.config.timezone)
        )
        where = "Dask cluster" if self.opts.scheduler else f"{workers} worker processes"
        slowest = max((r.seconds for r in results), default=0.0)
        peak = max((r.peak_rss_mb for r in results), default=0.0)
        report.notes.append(
            f"built {shards} shards on {where} (slowest {slowest:.1f} s, peak memory per "
            f"worker {peak:.0f} MB; joined in {folded.seconds:.1f} s)"
        )
        if folded.graph_fallbacks:
            report.notes.append(built_twice_note(folded.graph_causes, shards))
        report.fold_seconds = folded.seconds
        report.workers = [
            {
                "shard": r.index,
                "logs": [p.name for p in self.groups[r.index]],
                **part_fields(self.parts[r.index]),
                "worker": r.worker,
                "seconds": round(r.seconds, 3),
                "peak_rss_mb": round(r.peak_rss_mb, 1),
                "detections_used": r.report.detections_used,
            }
            for r in sorted(results, key=lambda r: r.index)
        ]
        counts = counts_of(report)
        check_usable(
            report, counts, self.build.previous_manifest, lost=self._unread(report, counts)
        )

    def _unread(
        self, report: BuildReport, counts: DetectionCounts
    ) -> tuple[int, int, list[str]] | None:
        """What :func:`check_usable` needs to tell logs whose messages were all lost from
        logs that hold nobody: the messages their indexes hold on the detection topics (the
        logs opened again, only when no detection was read)."""
        if counts.read > 0:
            return None
        from aion_cli.formats.logs import open_logs

        with open_logs(list(self.build.logs), self.opts.log_format) as logset:
            expected = logset.total(report.detection_topics)
        return unread_detections(report, counts, expected, report.warnings)

    def _overlap(self, reports: list[BuildReport]) -> None:
        """The note a sequential build makes on logs whose first detections come before the
        continued map's data ends, from the shards' first detections (a shard builds apart
        from the map and makes none)."""
        firsts = [r.first_detection_ns for r in reports if r.first_detection_ns is not None]
        if firsts:
            self.build.note_overlap(min(firsts))


def _plan_streams(
    logs: list[Path],
    build: _Build,
    shards: list[tuple[tuple[Path, ...], tuple[int, int] | None, bool]],
    spans: list[tuple[Path, int, int]],
) -> tuple[list[dict[str, float]], bool, StaticTf]:
    """Per shard, the detection topics whose orientations varied before it
    (:mod:`aion_cli.shard_yaws`; a shard starts at its part's start, else at its logs' first
    message); whether the build will look nodes up in KD-trees (it has scene graphs); and
    the static transforms of all the logs, which one pass applies to every log
    (:func:`aion_cli.tf_feed.read_static_tf`). A continued map's lineage
    is checked against the logs' first scene graph here, where the shards cannot see the map
    (:meth:`aion_cli.build_stream.StreamStep.continue_on_logs`)."""
    from aion_cli.build_options import build_topics
    from aion_cli.formats.logs import open_logs
    from aion_cli.shard_yaws import shard_seeds, varied_by
    from aion_cli.tf_feed import read_static_tf

    opts = build.opts
    first = {path: start for path, start, _ in spans}
    starts: list[int | None] = []
    for group, part, _ in shards:
        known = [first[p] for p in group if p in first]
        starts.append(part[0] if part is not None else min(known, default=None))
    with open_logs(logs, opts.log_format) as logset:
        plan = build_topics(logset, opts)
        build.continue_on_logs(logset, plan, peek=True)
        kd_trees = bool(plan.graph) or opts.graph_file is not None
        static_tf = read_static_tf(logset, plan)
        if all(start is None for start in starts[1:]):
            return [{} for _ in shards], kd_trees, static_tf
        return shard_seeds(varied_by(logset, plan, opts), starts), kd_trees, static_tf


def _window_ns(config: ModelConfig) -> int:
    from aion_cli.engine.windows import window_ns

    return window_ns(config.window_s)


def _open_start(previous: MapState | None) -> int | None:
    """The start of a continued map's open window (None: a new map, or none open): what its
    shards' data may not reach back before (``shard_fold._check_order``), as a sequential
    build's batches may not (``build_stream._check_after_map``)."""
    if previous is None or previous.open_window is None:
        return None
    from aion_cli.engine.windows import window_ns

    return previous.open_window * window_ns(previous.config.window_s)
