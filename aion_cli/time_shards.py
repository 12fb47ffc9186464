"""Time shards: a long log cut at quiet moments, so that ``aion build --workers N`` shares it
out like logs that record different times.

A parallel build (:mod:`aion_cli.parallel_build`) learns groups of logs that share no time
window in separate processes and joins them in time order. A single long log (or a group of
logs that overlap in time) is one such group; here it is cut further, into *parts* of log time
``[lo, hi)``, each learnt by a worker that reads the whole log's TF, time rules and scene-graph
schedule but streams only its part (:class:`aion_cli.pipeline._Build` with ``part``). A part
then equals what a separate log holding exactly those messages would give, and the join is
exact for the same reasons. A cut is a window start ``W`` where:

* no detection lies in the :data:`QUIET_NS` (10 s) before ``W``: every track seen before
  ``W`` has ended by then (headings and linked tracks start over after a gap of 5 s / 2 s in
  one pass too). Where no detection *message* lies there, the index says so; a tracker that
  publishes empty messages at a fixed rate is probed instead: the window starts nearest to
  an even split are decoded (those 10 s only, in logs that can be read a few seconds at a
  time: indexed MCAP, ROS 1 bags, rosbag2);
* the part before ``W`` ends in the window just before ``W`` or, when that window holds no
  message of any topic, in the window before it: no window that one pass would observe lies
  between two parts for neither to close. The part's last window is one that holds a message
  of the topics that make the build's time span (detections, scene graphs, dynamic TF);
* such messages lie on both sides of ``W``, and detection messages too.

The times come from the logs' indexes (:meth:`formats.logs.LogSet.index_times`), and the
build's own time rules drop the same strays and out-of-range times first.
Among the candidates, the cuts split the detection messages into parts of about equal size.
Logs without such an index, or without a quiet moment, are not cut (the build says so).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.types import I64

if TYPE_CHECKING:
    from aion_cli.pipeline import BuildOptions

#: a detection message this close before a cut would carry a track across it
QUIET_NS = 10 * 10**9
#: window starts decoded per cut (nearest to the even split first) when only decoding can
#: tell whether a moment is quiet (a tracker publishing empty messages at a fixed rate)
PROBES_PER_CUT = 48
#: a build with fewer groups of logs than this many per worker (and two at least) cuts them
#: into time shards; one per worker measured faster than two on a 20-day log (each join
#: scores its shard's held days in the parent, one after the other: docs/SCALING.md)
SHARDS_PER_WORKER = 1

Shard = tuple[tuple[Path, ...], tuple[int, int] | None, bool]
"""A shard of a parallel build: its logs, its part of log time (None: all) and whether it is
the first part of its logs (whose report carries what reading the whole logs counted)."""


@dataclass(frozen=True)
class GroupTimes:
    """What the cuts of one group of logs are chosen from: the log times (sorted, strays and
    out-of-range times left out) of its detection messages and of every topic of the build's
    time span."""

    detections: I64
    span: I64
    recorded: I64  # windows holding a message of any topic
    graphs: I64 = field(default_factory=lambda: np.zeros(0, np.int64))  # scene-graph messages


def cut_times(
    times: GroupTimes,
    window_ns: int,
    parts: int,
    probe: Callable[[int], bool] | None = None,
) -> list[int]:
    """Up to ``parts - 1`` cut times (window starts, increasing; see the module docstring)
    that split the detection messages into parts of about equal size.

    ``probe(W)``: whether the detection messages of the 10 s before ``W`` hold no detection
    (decoded: a tracker that publishes empty messages at a fixed rate is quiet there although
    its messages go on). Without it only moments without detection messages are quiet; with
    it, the window starts nearest to each even split are probed too (at most
    :data:`PROBES_PER_CUT` of them per cut)."""
    det, span = times.detections, times.span
    if parts < 2 or det.size == 0 or span.size == 0:
        return []
    delta = np.int64(window_ns)
    windows = np.unique(span // delta)  # windows holding span messages
    last, following = windows[:-1], windows[1:]  # each, and the next such window
    right_after = (last + 1) * delta
    quiet = np.searchsorted(det, right_after - QUIET_NS) == np.searchsorted(det, right_after)
    # else one window later, if the window between holds no message at all
    later = (following >= last + 2) & ~np.isin(last + 1, times.recorded)
    found = [right_after[quiet], right_after[~quiet & later] + delta]
    if probe is not None:  # quiet or not only decoding can tell
        found.append(right_after[~quiet])
    cand = np.concatenate(found)
    known = np.arange(cand.size) < found[0].size + found[1].size
    order = np.argsort(cand, kind="stable")
    cand, known = cand[order], known[order]
    before = np.searchsorted(det, cand, "left")  # detection messages before each cut
    useful = (before > 0) & (before < det.size)  # detections on both sides
    cand, known, before = cand[useful], known[useful], before[useful]
    targets = det.size * np.arange(1, parts, dtype=np.float64) / parts
    probed: dict[int, bool] = {}
    cuts = set()
    for target in targets.tolist():
        budget = PROBES_PER_CUT
        for i in np.argsort(np.abs(before - target), kind="stable").tolist():
            at = int(cand[i])
            if not known[i]:
                if at not in probed:
                    if budget == 0 or probe is None:
                        continue
                    budget -= 1
                    probed[at] = probe(at)
                if not probed[at]:
                    continue
            cuts.add(at)
            break
    return sorted(cuts)


def split_groups(
    groups: list[tuple[Path, ...]],
    opts: BuildOptions,
    window_ns: int,
    workers: int,
    tolerance: float,
    whole: frozenset[int],
    explain: bool = True,
) -> tuple[list[Shard], list[str]]:
    """The shards of a parallel build's groups of logs (each group's logs share no time window
    with another's) for ``workers`` processes: each group whole or, while there are fewer
    groups than :data:`SHARDS_PER_WORKER` per worker (two at least), cut into parts in
    proportion to its detection messages, unless the scene graph changes inside a part after
    the first (:func:`aion_cli.shard_graphs.changing_part`; ``tolerance``: the model's
    ``stable_move_tolerance``); and the report's notes on the cuts. The groups at indices
    ``whole`` (kept together across sessions, :func:`aion_cli.shard_graphs.kept_together`)
    are never cut, nor their times read. Without ``explain`` (workers not asked for) a group
    left whole is no news: only the cuts made are noted."""
    target = SHARDS_PER_WORKER * max(workers, 2)
    if len(groups) >= target or len(whole) == len(groups):
        return [(group, None, True) for group in groups], []
    times = [
        None if k in whole else group_times(group, opts, window_ns)
        for k, group in enumerate(groups)
    ]
    counts = [t.detections.size if t is not None else 0 for t in times]
    total = sum(counts)
    shards: list[Shard] = []
    notes = []
    for group, found, count in zip(groups, times, counts, strict=True):
        want = max(1, round(target * count / total)) if total else 1
        cuts, changing, slow = (
            _group_cuts(group, opts, found, window_ns, want, tolerance)
            if found and want > 1
            else ([], None, [])
        )
        names = ", ".join(p.name for p in group[:3]) + (", ..." if len(group) > 3 else "")
        if slow and not cuts and changing is None and explain:
            notes.append(
                f"{names}: not cut into time shards: no pause in the detection messages, and "
                f"{slow[0].name}{' (and others)' if len(slow) > 1 else ''} has no chunk index "
                "(truncated, or written without one), so a quiet moment cannot be found by "
                "decoding a few seconds; built in sequence (aion info LOG says whether a log "
                "is truncated)"
            )
        if changing is not None and explain:
            notes.append(
                f"{names}: not cut into time shards: {'their' if len(group) > 1 else 'its'} "
                f"scene graph changes after "
                f"{_iso(changing[0])} (places added, removed or moved), which a part built "
                "apart cannot know, so that part would be learnt twice; built in sequence"
            )
        if not cuts:
            shards.append((group, None, True))
            continue
        shards += [(group, part, k == 0) for k, part in enumerate(parts_of(cuts))]
        shown = ", ".join(_iso(t) for t in cuts[:3]) + (", ..." if len(cuts) > 3 else "")
        notes.append(f"{names}: cut into {len(cuts) + 1} time shards at quiet moments ({shown})")
    return shards, notes


def _group_cuts(
    group: tuple[Path, ...],
    opts: BuildOptions,
    times: GroupTimes,
    window_ns: int,
    parts: int,
    tolerance: float,
) -> tuple[list[int], tuple[int, int] | None, list[Path]]:
    """:func:`cut_times` of one group, probing by decoding where its logs can be read a few
    seconds at a time (:meth:`formats.logs.LogSet.skips_by_time`); none, and the part whose
    scene graph changes, where one does (:func:`aion_cli.shard_graphs.changing_part`); and
    the logs that kept it from probing (read from their start), for the note that says why a
    group of logs with an empty tracker message every few seconds was not cut."""
    from aion_cli.formats.logs import open_logs
    from aion_cli.shard_graphs import changing_part

    with open_logs(list(group), opts.log_format) as logset:
        probe = _decoded_quiet(logset, opts)
        slow = logset.read_from_start() if probe is None else []
        cuts = cut_times(times, window_ns, parts, probe)
        changing = (
            changing_part(logset, opts, times.graphs, parts_of(cuts), tolerance) if cuts else None
        )
    return ([], changing, slow) if changing is not None else (cuts, None, slow)


def _decoded_quiet(logset: Any, opts: BuildOptions) -> Callable[[int], bool] | None:
    """A probe for :func:`cut_times`: whether the detection messages of the 10 s before a
    time decode to no detection at all (with the build's own adapters; a message that does
    not decode gives none, as in the build). None where reading those seconds would mean
    reading the logs from their start."""
    if not logset.skips_by_time():
        return None
    from aion_cli.build_options import build_topics
    from aion_cli.detection_adapters import log_adapters

    plan = build_topics(logset, opts)
    adapters, factory, _ = log_adapters(logset, plan.detections, plan.mappings)
    topics = plan.names("detections")

    def quiet(at: int) -> bool:
        lo = at - QUIET_NS
        by_type: dict[tuple[str, str, str], list[Any]] = {}
        for msg in logset.messages(topics, (lo, at)):
            if msg.log_time_ns >= at:
                break  # the stream is in log-time order
            if msg.log_time_ns >= lo:
                by_type.setdefault((msg.topic, msg.msgtype, msg.encoding), []).append(msg)
        for key, messages in by_type.items():
            adapter = adapters.get(key) or factory(*key)
            if len(adapter.decode(messages, on_error="skip")):
                return False
        return True

    return quiet


def part_fields(part: tuple[int, int] | None) -> dict[str, str]:
    """A time shard's part in the report's worker rows (its inner bounds, UTC)."""
    if part is None:
        return {}
    from aion_cli.engine.mapper import MAX_TIME_NS, MIN_TIME_NS

    lo, hi = part
    return {
        "from": _iso(lo) if lo > MIN_TIME_NS else "start",
        "to": _iso(hi) if hi <= MAX_TIME_NS else "end",
    }


def _iso(t_ns: int) -> str:
    from aion_cli.engine.time_text import utc_text

    return utc_text(t_ns)


def parts_of(cuts: list[int]) -> list[tuple[int, int]]:
    """The parts ``[lo, hi)`` that ``cuts`` make of all log time."""
    from aion_cli.engine.mapper import MAX_TIME_NS, MIN_TIME_NS

    return list(pairwise([MIN_TIME_NS, *cuts, MAX_TIME_NS + 1]))


def group_times(
    logs: tuple[Path, ...], opts: BuildOptions, window_ns: int
) -> GroupTimes | None:
    """:class:`GroupTimes` of ``logs`` from their indexes, with the topics the build would
    choose; None when an index cannot give them (the logs are then not cut)."""
    from aion_cli.build_options import build_topics
    from aion_cli.formats.logs import open_logs
    from aion_cli.log_times import TopicTimes

    with open_logs(list(logs), opts.log_format) as logset:
        plan = build_topics(logset, opts)
        detections = plan.names("detections")
        graphs = plan.names("graph") if opts.graph_file is None else set()
        tf = {t for t in plan.names("tf") if not t.endswith("_static")} if plan.tf else set()
        span_topics = detections | graphs | tf
        if not detections:
            return None
        indexed = logset.index_times(span_topics)
        recorded = logset.recorded_windows(window_ns)
        recordings = list(logset.recording_times().values())
    if indexed is None:
        return None
    times = TopicTimes(span_topics)
    times.add_stream(indexed)
    checked = times.check(span_topics, recordings)
    det = [_kept(indexed.of(t), checked.strays.get(t)) for t in indexed.topics if t in detections]
    joined = np.sort(np.concatenate(det)) if det else np.zeros(0, np.int64)
    graph = [_kept(indexed.of(t), checked.strays.get(t)) for t in indexed.topics if t in graphs]
    return GroupTimes(
        joined,
        np.sort(checked.span_times),
        np.asarray(recorded, np.int64),
        np.sort(np.concatenate(graph)) if graph else np.zeros(0, np.int64),
    )


def _kept(t: np.ndarray, strays: I64 | None) -> I64:
    """One topic's log times from an index without out-of-range and stray times."""
    from aion_cli.log_times import in_range_mask

    t = np.asarray(t)
    t = t[in_range_mask(t)].astype(np.int64)
    if strays is not None and strays.size:
        t = t[~np.isin(t, strays)]
    return t
