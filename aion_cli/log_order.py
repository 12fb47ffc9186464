"""Logs added to a continued map in time order: the refusal of data before the map's open
window (:func:`check_after_open`, :func:`out_of_order_error`; :func:`other_clock_error` when
the logs' own clock is a simulation's), the note on logs that start before the map's data
ends (:func:`overlap_note`), and the warning on logs that repeat each other's detections
(:func:`overlap_warnings`).

Split from :mod:`aion_cli.log_times` (which log times a build can trust)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from aion_cli.engine.time_text import utc_ends, utc_text
from aion_cli.engine.types import I64
from aion_cli.errors import InputError, path_word

if TYPE_CHECKING:
    from pathlib import Path

    from aion_cli.log_twins import AdapterOf


def other_clock_error(
    names: str, log_start_ns: int | None, open_start: int, stamped_ns: int | None = None
) -> InputError | None:
    """The refusal of logs (``names``) out of time order for a map that closed every window
    before ``open_start`` on the wall clock, when their own log times (from ``log_start_ns``)
    are a simulation's clock from 0: the logs were not given out of order, their clock and
    their messages' header stamps (from ``stamped_ns``) are two clocks, and the windows come
    from the stamps but the order of the logs from the log times. None when that is not so
    (a wall-clock log, or a map on the simulation's clock too): the order is the reason."""
    from aion_cli.stamp_warnings import SIM_TIME_BEFORE_NS

    if log_start_ns is None or not log_start_ns < SIM_TIME_BEFORE_NS <= open_start:
        return None
    stamped = "" if stamped_ns is None else f" (theirs are stamped from {utc_text(stamped_ns)})"
    return InputError(
        f"the log times of {names} start at {utc_text(log_start_ns)}: their clock is not wall "
        "time but, it seems, a simulation's clock from 0 (use_sim_time), while the map's "
        "windows come from the messages' header stamps, on the wall clock; it has closed "
        f"every window before {utc_text(open_start)}{stamped}, and such log times cannot tell "
        "the order of the logs' stamps; nothing was added",
        hint="add the logs one at a time in the order of their stamps (aion build FIRST.mcap "
        "-o MAP.aion, then aion build NEXT.mcap --map MAP.aion), or record them with the "
        "wall clock",
    )


def check_after_open(
    t_ns: I64,
    open_start: int,
    what: str,
    map_inputs: list[str],
    logs: Sequence[Path],
    map_name: str,
    log_start_ns: int | None = None,
    zone: str = "UTC",
) -> None:
    """A continued map (``map_name``, built from ``map_inputs``) has closed every window before
    its open one, which starts at ``open_start``: ``what``s of ``logs`` there (times ``t_ns``:
    detection stamps, scene-graph times) would be lost (``before_window``) and yet the logs
    recorded as added, so they could never be added again. :class:`InputError` instead,
    before anything is written; :func:`other_clock_error` when the logs' own log times (from
    ``log_start_ns``) are a simulation's clock and the map's windows are not. ``zone``: the
    map's, which the hint's rebuild keeps (:func:`out_of_order_error`)."""
    early = int(np.count_nonzero(t_ns < open_start))
    if early == 0:
        return
    names = ", ".join(p.name for p in logs)
    clocks = other_clock_error(names, log_start_ns, open_start, int(t_ns.min()))
    if clocks is not None:
        raise clocks
    raise out_of_order_error(
        f"the {what}s of {names}", int(t_ns.min()), open_start, map_name, map_inputs, logs, zone
    )


def out_of_order_error(
    what: str,
    first_ns: int,
    open_start: int,
    map_name: str,
    map_inputs: Sequence[str],
    logs: Sequence[Path],
    zone: str = "UTC",
) -> InputError:
    """The refusal of data (``what``: "the detections of a.mcap", first at ``first_ns``)
    before the open window (from ``open_start``) of the continued map ``map_name``: its hint
    is the command that builds the map's inputs (``map_inputs``) and the build's ``logs`` at
    once, on the map's clock (``zone``, its ``--tz``: a build without it is on UTC or the
    logs' declared zone, another map's days). One text for both routes: a sequential build
    (:func:`check_after_open`) and a parallel one's fold of its shards
    (:func:`aion_cli.shard_fold.fold`)."""
    # paths quoted as a shell needs them (a space in a folder's name)
    words = [*map(path_word, map_inputs[:3]), *(["..."] if len(map_inputs) > 3 else [])]
    listed = " ".join([*words, *map(path_word, logs[:3])])
    clock = "" if zone == "UTC" else f" --tz {path_word(zone)}"
    return InputError(
        f"{what} start at {utc_text(first_ns)}, but {map_name} has already closed every "
        f"window before {utc_text(open_start)}: logs must be added to a map in time order; "
        "nothing was added",
        hint=f"rebuild the map from all logs at once (aion build {listed}{clock} -o NEW.aion)",
    )


def overlap_note(first: int, end_ns: int, logs: Sequence[Path], map_name: str) -> str | None:
    """The note for a continued map (``map_name``, whose data ends at ``end_ns``) given logs
    whose detections start (log time ``first``) before that end, inside its open window
    (:func:`check_after_open` refuses earlier ones): they are learnt after the map's own, not
    interleaved with them, so the map is not the one of one build of all the logs (tracks of
    the same topic are linked apart)."""
    if first >= end_ns:
        return None
    return (
        f"the detections of {', '.join(p.name for p in logs)} start at {utc_text(first)}, before "
        f"{map_name}'s data ends ({utc_text(end_ns)}): they are learnt after the map's, not "
        "interleaved with them, so the map differs from one build of all the logs (tracks "
        "are linked apart); build all the logs at once for that map"
    )


def overlap_warnings(
    logset: Any, topics: set[str], window_ns: int, adapter_of: AdapterOf | None = None
) -> list[str]:
    """A warning per pair of logs that hold the same detection topics over the same time (one
    window or more) *and the same detections* there (:func:`aion_cli.log_twins.same_people`,
    decoded with ``adapter_of``, the build's adapters): people both saw count twice, as
    when one log repeats the other (a copy, an excerpt, a file merged from others; identical
    files are already read once). Logs of the same time that hold other people (two
    sensors, two robots, the train and test splits of one recording) do not warn; nor do
    logs whose detections have no stamp in common (nothing tells them apart then). Without
    ``adapter_of`` (or when the comparison cannot decode them) the shared time alone warns."""
    from aion_cli.errors import AionError
    from aion_cli.log_twins import same_people
    from aion_cli.number_text import span_text

    out = []
    for o in logset.overlaps(topics, window_ns):
        try:
            same = True if adapter_of is None else same_people(logset, o, adapter_of)
        except AionError:  # a message it cannot decode: the build will say; warn as before
            same = True
        if not same:
            continue
        shared = span_text((o.end_ns - o.start_ns) / 1e9)  # as info gives spans: "0.3 s"
        start, end = utc_ends(o.start_ns, o.end_ns)  # "03:16:51.2 to 03:16:51.5" within a second
        out.append(
            f"{o.first.path.name} and {o.second.path.name} both hold {', '.join(o.topics)} "
            f"from {start} to {end} ({shared}), with the same people "
            "at the same times and places: the people both logs saw count twice; if one "
            "repeats the other (a copy, an excerpt, a merged file), build from one of them"
        )
    return out
