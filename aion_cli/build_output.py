"""Writing a build's map file: the state's arrays and the typed manifest (``aion build``).

The manifest (:class:`aion_cli.manifest.Manifest`) records the config, the inputs of every
build, the time span, the counts over every build and of this one, where the graph and the
observation came from, the default time zone of ``predict`` / ``plan`` / ``export`` and the
model families in use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from aion_cli.manifest import InputLog, Manifest, add_counts, part_spans
from aion_cli.mapquery import state_counts
from aion_cli.recording_twins import recording_entry, recordings_after

if TYPE_CHECKING:
    from aion_cli.build_report import BuildReport
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.state import MapState


def cumulative_counts(report: BuildReport, previous: Manifest | None) -> dict[str, Any]:
    """Detections read / used / dropped over every build of the map, and a fixed sensor's
    logs' own time in windows (``recording_windows``, the union over every build's logs: a
    window the previous builds' logs reached, ``recording_reach``, is not counted again; the
    first window they recorded, ``recording_first``, lets a merge do the same), and the
    detection messages that held no detection (``empty_messages``). The reach includes the
    windows a declared span filled after the last message: a continuing build's spans fill
    from the window after them."""
    from aion_cli.fixed_sensor import recording_window_count

    new = report.to_dict()["detections"]
    new["empty_messages"] = report.empty_messages  # a tracker that publishes them is not silent
    after = previous.recording_reach if previous is not None else None
    if report.fixed_windows is not None and report.recording_spans:
        new["recording_windows"] = recording_window_count(report.recording_spans, after)
        reach = max(last for _, _, last in report.recording_spans)
        if report.declared_end_ns is not None:  # a declared span after the last message
            reach = max(reach, (report.declared_end_ns - 1) // report.fixed_windows[3])
        new["recording_reach"] = reach if after is None else max(after, reach)
        new["recording_first"] = min(first for _, first, _ in report.recording_spans)
    if previous is None:
        return new
    return add_counts(previous.counts, new)


def write_build(
    state: MapState,
    config: ModelConfig,
    inputs: tuple[InputLog, ...],
    report: BuildReport,
    previous: Manifest | None,
    map_frame: str | None = None,
    declared: tuple[tuple[int, int], ...] = (),
) -> None:
    """Write ``report.output`` (the caller holds its lock) and fill the report's counts and
    size. ``map_frame``: the frame the positions are in, recorded in the manifest;
    ``declared``: the ``--observed`` spans (a note counts those left outside the logs' time)."""
    from aion_cli.build_plausibility import far_from_graph_of
    from aion_cli.derived_seal import seal
    from aion_cli.engine.family_summary import family_summary
    from aion_cli.fixed_sensor import DECLARED, map_observation_text, share_text, silent_advice
    from aion_cli.forecast_notes import observed_hours
    from aion_cli.formats.mapfile import write_map
    from aion_cli.observed_spans import outside_logs_note

    arrays, meta = state.to_arrays(lazy=True)
    stats = state_counts(state)
    far = far_from_graph_of(state, stats)
    if far is not None:
        report.warnings.append(far)
    if state.graph is not None and stats["nodes"] == 0:
        report.warnings.append(
            "the scene graph's navigational layer has no places: every detection stays on "
            "hash cells (see --nav-layer; aion info LOG lists the graph's layers)"
        )
    if state.graph is None and report.graph_source == "log" and report.graph_topics:
        topics = ", ".join(report.graph_topics)
        report.warnings.append(
            f"no scene graph of {topics} could be used (see the warnings above): the map has "
            "hash cells only, no places"
        )
    report.cells = stats["cells"]
    report.nodes = stats["nodes"]
    report.nodes_with_flow = stats["nodes_with_flow"]
    report.bound_cells = stats["bound_cells"]
    report.windows = stats["windows"]
    observation = map_observation_text(
        [previous.observation, report.observation] if previous else [report.observation],
        state.observation,
        state.window_ns,
    )
    recording = _recording_windows(report)
    fixed = report.fixed_windows
    counts = cumulative_counts(report, previous)
    report.map_detections = (int(counts.get("read", 0)), int(counts.get("used", 0)))
    share = None if not recording or fixed is None else min(1.0, fixed[0] / recording)
    # this build's own logs had spans declared (its text says so)
    if share is not None and share < 0.5 and DECLARED not in report.observation:
        report.notes.append(
            f"the fixed sensor observed {share_text(share)} of its logs' time (the windows in "
            "which a log recorded a message, each log from its first message to its last; the "
            f"rest is unknown, not empty): {silent_advice(counts)}"
        )
    if declared and fixed is not None:
        from aion_cli.log_observed import fill_end, fill_start

        part, delta = state.deferred is not None, fixed[3]
        start, end = fill_start(declared, delta, previous, part), fill_end(declared, delta, part)
        args = (declared, report.recording_spans, delta, start)
        outside = (  # a part's: the merge fills them
            outside_logs_note(*args, "aion merge fills them as it joins the parts", end)
            if part else outside_logs_note(*args, end=end)
        )
        if outside is not None:
            report.notes.append(outside)
    manifest = Manifest(
        state=meta,
        config=config.to_dict(),
        inputs=inputs,
        start_ns=report.start_ns,
        end_ns=report.end_ns,
        counts=counts | stats,
        last_build=report.to_dict()["detections"],
        graph_source=report.graph_source,
        observation=observation,
        timezone=config.timezone,
        families=family_summary(state),
        merged_from=previous.merged_from if previous is not None else (),
        lineage=previous.lineage if previous is not None else None,
        map_frame=map_frame,
        observed_spans=part_spans(previous, declared) if state.deferred is not None else (),
        recordings=recordings_after(previous, recording_entry(report.sketch, report.inputs)),
    )
    out = report.output
    write_map(out, arrays, manifest.to_dict(), lock=False, seal=seal)
    report.map_bytes = out.stat().st_size
    report.hours_observed = observed_hours(manifest.families, manifest.config, config.timezone)
    report.timezone = config.timezone


def _recording_windows(report: BuildReport) -> int | None:
    """This build's logs' own time in windows (each file from its first to its last recorded
    window: the time between two files is not the sensor's to observe); None without a fixed
    sensor."""
    from aion_cli.fixed_sensor import recording_window_count

    if report.fixed_windows is None or not report.recording_spans:
        return None
    return recording_window_count(report.recording_spans)
