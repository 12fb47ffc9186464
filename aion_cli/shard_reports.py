"""The reports of a parallel build's shards as the one report a sequential build writes.

Counts add (detections read and used, drops, headings and speeds, header stamps off their log
times (warned of from the sums, once), scene-graph messages and skips, TF failures, per topic);
notes and warnings are kept once each; the observation source is the first shard's, with a
warning when the shards' sources differ, and a fixed sensor's observed windows are summed into
one line. The scene-graph counts note is written once, from the sums
(:func:`aion_cli.graph_notes.graph_counts_note`), and the parent stops, as one pass does, only
when no shard could decode any of its scene graphs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aion_cli.build_observation import NO_TRAJECTORY_NOTE, SILENT_NOTE, silent_note
from aion_cli.build_plausibility import FAST_PEOPLE_WARNING, fast_people_warning
from aion_cli.build_report import BuildReport
from aion_cli.detection_counts import TopicCounts
from aion_cli.errors import MessageDecodeError
from aion_cli.fixed_sensor import (
    DECLARED,
    FIXED_SENSOR_OVER,
    UNPOSED_NOTE,
    fixed_sensor_text,
    unposed_note,
)
from aion_cli.graph_notes import (
    DAMAGED_GRAPHS_NOTE,
    GRAPH_COUNTS_NOTE,
    NO_GRAPH_NOTES,
    graph_counts_note,
)
from aion_cli.observed_spans import LOGS_OBSERVED_NOTE, OBSERVED_NOTE, observed_note
from aion_cli.stamp_warnings import FAR_STAMPS, OFF_STAMPS, stamp_warnings


def counts_of(report: BuildReport) -> Any:
    """The detection counts of ``report`` for the usable-detections check: read, used, the
    drops by reason and each topic's messages (from the shards' combined per-topic figures;
    without them the check of a parallel build said "in the 0 messages" of a topic of
    thousands)."""
    from aion_cli.detection_feed import DetectionCounts

    counts = DetectionCounts()
    counts.read = report.detections_read
    counts.used = report.detections_used
    for topic, info in report.detection_decoding.items():
        mine = counts.topic(topic)
        mine.messages = int(info.get("messages", 0) or 0)
        mine.undecodable = int(info.get("undecodable", 0) or 0)
    for stats in report.by_topic.values():
        for reason, n in (stats.get("dropped") or {}).items():
            counts.dropped[reason] += int(n)
    for value, n in report.filter_seen.items():
        counts.see(value, n)
    return counts


def declared_beside_robot(parts: list[BuildReport]) -> bool:
    """Whether the shards include a robot's and a fixed sensor's built with ``--observed``:
    one pass ignores the declared spans beside a robot's trajectory (its poses say what was
    observed), which a fixed sensor's shard applies, so such shards do not join into the map
    one pass makes."""
    kinds = {p.observation.split(" ")[0] for p in parts}
    return "fixed" in kinds and len(kinds) > 1 and any(DECLARED in p.observation for p in parts)


def combine_reports(out: BuildReport, parts: list[BuildReport]) -> None:
    """Fill ``out`` (the parent's report) from the shards' reports, in time order."""
    if not parts:
        return
    kinds = {p.observation.split(" ")[0] for p in parts}
    # robot shards beside fixed-sensor ones observe as one pass does (a log without poses
    # is a fixed sensor: fixed_sensor.unposed_log_windows), except for --observed, which one
    # pass ignores beside a robot's trajectory and a fixed sensor's shard applies
    robots = kinds - {"fixed"}
    mixed = (
        "fixed" in kinds
        and robots in ({"tf"}, {"scene-graph"})
        and not any(DECLARED in p.observation for p in parts)
    )
    if len(kinds) > 1 and not mixed:
        out.warnings.append(
            "the logs' observation sources differ (" + ", ".join(sorted(kinds)) + "): each "
            "group of logs used its own"
        )
    out.observation = parts[0].observation
    if mixed:
        out.observation = _robot_and_fixed(parts)
        out.notes.append(unposed_note(_unposed_logs(parts)))
    fixed = [p.fixed_windows for p in parts if p.fixed_windows is not None]
    if fixed and len(kinds) == 1 and out.observation.startswith(FIXED_SENSOR_OVER):
        count = sum(f[0] for f in fixed)
        out.fixed_windows = (count, min(f[1] for f in fixed), max(f[2] for f in fixed), fixed[0][3])
        out.recording_spans = [span for p in parts for span in p.recording_spans]
        declared = any(DECLARED in p.observation for p in parts)
        out.observation = fixed_sensor_text(*out.fixed_windows, declared=declared)
    for p in parts:
        out.detections_read += p.detections_read
        out.detections_used += p.detections_used
        _add(out.dropped, p.dropped)
        _add(out.headings, p.headings)
        out.speed_micro += p.speed_micro
        out.speed_n += p.speed_n
        out.empty_messages += p.empty_messages
        _add(out.filter_seen, p.filter_seen)
        out.graph_messages += p.graph_messages
        out.graph_skipped += p.graph_skipped
        out.graph_decoded += p.graph_decoded
        out.graphs_skipped_identical += p.graphs_skipped_identical
        out.graphs_read_by_changes += p.graphs_read_by_changes
        out.graphs_skipped_period += p.graphs_skipped_period
        out.tf_undecodable += p.tf_undecodable
        out.sketch.merge(p.sketch)
        for topic, stats in p.by_topic.items():
            mine = out.by_topic.setdefault(topic, {})
            _add_nested(mine, stats)
        for topic, stats in p.time_dropped.items():
            _add(out.time_dropped.setdefault(topic, {}), stats)
        for topic, info in p.detection_decoding.items():
            have = out.detection_decoding.get(topic)
            if have is None:
                out.detection_decoding[topic] = dict(info)
            else:
                _add_nested(have, {k: v for k, v in info.items() if isinstance(v, int)})
        for line in p.notes:
            if line.startswith((OBSERVED_NOTE, LOGS_OBSERVED_NOTE, SILENT_NOTE)):  # added up below,
                continue  # one note as one pass gives
            if mixed and (line.startswith(NO_TRAJECTORY_NOTE) or UNPOSED_NOTE in line):
                continue  # the logs beside the robot's: named in one note above
            if line not in out.notes and not line.startswith(GRAPH_COUNTS_NOTE):
                out.notes.append(line)
        for line in p.warnings:
            if line in out.warnings or line.startswith(FAST_PEOPLE_WARNING):
                continue
            if FAR_STAMPS not in line and OFF_STAMPS not in line:  # from the sums, below
                out.warnings.append(line)
        for topic, counts in p.stamp_counts.items():
            mine = out.stamp_counts.setdefault(topic, TopicCounts())
            mine.add_stamps(counts)
        if p.graph_source != "none":
            out.graph_source = p.graph_source
        out.graph_layer = out.graph_layer or p.graph_layer
        out.dsg_version = out.dsg_version or p.dsg_version
        out.graph_period_ns = p.graph_period_ns or out.graph_period_ns
    if out.graph_source != "none":  # a shard read a graph: the map has it, as one pass's
        out.notes = [n for n in out.notes if not n.startswith(NO_GRAPH_NOTES)]
    added = [p.observed_added for p in parts if p.observed_added is not None]
    if added:
        delta = next((p.fixed_windows[3] for p in parts if p.fixed_windows is not None), 0)
        out.observed_added = sum(added)
        files = len({path for p in parts for path, _, _ in p.recording_spans})  # a cut log: 1
        from_logs = any(p.observed_from_logs for p in parts)
        out.notes.append(observed_note(out.observed_added, delta, files, from_logs))
    ends = [p.declared_end_ns for p in parts if p.declared_end_ns is not None]
    out.declared_end_ns = max(ends, default=None)  # the last shard's: where the map's reach ends
    silent = [p.silent_windows for p in parts if p.silent_windows is not None]
    if silent:
        out.silent_windows = (sum(n for n, _ in silent), silent[0][1])
        if out.silent_windows[0]:
            out.notes.append(silent_note(*out.silent_windows))
    note = graph_counts_note(out)  # the shards' counts added up
    if note is not None:
        out.notes.append(note)
    out.warnings.extend(stamp_warnings(out.stamp_counts))  # from the shards' stamps added up
    fast = fast_people_warning(out)  # from the shards' speeds added up
    if fast is not None:
        out.warnings.append(fast)
    if out.graph_skipped and not out.graph_messages:  # as one pass stops (check_skips)
        first = next((n for n in out.notes if DAMAGED_GRAPHS_NOTE in n), "")
        raise MessageDecodeError(
            f"none of the {out.graph_skipped:,} scene-graph messages could be decoded"
            + (f": {first}" if first else ""),
            hint="check --dsg-version and --nav-layer, or build without the graph topic",
        )
    out.detection_topics = sorted({t for p in parts for t in p.detection_topics})
    out.graph_topics = sorted({t for p in parts for t in p.graph_topics})


def _robot_and_fixed(parts: list[BuildReport]) -> str:
    """The observation of robot shards beside fixed-sensor ones, as one pass says it: the
    robot's trajectory + the fixed sensors' windows added up."""
    robot = next(p.observation for p in parts if not p.observation.startswith(FIXED_SENSOR_OVER))
    robot = robot.split(" + ")[0]  # a robot shard's own logs beside it: added up below
    fixed = [p.fixed_windows for p in parts if p.fixed_windows is not None]
    fixed += [p.unposed[1] for p in parts if p.unposed is not None]
    if not fixed:
        return robot
    count = sum(f[0] for f in fixed)
    first, last = min(f[1] for f in fixed), max(f[2] for f in fixed)
    return f"{robot} + " + fixed_sensor_text(count, first, last, fixed[0][3])


def _unposed_logs(parts: list[BuildReport]) -> list[str]:
    """The logs of robot and fixed-sensor shards that are read as fixed sensors, in time
    order, as one pass names them: a fixed-sensor shard's logs, a robot shard's unposed."""
    names: list[str] = []
    for p in parts:
        if p.unposed is not None:
            names += p.unposed[0]
        elif p.observation.startswith(FIXED_SENSOR_OVER):
            names += [Path(s[0]).name for s in sorted(p.recording_spans, key=lambda s: s[1])]
    return list(dict.fromkeys(names))  # a log cut into time shards is named once


def _add(into: dict[str, int], more: dict[str, int]) -> None:
    for key, value in more.items():
        into[key] = into.get(key, 0) + int(value)


def _add_nested(into: dict[str, Any], more: dict[str, Any]) -> None:
    for key, value in more.items():
        if isinstance(value, dict):
            _add_nested(into.setdefault(key, {}), value)
        elif isinstance(value, bool) or not isinstance(value, int | float):
            into.setdefault(key, value)
        else:
            into[key] = into.get(key, 0) + value



def built_twice_note(causes: list[str], shards: int) -> str:
    """The note on the shards a parallel build learnt again in sequence because their scene
    graph bound cells, or moved places, otherwise than one pass would have: how many, and
    why (each ``causes`` item one shard's :attr:`~aion_cli.engine.join_blockers.JoinBlock.cause`,
    counted when they differ)."""
    counts: dict[str, int] = {}
    for cause in causes:
        counts[cause] = counts.get(cause, 0) + 1
    why = " and ".join(
        cause if len(counts) == 1 else f"{cause} ({n})" for cause, n in counts.items()
    )
    return (
        f"{len(causes)} of {shards} shards {'was' if len(causes) == 1 else 'were'} built twice "
        "(in a worker, then in sequence) "
        f"because of {why}, which a shard built apart cannot know; for logs whose scene graph "
        "changes as they go (a live Hydra stream) --workers 1 is faster (docs/SCALING.md)"
    )
