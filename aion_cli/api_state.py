"""A map of a state in memory and the two ways ``Map.save`` writes a map: the map
:meth:`aion_cli.api.Map.from_state` makes of a state fed in memory (:func:`state_map`, with
the manifest of what was fed: :func:`state_manifest`, :func:`state_span`), a loaded map's
file copied byte for byte (:func:`copy_map`) and a state in memory written
(:func:`write_state`).

Split from :mod:`aion_cli.api_make` (the functions that make maps from logs and maps)."""

from __future__ import annotations

import os
from dataclasses import replace
from typing import TYPE_CHECKING

from aion_cli.errors import InputError

if TYPE_CHECKING:
    from pathlib import Path

    from aion_cli.engine.state import MapState
    from aion_cli.manifest import Manifest
    from aion_cli.mapquery import LoadedMap
    from aion_cli.pinned_file import PinnedFile


def state_map(state: object, timezone: object) -> LoadedMap:
    """A state built in memory as a map to query and save (:meth:`Map.from_state`): a
    ``MapState`` that can be written (not a loaded map's), its zone a name every query
    reads; its scene graph is the state's latest, and its manifest the one :meth:`Map.save`
    writes (:func:`state_manifest`), so its queries answer with the notes and
    ``hour_observed`` the saved map's give (before: none, and None). The state as its
    fixed sensor's end leaves it (:func:`observed_to_end`)."""
    from aion_cli.api_checks import zone_name
    from aion_cli.engine.state import MapState
    from aion_cli.mapquery import LoadedMap, latest_graph

    if not isinstance(state, MapState):
        raise InputError(
            f"from_state needs an engine MapState, got {type(state).__name__}",
            hint="aion_cli.engine.mapper.Mapper(config).state, after feeding it",
        )
    if not state.writable:
        raise InputError(
            "this state was read from a map file for queries and cannot be written",
            hint="save the loaded map itself (Map.save copies it), or load it with "
            "aion_cli.mapquery.load_map(path, writable=True) to continue it",
        )
    name = zone_name(timezone, "timezone")
    if name is not None:  # an unknown name would fail every query of the saved map
        from aion_cli.timeparse import resolve_zone

        name = resolve_zone(name).name
    state = observed_to_end(state)
    return LoadedMap(state, latest_graph(state), state_manifest(state, name).to_dict())


def observed_to_end(state: MapState) -> MapState:
    """The state as ``aion build`` leaves it at the end of its log: log time advanced
    (``Mapper.advance``) to the last instant its fixed-sensor intervals declare observed, so
    the windows watched after the last detection count as observed and empty, as a build
    counts them (it advances to its log's last message); unless they were, a map of a
    sensor watching 10:00-11:00 whose last detection came at 10:20 counted two windows
    observed, and its saved copy the same, where the build of its log counted six. A copy
    is advanced (the caller's state may still be fed, earlier times included); the state
    itself when it has no such window left open."""
    import copy

    import numpy as np

    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.windows import window_index

    _, ends = state.observation.merged_fixed()
    if ends.size == 0:
        return state
    last = int(ends[-1]) - 1  # [start, end): its last instant
    window = int(window_index(np.int64(last), state.window_ns))
    if state.open_window is not None and window <= state.open_window:
        return state
    advanced = copy.deepcopy(state)
    Mapper(advanced.config, advanced).advance(last)
    return advanced


def copy_map(file: PinnedFile, target: Path) -> None:
    """Write the map file held open as ``file`` (a loaded map's, :meth:`Map.save`) to
    ``target`` byte for byte, its checksums valid: the bytes loaded, also once its path was
    replaced or deleted; nothing to write when ``target`` is that very file. An existing
    ``target`` is replaced atomically only if it is an aion map."""
    from aion_cli.formats.mapfile import check_map_target, map_lock
    from aion_cli.formats.outputs import staging_prefix

    file.check()
    if target.exists() and os.path.samestat(os.stat(target), os.fstat(file.fd)):
        return  # the very file: nothing to write
    check_map_target(target)
    tmp = target.with_name(f"{staging_prefix(target.name)}{os.getpid()}.tmp")
    with map_lock(target):  # as write_map: one writer per map at a time
        try:
            file.copy_to(tmp)  # the bytes loaded, even if the path was replaced
            os.replace(tmp, target)
        finally:
            tmp.unlink(missing_ok=True)


def state_manifest(state: MapState, timezone: str | None) -> Manifest:
    """The manifest of a state fed in memory (``Map.from_state``): the detections fed, counted
    as a build's manifest counts them, and the families, days scored and hours observed
    (``family_summary``) that queries note from; what :func:`write_state` stores."""
    from aion_cli.engine.family_summary import family_summary
    from aion_cli.manifest import Manifest
    from aion_cli.mapquery import state_counts

    start, end = state_span(state)
    return Manifest(
        state={},
        config=state.config.to_dict(),
        counts={  # the detections fed, as a build's manifest counts them
            "read": state.accepted + sum(state.dropped.values()),
            "used": state.accepted,
            "dropped": {k: v for k, v in state.dropped.items() if v},
            **state_counts(state),
        },
        graph_source="memory",
        timezone=timezone,
        families=family_summary(state),
        start_ns=start,
        end_ns=end,
    )


def state_span(state: MapState) -> tuple[int | None, int | None]:
    """The span of log time a state fed in memory knows (what a build records as its logs'
    ``time_span``, for the notes of queries far from it): from the earliest time fed
    (``first_time_ns``) or fixed-sensor interval to the latest (``log_time_ns``) or the last
    instant of an interval ``[start, end)`` (``end - 1``, as a build records a declared
    span's end); ``(None, None)`` when it knows no start or no end (a state read from a file
    and continued keeps no first time)."""
    starts = [] if state.first_time_ns is None else [int(state.first_time_ns)]
    ends = [] if state.log_time_ns is None else [int(state.log_time_ns)]
    fixed_start, fixed_end = state.observation.merged_fixed()  # (empty intervals left out)
    if fixed_start.size:
        starts.append(int(fixed_start[0]))
        ends.append(int(fixed_end[-1]) - 1)
    if not starts or not ends:
        return None, None
    return min(starts), max(ends)


def write_state(state: MapState, timezone: str | None, target: Path) -> None:
    """Write an in-memory ``state`` (``Map.from_state``) as the map file ``target``, with
    :func:`state_manifest` (of the state now, as fed so far) and the state's members."""
    from aion_cli.derived_seal import seal
    from aion_cli.formats.mapfile import write_map

    arrays, meta = state.to_arrays(lazy=True)
    manifest = replace(state_manifest(state, timezone), state=meta).to_dict()
    write_map(target, arrays, manifest, seal=seal)
