"""The windows the ``--observed`` spans declare observed (``build --observed``, for a tracker
that publishes only when it sees someone): which windows of ``delta`` ns the spans ``[lo, hi)``
fill within the logs' time (:func:`declared_windows`), and the notes that say how many were
added and how many lie outside the logs' time and stay unknown (:func:`observed_note`,
:func:`outside_logs_note`).

Why apart from :mod:`aion_cli.fixed_sensor`: a fixed sensor's observation takes these
windows, but so do a merge filling the time between its parts
(:mod:`aion_cli.merge_observed`) and a parallel build adding its shards' notes up
(:mod:`aion_cli.shard_reports`); the spans' arithmetic is one job, apart from reading the logs'
recorded windows.
"""

from __future__ import annotations

import numpy as np

from aion_cli.engine.types import I64
from aion_cli.fixed_sensor_text import time_text

__all__ = [
    "LOGS_OBSERVED_NOTE",
    "OBSERVED_NOTE",
    "declared_windows",
    "observed_note",
    "outside_logs_note",
]


OBSERVED_NOTE = "--observed: "
"""How :func:`observed_note` starts (a parallel build's parent replaces its shards' notes)."""
LOGS_OBSERVED_NOTE = "the observed spans the logs record: "
"""How :func:`observed_note` starts for the spans the logs record (no ``--observed`` given)."""


def observed_note(added: int, delta: int, files: int, from_logs: bool = False) -> str:
    """The note of the windows without a message that ``--observed`` spans (or, ``from_logs``,
    the spans the logs record: ``aion convert --observed``) made observed (``added`` windows
    of ``delta`` ns), the time between the logs named only where there are logs apart
    (``files``: the log files read, a rosbag2 bag's storage files one): one log's own
    declared span has no time between logs. None added: a note that says so in words. The
    logs' own spans are not the user's ``--observed``, and their windows hold the logs' empty
    marker messages: the note says so rather than "without a message"."""
    lead = LOGS_OBSERVED_NOTE if from_logs else OBSERVED_NOTE
    message = "a message besides the logs' empty markers" if from_logs else "a message"
    if added == 0:  # "0 window(s) ... (0 s), the time between the logs included" said less
        return (
            f"{lead}every window the spans declare within the logs' time holds {message} "
            "already: they add none"
        )
    what = "window(s) with no message but the logs' empty markers" if from_logs else (
        "window(s) without a message"
    )
    between = ", the time between the logs included" if files > 1 else ""
    return f"{lead}{added:,} {what} taken as observed ({time_text(added * delta)}){between}"


def outside_logs_note(
    declared: tuple[tuple[int, int], ...],
    spans: list[tuple[str, int, int]],
    delta: int,
    start: int | None = None,
    then: str = "a log that continues the map fills the time since the map's last message",
    end: int | None = None,
) -> str | None:
    """The note for the windows of the ``--observed`` spans ``[lo, hi)`` that lie outside the
    logs' time (``spans``: each file's first and last window,
    :func:`aion_cli.fixed_sensor._file_spans`; ``start``, ``end``: the first and last window
    the spans may fill, ``log_observed.fill_start`` and ``fill_end``), which stay unknown
    (:func:`declared_windows`; ``then``: what follows for the command). None when there are
    none."""
    if not declared or not spans:
        return None
    runs = _window_runs(declared, delta)
    total = sum(b - a + 1 for a, b in runs)
    filled = declared_windows(declared, spans, delta, (start, end))
    n = total - filled.size
    if n == 0:
        return None
    last = _fill_range(spans, (start, end))[1]
    after = sum(b - max(a, last + 1) + 1 for a, b in runs if b > last)
    where = (
        "after the last log's last message" if after == n else "outside the logs' time "
        "(before the first log's first message or after the last log's last)"
    )
    return (
        f"{OBSERVED_NOTE}{n:,} declared window(s) ({time_text(n * delta)}) lie {where} and "
        f"stay unknown, not empty: {then}"
    )


def declared_windows(
    declared: tuple[tuple[int, int], ...],
    spans: list[tuple[str, int, int]],
    delta: int,
    fill: tuple[int | None, int | None] = (None, None),
) -> I64:
    """The windows of ``delta`` ns that the spans ``[lo, hi)`` overlap within the logs' time:
    from the first file's first recorded window to the last file's last (``spans``, each
    file's own first and last window inside the runs of the topics aion uses, so a stray
    message adds no decades of empty windows), the time between two files included (a
    tracker recorded one log a day keeps its declared nights). ``fill`` widens the range:
    its first window where a continued map's logs stopped (so building A and B at once equals
    building A and continuing with B), and a parallel shard's first and last window, each
    shard taking its share of the time between the groups of logs (so the shards together
    fill what one pass fills)."""
    if not spans:
        return np.zeros(0, np.int64)
    first, last = _fill_range(spans, fill)
    parts = []
    for a, b in _window_runs(declared, delta):
        a, b = max(a, first), min(b, last)
        if b >= a:
            parts.append(np.arange(a, b + 1, dtype=np.int64))
    if not parts:
        return np.zeros(0, np.int64)
    out: I64 = np.concatenate(parts)  # the runs are disjoint and sorted: so are their windows
    return out


def _fill_range(
    spans: list[tuple[str, int, int]], fill: tuple[int | None, int | None]
) -> tuple[int, int]:
    """The first and last window the declared spans may fill: the files' first to their
    last, widened by ``fill``."""
    first = min(f for _, f, _ in spans)
    last = max(b for _, _, b in spans)
    lo, hi = fill
    return (first if lo is None else min(first, lo)), (last if hi is None else max(last, hi))


def _window_runs(declared: tuple[tuple[int, int], ...], delta: int) -> list[tuple[int, int]]:
    """The spans ``[lo, hi)`` as disjoint runs of whole windows (first, last), sorted: the
    windows each span overlaps, overlapping or touching runs joined (as half-open window
    ranges, by the engine's span merge)."""
    from aion_cli.engine.observation import merged_spans

    lo = np.array([int(a) for a, _ in declared], np.int64) // delta
    hi = -(-np.array([int(b) for _, b in declared], np.int64) // delta)
    starts, ends = merged_spans(lo, hi)
    return [(int(a), int(b) - 1) for a, b in zip(starts, ends, strict=True)]
