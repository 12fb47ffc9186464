"""What ``aion evaluate holdout`` tells the reader about the test logs beside the scores
(:mod:`aion_cli.evaluation.holdout`): the logs' own notes, windows a moving robot observed,
test detections inside or before the map's time span, test hours the map never observed, and
why the rows of aion and aion static agree."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from aion_cli.held_out import HeldOut


def unobserved_hours_note(manifest: dict[str, Any], hours: list[int]) -> str | None:
    """:func:`aion_cli.forecast_notes.unobserved_hours` of the test's hours (their starts,
    UNIX ns): those whose hour of the day the map never observed, where aion's forecast (and
    its hour-of-day profile) is extrapolated, not measured."""
    if not manifest or not hours:
        return None
    from aion_cli.forecast_notes import unobserved_hours
    from aion_cli.manifest import Manifest

    return unobserved_hours(Manifest.from_dict({"state": {}, **manifest}), hours, "test hours")


def time_warnings(held: HeldOut, manifest: dict[str, Any]) -> list[str]:
    """Test detections inside the map's own time span (the map learnt from that time, from
    them too if its logs hold them, or from other people then, a dataset's split: the scores
    are in-sample) or before it (the map is judged on the past): a warning each, as the scores
    are then not those of a forecast."""
    warnings: list[str] = []
    span = manifest.get("time_span") or {}
    start, end = span.get("start_ns"), span.get("end_ns")
    t = held.batch.t_ns
    if isinstance(start, int) and isinstance(end, int) and len(t):
        inside = int(np.count_nonzero((t >= start) & (t <= end)))
        if inside:
            warnings.append(
                f"{inside:,} of {len(t):,} test detections lie within the map's own time span: "
                "the map learnt from that time (from these detections too, if its logs hold "
                "them), so the scores are not a forecast's (build the map from logs before the "
                "test logs only)"
            )
        before = int(np.count_nonzero(t < start))
        if before:
            warnings.append(
                f"{before:,} of {len(t):,} test detections lie before the map's own time span: "
                "the map learnt from later logs, so it is judged on the past, not on what it "
                "forecasts (build the map from logs before the test logs only)"
            )
    return warnings


def held_out_notes(held: HeldOut, manifest: dict[str, Any], sensor_range: float) -> list[str]:
    """What the reader should know about the test: the logs' own notes, windows left out of
    the activity."""
    notes = [n for n in held.notes if "scene graph" not in n]  # the map has its own
    static = all_static_note(manifest)
    if static is not None:  # why the rows of aion and aion static agree
        notes.append(f"aion's figures are those of its static rates: {static}")
    robot = int(np.count_nonzero(~held.fixed))
    if robot:
        notes.append(
            f"{robot:,} of {held.windows.size:,} test windows were observed by a moving robot: "
            "there the activity sums the map's places within its sensor range "
            f"({sensor_range:g} m) then"
        )
    return notes


def all_static_note(manifest: dict[str, Any]) -> str | None:
    """:func:`aion_cli.forecast_notes.all_static` of a map's manifest (None without one)."""
    if not manifest:
        return None
    from aion_cli.forecast_notes import all_static
    from aion_cli.manifest import Manifest

    return all_static(Manifest.from_dict({"state": {}, **manifest}))
