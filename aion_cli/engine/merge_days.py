"""The day two merged maps share: the earlier map's pending day and the later map's first.

One build of both maps' logs closes the earlier log's windows when the later log's first
recorded window arrives, and closes (scores and absorbs) the earlier log's pending day only if
that window falls on a later local day; otherwise the two logs' windows of that day are one
pending day, scored once when the day is over. A merge does the same where the maps allow it
(:func:`shared_first_day`): the later map has closed no day (its first day is still pending,
so none of it was scored or absorbed) and starts after the earlier map's open window. Then
:func:`close_earlier` closes the earlier map's windows up to the later map's first recorded
window and leaves its pending day open, and :func:`carry_pending` puts that day's windows
before the later map's pending day in the merged map. Where the later map already closed
that day (it goes on past it), or the maps' windows interleave, the earlier map's pending day
is closed at the merge and the day is scored as two (merge approximation 4).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from aion_cli.engine.closing import close_windows

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState
    from aion_cli.engine.types import I64


def shared_first_day(early: MapState, later: MapState) -> tuple[int, int] | None:
    """The later map's first recorded window (its open window when it recorded none) and
    its local day, when the earlier map's pending day may join it: the later map (an
    ordinary map) closed no day, and that window comes after the earlier map's open window.
    None otherwise."""
    if later.deferred is not None or later.open_window is None or later.closed_a_day():
        return None
    if later.pending:
        first, day = int(later.pending.windows[0]), later.pending.day
    else:
        first = int(later.open_window)
        day = later.window_day(first)
    if early.open_window is not None and first <= early.open_window:
        return None  # the maps share a window: their times interleave
    assert day is not None
    return first, int(day)


def close_earlier(early: MapState, later: MapState | None = None) -> None:
    """Close the earlier map's windows as the later map's first recorded window would in one
    pass (up to it, when :func:`shared_first_day` knows it; else the open window alone), and
    close its pending day unless that day is the later map's first: the first step of every
    merge."""
    shared = None if later is None else shared_first_day(early, later)
    if early.open_window is not None:
        stop = early.open_window + 1 if shared is None else shared[0]
        close_windows(early, stop)
    if shared is None or early.pending.day != shared[1]:
        early.close_day()


def carry_pending(out: MapState, early: MapState, row_map: I64) -> None:
    """The earlier map's pending day (left open by :func:`close_earlier`: the later map's
    first day) before the windows of ``out``'s, its entry rows ``r`` moved to
    ``row_map[r]``: the merged map's pending day, as one build holds it."""
    if not early.pending:
        return
    carried = early.pending.relabelled(row_map)
    carried.extend(out.pending)
    out.pending = carried
