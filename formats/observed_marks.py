"""The observed spans of a tracks log (:mod:`formats.tracks_log`), written as a running tracker
marks them: the stamps of the empty detection messages over each span (:func:`observed_stamps`,
every :data:`OBSERVED_INTERVAL_NS` and at the span's last instant), where a log without
detections takes its scene graph, and the spans declared in aion's metadata
(:mod:`formats.log_zone`) so that ``aion build`` counts them as ``--observed`` spans.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from aion_cli.engine.types import I64
from aion_cli.errors import InputError
from aion_cli.formats.track_types import merge_spans

#: interval of the empty detection messages over an observed span: far below any sane
#: observation window (aion's default is 600 s), so every window the span touches holds one
OBSERVED_INTERVAL_NS = 30 * 1_000_000_000


MOST_OBSERVED_MARKS = 10_000_000
"""Empty marker messages one log takes for ``--observed`` spans (at one every 30 s, about
9.5 years): beyond, a span is a typo (a 1970 start), not a recording."""


def observed_stamps(
    spans: Iterable[tuple[int, int]], interval_ns: int = OBSERVED_INTERVAL_NS
) -> I64:
    """Stamps of the empty detection messages that mark ``spans`` (half-open ``[start, end)``
    ns, merged first) as observed: ``start, start + interval, ...`` while before ``end``, and
    the span's last instant ``end - 1 ns``, so a window that overlaps a span only briefly at
    either end still gets a message. Sorted, unique."""
    if not interval_ns > 0:
        raise InputError(f"the observed-message interval must be > 0 ns, got {interval_ns}")
    merged = merge_spans(spans)
    total = sum(b - a for a, b in merged)
    if total // interval_ns > MOST_OBSERVED_MARKS:
        years = total / (365.25 * 86400e9)
        raise InputError(
            f"the observed spans cover {years:,.1f} years: more than one log's empty marker "
            f"messages hold (at most {MOST_OBSERVED_MARKS:,}, one every "
            f"{interval_ns / 1e9:g} s: about {MOST_OBSERVED_MARKS * interval_ns / 3.1557e16:.1f}"
            " years)",
            hint="give the spans the sensor was really recording, e.g. --observed "
            '"2026-01-06 08:00..2026-01-06 18:00"',
        )
    parts = [
        np.append(np.arange(a, b, interval_ns, dtype=np.int64), np.int64(b - 1))
        for a, b in merged
    ]
    return np.unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)


def _lone_graph_ns(spans: list[tuple[int, int]]) -> int | None:
    """Where a log without detections takes its scene graph: its first marker, the first
    span's start, which is the log's own start. A build cuts the log's first window at its
    start as the span does, so the graph adds no observed time there, whatever the window;
    inside the log a window holding a message counts whole, and the middle of a span short
    of two windows (it went there) could lie in a window the span covers in part."""
    if not spans:
        return None
    return int(observed_stamps(spans)[0])


def _declared_metadata(timezone: str | None, spans: list[tuple[int, int]]) -> dict[str, str]:
    """What the log declares in aion's metadata (:mod:`formats.log_zone`): the zone, and the
    observed spans, so that ``aion build`` counts them as ``--observed`` spans (a window
    only the empty marker messages hold counts for the share the spans cover)."""
    from aion_cli.formats.log_zone import KEY, OBSERVED_KEY, spans_text

    out = {} if timezone is None else {KEY: timezone}
    if spans:
        out[OBSERVED_KEY] = spans_text(spans)
    return out
