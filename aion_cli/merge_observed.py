"""The ``--observed`` windows between part maps (``aion merge``; no click).

One build of a fixed sensor's logs with ``--observed`` counts the declared windows between two
logs as observed (nobody there); a part map built with ``--observed`` fills only its own
logs' time, so its manifest keeps the spans (``observed_spans``) and the merge fills the
windows between the maps before it and the part from them, as a build continuing the earlier
maps with the part's logs and spans does (from the window after the earlier logs' last,
``recording_reach``, to the one before the part's first, ``recording_first``). The spans it
fills with are every part's (:func:`merged_part_spans`), as one build of all the logs takes
every span given: an earlier part's span that reaches past its logs covers the time after
them too, and a part built without ``--observed`` is filled around as the others' spans say.

What the merge cannot fill: the windows inside a part's own logs' time that hold no message
and that only another part's spans cover (:func:`unfilled_within`). The part closed them
unobserved when it was built, and its held days cannot take a window afterwards; one build
given every span counts them as observed and empty, so the merge says so in a note (build
that part again with every span, and the merge is exact)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState
    from aion_cli.engine.types import I64
    from aion_cli.manifest import Manifest


def merged_part_spans(parts: Sequence[Manifest]) -> tuple[tuple[int, int], ...]:
    """The ``observed_spans`` of every part map of a merge (``parts``: their manifests),
    sorted, once each: the spans one build of all their logs is given."""
    return tuple(sorted({(int(a), int(b)) for m in parts for a, b in m.observed_spans}))


def fill_declared_gap(
    acc: MapState,
    early: Manifest | None,
    part: Manifest,
    spans: tuple[tuple[int, int], ...] | None = None,
) -> int | None:
    """Declare observed in ``acc`` (the maps before the part, ``early`` the manifest of the
    latest of them) the windows between them and the part (manifest ``part``) that the
    ``spans`` cover (every part's, :func:`merged_part_spans`, as one build is given them all,
    whether or not this part was built with ``--observed``; None: the part's own
    ``observed_spans``): how many; None when there are no spans to fill with (no part was
    built with ``--observed``), the maps' recording windows are unknown, or no window lies
    between them. ``early`` None: the part is the merge's first map, and the
    spans' windows before its logs count from the spans' start, as one build of its logs as a
    new map counts them (:func:`aion_cli.log_observed.fill_start`)."""
    from aion_cli.observed_spans import declared_windows

    delta = acc.window_ns
    first = part.counts.get("recording_first")
    spans = part.observed_spans if spans is None else spans
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


def fill_declared_tail(
    acc: MapState, last: Manifest, spans: tuple[tuple[int, int], ...]
) -> int | None:
    """Declare observed in ``acc`` (the merged maps, the part of manifest ``last`` joined
    last) the windows after the last part's logs that the ``spans`` (every part's,
    :func:`merged_part_spans`) cover, to their end, and close them as one build of all the
    logs closes them when a declared span ends after its last message
    (:func:`aion_cli.log_observed.fill_end`: it reaches the span's last instant, the window
    holding it left open): the end of the time they observed (ns, exclusive; the merged map
    ends at its last instant), None when there is none (the part stores no spans, its logs'
    recording windows are unknown, or the spans end within its logs). The last part need not
    have spans of its own: an earlier part's that reach past its logs fill after them too, as
    in one build given them all."""
    from aion_cli.engine.mapper import Mapper
    from aion_cli.log_observed import declared_end_ns, fill_end
    from aion_cli.observed_spans import declared_windows

    reach, delta = last.recording_reach, acc.window_ns
    end = fill_end(spans, delta, False)
    if not spans or reach is None or end is None or end <= reach:
        return None
    tail = declared_windows(spans, [("after", reach + 1, end)], delta)
    stop = declared_end_ns(tail, spans, delta)
    if stop is None:
        return None
    bounds = (
        np.array([lo for lo, _ in spans], np.int64),
        np.array([hi for _, hi in spans], np.int64),
    )
    mapper = Mapper(acc.config, acc)
    mapper.set_fixed_windows(tail, bounds)
    mapper.advance(stop - 1)
    return stop


def unfilled_within(
    part: MapState, manifest: Manifest, spans: tuple[tuple[int, int], ...]
) -> int:
    """How many windows inside the part's own logs' time (``manifest``'s ``recording_first``
    to ``recording_reach``) the ``spans`` (every part's, :func:`merged_part_spans`) cover for
    time the part's state did not observe: one build given every span counts that time as
    observed (a window without a message, wholly or for the share the spans add), the part,
    built with its own spans only, closed it unobserved. 0 when there are none, the part's
    recording windows are unknown, or it is not a fixed sensor's (a robot part's windows are
    its trajectory's: spans do not add to them)."""
    from aion_cli.engine.observation import merged_spans
    from aion_cli.fixed_sensor_text import FIXED_SENSOR_OVER

    first, reach = manifest.counts.get("recording_first"), manifest.recording_reach
    if not spans or type(first) is not int or reach is None or reach < first:
        return 0
    if not manifest.observation.startswith(FIXED_SENSOR_OVER):
        return 0
    delta = part.window_ns
    lo, hi = first * delta, (reach + 1) * delta
    own = part.observation.merged_fixed()
    s = np.clip(np.array([a for a, _ in spans], np.int64), lo, hi)
    e = np.clip(np.array([b for _, b in spans], np.int64), lo, hi)
    union = merged_spans(np.concatenate([own[0], s]), np.concatenate([own[1], e]))
    windows = np.arange(first, reach + 2, dtype=np.int64) * delta  # window edges
    gained = _covered_below(union, windows) - _covered_below(own, windows)
    return int(np.count_nonzero(np.diff(gained)))


def _covered_below(intervals: tuple[I64, I64], t: I64) -> I64:
    """Per time of ``t``, how much of it the sorted disjoint ``intervals`` cover before it (ns,
    exact): the whole intervals before it and the part of the one it falls in."""
    starts, ends = intervals
    if starts.size == 0:
        return np.zeros(t.size, np.int64)
    before = np.concatenate([[0], np.cumsum(ends - starts)]).astype(np.int64)
    k = np.searchsorted(starts, t, side="right")  # intervals starting at or before t
    last = np.maximum(k - 1, 0)
    inside = np.where(k > 0, np.clip(t - starts[last], 0, ends[last] - starts[last]), 0)
    out: I64 = before[np.maximum(k - 1, 0)] * (k > 0) + inside
    return out
