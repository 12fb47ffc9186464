"""The ``--observed`` windows between part maps (``aion merge``; no click).

One build of a fixed sensor's logs with ``--observed`` counts the declared windows between two
logs as observed (nobody there); a part map built with ``--observed`` fills only its own
logs' time, so its manifest keeps the spans (``observed_spans``) and the merge fills the
windows between the maps before it and the part from them, as a build continuing the earlier
maps with the part's logs and spans does (from the window after the earlier logs' last,
``recording_reach``, to the one before the part's first, ``recording_first``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState
    from aion_cli.manifest import Manifest


def fill_declared_gap(acc: MapState, early: Manifest | None, part: Manifest) -> int | None:
    """Declare observed in ``acc`` (the maps before the part, ``early`` the manifest of the
    latest of them) the windows between them and the part (manifest ``part``) that the part's
    ``observed_spans`` cover: how many; None when it has none to fill with (no spans stored,
    the maps' recording windows unknown, or no window between them). ``early`` None: the
    part is the merge's first map, and its spans' windows before its logs count from the
    spans' start, as one build of its logs as a new map counts them
    (:func:`aion_cli.log_observed.fill_start`)."""
    from aion_cli.fixed_sensor import declared_windows

    spans = part.observed_spans
    delta = acc.window_ns
    first = part.counts.get("recording_first")
    if not spans or type(first) is not int:
        return None
    if early is None:
        lo: int | None = min(int(a) for a, _ in spans) // delta
    else:
        reach = early.recording_reach
        lo = None if reach is None else reach + 1
    if lo is None or first <= lo:
        return None
    gap = declared_windows(spans, [("between", lo, first - 1)], delta)
    bounds = (
        np.array([lo for lo, _ in spans], np.int64),
        np.array([hi for _, hi in spans], np.int64),
    )
    acc.observation.add_fixed_windows(gap, delta, bounds)
    if early is None and gap.size and acc.open_window is None:
        acc.open_window = int(gap[0])  # the join closes them, as a build's first window
    return int(gap.size)
