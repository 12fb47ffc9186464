"""The notes of ``aion merge``: which approximations of the engine's merge
(:mod:`aion_cli.engine.merge`, numbered as in its docstring) apply to the maps at hand, so a
merged map says where it may differ from one build of all the logs. Read-only: nothing here
changes a state."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aion_cli.engine.entries import NODE
from aion_cli.engine.grouping import contained

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState
    from aion_cli.manifest import Manifest


def pair_notes(early: str, end_ns: int | None, late: str, start_ns: int | None) -> list[str]:
    """Two consecutive maps (names ``early`` and ``late``; the earlier one ends at
    ``end_ns``, the later starts at ``start_ns``): overlapping times."""
    notes = []
    if interleave(end_ns, start_ns):
        notes.append(
            f"the times of {early} and {late} overlap or interleave ({late} starts before "
            f"{early} ends): a window both observed, if any, counts twice (merge maps of "
            "disjoint time)"
        )
    return notes


def day_notes(
    early: str, early_state: MapState, late: str, late_state: MapState, start_ns: int | None
) -> list[str]:
    """Approximation (4) for the map ``late`` (starting at ``start_ns``) about to be merged
    after ``early`` (``early_state``: the merge so far): a day both maps hold is scored as two
    when the merge cannot join its two parts (the later map closed that day, or starts in
    the earlier map's last window: :func:`aion_cli.engine.merge_days.shared_first_day`)."""
    from aion_cli.engine.merge_days import shared_first_day

    w = early_state.open_window
    if w is None or late_state.open_window is None or start_ns is None:
        return []  # a map that recorded no window holds no day
    if not _same_day(early_state, w, start_ns):
        return []
    if shared_first_day(early_state, late_state) is not None:
        return []  # one pending day, as one build holds it
    return [
        f"{early} ends on the day {late} starts, and {late} "
        + (
            "goes on past that day"
            if late_state.closed_a_day()
            else f"starts in the time window in which {early} ends"
        )
        + ": that day is scored as two days (merge approximation 4; a map that ends on "
        "the day it starts, merged after one that ends that day, joins it as one day)"
    ]


def declared_gap_note(
    name: str, early: Manifest, late: Manifest, spans: tuple[tuple[int, int], ...], delta: int
) -> str | None:
    """The ordinary map ``name`` (manifest ``late``) merged after the map of manifest
    ``early``, with part maps' ``--observed`` spans in the merge (``spans``: every part's,
    :func:`aion_cli.merge_observed.merged_part_spans`): one build of all the logs counts the
    windows of ``delta`` ns between the two maps' logs that the spans cover as observed
    (nobody there), from where the earlier logs stopped (``recording_reach``), but neither
    map holds them, and the merge fills the time between maps only before a part map
    (:mod:`aion_cli.merge_observed`). A note counts those windows and says how to get them;
    None when the spans cover none of them. The ordinary maps' own spans are not stored, but
    they cover no time between the maps: a map built with ``--observed`` observes its spans
    whole, before and after its logs (:func:`aion_cli.log_observed.fill_start`,
    ``fill_end``), so its time ends where they do (its ``recording_reach`` includes it)."""
    from aion_cli.observed_spans import declared_windows

    reach, first = early.recording_reach, late.counts.get("recording_first")
    if not spans or reach is None or type(first) is not int or first <= reach + 1:
        return None
    between = declared_windows(spans, [("between", reach + 1, first - 1)], delta).size
    if not between:
        return None
    return (
        f"{name} was merged, but not exactly as one build would: one build of all the logs "
        f"counts the {between:,} window(s) between its logs and those before it that the part "
        "maps' --observed spans cover as observed and empty, and a merge fills the time "
        "between maps only before a part map (build these logs as a part too, aion build LOG "
        "--part --observed ..., and merge the parts)"
    )


def within_note(name: str, windows: int, delta: int) -> str:
    """The note for a part map ``name`` in whose own logs' time other parts' ``--observed``
    spans cover ``windows`` windows of ``delta`` ns it did not observe
    (:func:`aion_cli.merge_observed.unfilled_within`): one build given every span counts them
    as observed, the part closed them unobserved, and a merge cannot add a window to a day
    the part closed."""
    from aion_cli.fixed_sensor_text import time_text

    return (
        f"{name} was joined, but not exactly as one build would: other parts' --observed spans "
        f"cover {windows:,} window(s) ({time_text(windows * delta)}) within its own logs' time "
        "that it did not observe (no message, and its own spans left them out or in part), "
        "which one build of all the logs counts as observed and empty; a merge cannot add "
        "them to the days the part closed (build that part again giving every part's spans, "
        "aion build LOGS --part --observed SPAN --observed SPAN ..., and merge again)"
    )


def interleave(end_ns: int | None, start_ns: int | None) -> bool:
    """Whether a map ending at ``end_ns`` and the next starting at ``start_ns`` share time:
    then each scored its days without the other's (merge approximation 2), whichever of
    them closed a day."""
    return end_ns is not None and start_ns is not None and end_ns > start_ns


def _same_day(state: MapState, window: int, t_ns: int) -> bool:
    """Whether window ``window`` and the window at ``t_ns`` lie on one local day."""
    return state.window_day(window) == state.window_day(t_ns // state.window_ns)


@dataclass(frozen=True)
class Footprint:
    """What the notes need of an earlier map once it is merged away (copies, so the merge
    may change the state): its cells' keys, its node entries' ids, its node table, and
    whether a robot observed any of its entries (else it is a fixed sensor's, whose windows
    the merge adds for every entry)."""

    cell_keys: npt.NDArray[np.int64]
    node_entry_ids: npt.NDArray[np.uint64]
    node_ids: npt.NDArray[np.uint64]
    node_ref_xyz: npt.NDArray[np.float64]
    robot: bool = True

    @classmethod
    def of(cls, state: MapState) -> Footprint:
        e = state.entries
        return cls(
            e.key[e.cell_rows()].copy(),
            e.node_id[e.node_rows()].copy(),
            state.nodes.ids.copy(),
            state.nodes.ref_xyz.copy(),
            bool(np.isfinite(_first_observed(state)).any()),
        )


class ApproximationTally:
    """Approximations (1), (2) and (3) of :mod:`aion_cli.engine.merge` over the ordinary maps
    of a merge, in time order, one map at a time (``aion merge`` holds no more than the maps
    it is merging): :meth:`add` each before it is merged, then :meth:`notes`."""

    def __init__(self, lineage: str) -> None:
        self.lineage = lineage
        self.only = 0
        self.moved = 0
        self.closed = False
        self._last: Footprint | None = None

    def interleaved(self) -> None:
        """Two maps share time (:func:`interleave`): their days were scored apart."""
        self.closed = True

    def add(self, state: MapState) -> None:
        """The next ordinary map (the first map of a merge counts as one, part or not)."""
        if self._last is not None:
            self.only += _unseen_entries(self._last, state)
            if self.lineage == "same":
                self.moved += _moved_nodes(self._last, state)
            self.closed = self.closed or state.closed_a_day()
        self._last = Footprint.of(state)

    def notes(self, parts: bool = False) -> list[str]:
        """The notes; ``parts``: the merge joined part maps too (then approximation 2 says how
        to avoid it: a merged map is an ordinary map, so parts merged in two steps are not
        the one merge of them all)."""
        notes = []
        if self.only:
            notes.append(
                f"{self.only} entries are in one map only, or appear in the later map after it "
                "began: the windows in which the other map's robot saw them empty are not known "
                "(merge approximation 1)"
            )
        if self.closed:
            notes.append(
                "day-ahead scores add: the later maps scored their closed days against their "
                "own history only, not the earlier maps', so the forecast families may differ "
                "from one build of all logs (merge approximation 2)"
                + (
                    "; for an exact map merge part maps only, all in one merge (aion build LOG "
                    "--part for every log; a merged map is an ordinary map, not a part)"
                    if parts
                    else ""
                )
            )
        if self.moved:
            notes.append(
                f"{self.moved} nodes moved between the maps: their stability timers restart "
                "(merge approximation 3)"
            )
        return notes


def _unseen_entries(early: Footprint, late: MapState) -> int:
    """Entries whose robot-observed empty windows one of two maps cannot know: those only
    one map has, where the other map's robot observed (a fixed sensor's windows are global:
    the merge adds them for every entry, as one pass would), and those of both that the
    later map first observed after its own first robot-observed window (created there late,
    so its earlier windows passed them by)."""
    el = late.entries
    late_cells, late_nodes = el.key[el.cell_rows()], el.node_id[el.node_rows()]
    rows = el.canonical_order()
    first = _first_observed(late)[rows]  # model seconds, NaN: never robot-observed
    late_robot = bool(np.isfinite(first).any())
    only = 0
    if late_robot:  # the later robot's empty windows of the earlier map's own entries
        only += np.setdiff1d(early.cell_keys, late_cells).size
        only += np.setdiff1d(early.node_entry_ids, late_nodes).size
    if early.robot:  # the earlier robot's empty windows of the later map's own entries
        only += np.setdiff1d(late_cells, early.cell_keys).size
        only += np.setdiff1d(late_nodes, early.node_entry_ids).size
    if not late_robot:
        return int(only)
    in_early = np.where(
        el.kind[rows] == NODE,
        contained(early.node_entry_ids, el.node_id[rows]),
        contained(early.cell_keys, el.key[rows]),
    )
    late_first = first > np.nanmin(first)  # NaN compares False
    return int(only + np.count_nonzero(in_early & late_first))


def _first_observed(state: MapState) -> npt.NDArray[np.float64]:
    """Per entry row, the first window (model seconds) in which a robot observed it, as a
    query sees it (pending day and open window included; NaN: never), without preparing the
    query's copy of the whole state: absorbing a window only lowers ``obs.first`` of the
    entries the robot saw in it (fixed-sensor windows go to the global block)."""
    from aion_cli.engine.closing import open_window_record
    from aion_cli.engine.temporal.absorption import slot_utc_seconds

    first = state.temporal.obs.first.copy()
    parts = [state.pending.consolidated() if state.pending else None, open_window_record(state)]
    for day in parts:
        if day is None or day.windows.size == 0:
            continue
        entry, slot, _ = day.own_pairs()
        np.fmin.at(first, entry, slot_utc_seconds(day, state.window_ns)[slot])
    return first


def _moved_nodes(early: Footprint, late: MapState) -> int:
    """Nodes in both node tables whose reference positions differ by more than
    ``stable_move_tolerance`` (the earlier stability start is then not kept)."""
    _, at_e, at_l = np.intersect1d(early.node_ids, late.nodes.ids, return_indices=True)
    gap = np.linalg.norm(early.node_ref_xyz[at_e] - late.nodes.ref_xyz[at_l], axis=1)
    return int(np.count_nonzero(gap > late.config.stable_move_tolerance))
