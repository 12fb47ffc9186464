"""Writing a merged map (``aion merge``'s last step): the map file and the report's figures.

:func:`write_merged` takes the folded, bound state from :func:`aion_cli.merging.merge_map_files`
and writes it atomically with a manifest that accounts for every input map: the span, the
detection counts added in their logs' time order (windows where two maps meet counted once),
the observation, zone, frame and recordings, and fills the report's figures. It is apart from
:mod:`aion_cli.merging`, which reads, checks and folds the maps, because the manifest of a
merged map is one job the fold never needs: it takes only the merged state, the inputs and
their logs.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from aion_cli.manifest import InputLog, Manifest, add_counts
from aion_cli.merge_frames import common_frame, frame_warning
from aion_cli.merge_report import MergedInput, MergeReport

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState
    from aion_cli.merging import _Input


def write_merged(
    merged: MapState, maps: list[_Input], inputs: tuple[InputLog, ...], report: MergeReport
) -> None:
    """The merged map file (atomic; the caller holds the output's lock) and the report's
    figures."""
    from aion_cli.build_plausibility import far_from_graph_of
    from aion_cli.derived_seal import seal
    from aion_cli.engine.family_summary import family_summary
    from aion_cli.fixed_sensor import map_observation_text
    from aion_cli.forecast_notes import observed_hours
    from aion_cli.formats.mapfile import write_map
    from aion_cli.mapquery import state_counts

    starts = [m.manifest.start_ns for m in maps if m.manifest.start_ns is not None]
    starts += [] if report.start_ns is None else [report.start_ns]  # the first part's spans'
    ends = [m.manifest.end_ns for m in maps if m.manifest.end_ns is not None]
    tail = report.end_ns  # where the parts' spans after their logs end (fill_declared_tail)
    ends += [] if tail is None else [tail - 1]  # the last instant, as one build's
    report.start_ns = min(starts) if starts else None
    report.end_ns = max(ends) if ends else None
    counts: dict[str, Any] = {}
    # in the order of their logs' time, so that the windows in which two meet count once
    for m in sorted(maps, key=lambda m: _recording_first(m.manifest.counts)):
        c = m.manifest.counts
        part = {
            "read": int(c.get("read", 0)),
            "used": int(c.get("used", 0)),
            "dropped": dict(c.get("dropped", {})),
        }
        for key in ("recording_windows", "recording_reach", "recording_first", "empty_messages"):
            if key in c:  # add_counts checks them
                part[key] = c[key]
        counts = add_counts(counts, part, meet=True)
    if tail is not None and type(counts.get("recording_reach")) is int:  # as one build's
        counts["recording_reach"] = max(counts["recording_reach"], (tail - 1) // merged.window_ns)
    stats = state_counts(merged)
    frames = frame_warning([(m.name, m.manifest.map_frame) for m in maps])
    if frames is not None:
        report.warnings.append(frames)
    far = far_from_graph_of(merged, stats)
    if far is not None:  # a --graph FILE of another site, say: a warning, as build's
        report.warnings.append(far)
    observation = map_observation_text(
        [m.manifest.observation for m in maps], merged.observation, merged.window_ns
    )
    arrays, meta = merged.to_arrays(lazy=True)
    manifest = Manifest(
        state=meta,
        config=merged.config.to_dict(),
        inputs=inputs,
        start_ns=report.start_ns,
        end_ns=report.end_ns,
        counts=counts | stats,
        graph_source=f"merge: {report.graph_source}",
        observation=observation,
        # the merged config's spelling where the maps name one zone in two (Etc/UTC, UTC)
        timezone=zones.pop() if len(zones := {m.manifest.timezone for m in maps}) == 1
        else merged.config.timezone,
        families=family_summary(merged),
        merged_from=tuple(m.file.to_dict() for m in maps),
        lineage=report.lineage,
        map_frame=common_frame([m.manifest.map_frame for m in maps]),
        recordings=tuple(r for m in maps for r in m.manifest.recordings),  # recording_twins
    )
    # the caller holds the lock; the seal binds the derived members to the others
    write_map(report.output, arrays, manifest.to_dict(), lock=False, seal=seal)
    report.inputs = [
        MergedInput(
            m.file, m.manifest.start_ns, m.manifest.end_ns, len(m.manifest.inputs), m.detections
        )
        for m in maps
    ]
    report.detections = int(merged.accepted)
    report.logs = len(inputs)
    for key in ("cells", "nodes", "nodes_with_flow", "bound_cells", "windows"):
        setattr(report, key, int(stats[key]))
    report.map_bytes = report.output.stat().st_size
    report.hours_observed = observed_hours(
        manifest.families, manifest.config, merged.config.timezone
    )
    report.timezone = merged.config.timezone


def _recording_first(counts: dict[str, Any]) -> float:
    """A map's first window of its logs' own time (infinite when its manifest has none)."""
    first = counts.get("recording_first")
    return float(first) if type(first) is int else math.inf
