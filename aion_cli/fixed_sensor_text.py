"""The one-line description of a fixed sensor's observation, written into the report and the
manifest (:func:`fixed_sensor_text`) and read back from a map's manifest
(:func:`fixed_sensor_share`), and a share of time observed as a percentage.

It counts windows, never a time: ``fixed sensor over the 2 windows with messages (2 of the 3
windows of 10 min from the first to the last)``. It had given their time as the log's,
``(10 min of a 10 min span)`` for a 250-second log in one window; manifests written so
(in hours, minutes or seconds: ``(72.3 h of a 72.3 h span)``) still read back.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

FIXED_SENSOR_OVER = "fixed sensor over"
"""How the description of a fixed sensor's recorded windows starts (:func:`fixed_sensor_text`)."""

DECLARED = "or --observed"
"""In a fixed sensor's description when ``build --observed`` declared some of its windows."""

SILENT_HINT = (
    "if its tracker is silent when nobody is there, declare the spans it was recording with "
    "aion build --observed"
)
"""Where a fixed sensor observed little of its span: windows without any message are
unknown, not empty, unless the user says the sensor was recording."""


def silent_advice(counts: Mapping[str, Any]) -> str:
    """:data:`SILENT_HINT` for a map or build whose detection topics published no message
    without a detection (``counts["empty_messages"]``; older maps did not count them); when
    they published some, why it does not apply: such a tracker is not silent when nobody is
    there, so the windows without a message were not recorded (declaring them would be wrong).
    """
    n = counts.get("empty_messages")
    if type(n) is not int or n <= 0:
        return SILENT_HINT
    return (
        f"its detection topics published {n:,} message{'' if n == 1 else 's'} with nobody in "
        f"{'it' if n == 1 else 'them'}, so its tracker is not silent when nobody is there and "
        "the windows without a message were not recorded"
    )


#: The unit words of :func:`time_text`, in seconds.
_UNIT_S = {"h": 3600.0, "min": 60.0, "s": 1.0}

_SHARE = re.compile(r"\(([\d.,]+) (h|min|s) of a ([\d.,]+) (h|min|s) span\)")
"""The share as manifests written before gave it, in times (``(0.3 h of a 0.6 h span)``)."""
_WINDOWS_SHARE = re.compile(r"\(([\d,]+) of the ([\d,]+) windows of [\d.,]+ (?:h|min|s) from ")
"""The share as :func:`fixed_sensor_text` gives it, in windows."""


def share_text(share: float) -> str:
    """A share of time observed as a whole percentage that reads 0 % or 100 % only when it
    is: ``"<1%"`` for 0.4 %, ``">99%"`` for 99.6 % (``"0%"`` had read as nothing observed)."""
    text = f"{share:.0%}"
    if share > 0.0 and text == "0%":
        return "<1%"
    if share < 1.0 and text == "100%":
        return ">99%"
    return text


def time_text(ns: int) -> str:
    """``ns`` as the description writes it: ``72.3 h`` from an hour up, else ``12 min`` (or
    ``1.5 min``), under a minute ``40 s``."""
    seconds = ns / 1e9
    if seconds >= 3600:
        return f"{seconds / 3600:,.1f} h"
    if seconds >= 60:
        return f"{round(seconds / 60, 1):g} min"
    return f"{round(seconds, 1):g} s"


def fixed_sensor_text(
    count: int, first: int, last: int, delta: int, declared: bool = False
) -> str:
    """The report's description of fixed-sensor observation: ``count`` windows of
    ``delta`` ns with messages (``declared``: or declared by ``--observed``), from window
    ``first`` to ``last``, in windows (a log of 250 s in one window of 10 min had read
    ``(10 min of a 10 min span)``)."""
    span = last - first + 1
    why = f"with messages {DECLARED}" if declared else "with messages"
    return (
        f"{FIXED_SENSOR_OVER} the {count:,} window{'' if count == 1 else 's'} {why} "
        f"({count:,} of the {span:,} windows of {time_text(delta)} from the first to the last)"
    )


def fixed_sensor_share(observation: str, recording_windows: int | None = None) -> float | None:
    """The share of its time a fixed sensor observed, read from a description that
    :func:`fixed_sensor_text` wrote (``the N windows ... (N of the M windows of 10 min from
    the first to the last)``, or before, in times: ``(A h of a B h span)``, ``(12 min of a 12 min
    span)``): of its logs' own time when ``recording_windows`` says how long that was (a
    manifest's ``counts.recording_windows``), else of the span; None for any other
    description."""
    if not observation.startswith(FIXED_SENSOR_OVER):
        return None
    in_windows = _WINDOWS_SHARE.search(observation)
    found = _SHARE.search(observation)
    if in_windows is None and found is None:
        return None
    windows = re.search(r"the ([\d,]+) windows?", observation)
    if recording_windows and windows is not None:
        return min(1.0, int(windows.group(1).replace(",", "")) / int(recording_windows))
    if in_windows is not None:  # this version's text: the windows from the first to the last
        seen_w, span_w = (int(g.replace(",", "")) for g in in_windows.groups())
        return seen_w / span_w if span_w > 0 else None
    if found is None:
        return None
    seen_n, seen_unit, span_n, span_unit = found.groups()
    seen = float(seen_n.replace(",", "")) * _UNIT_S[seen_unit]
    span = float(span_n.replace(",", "")) * _UNIT_S[span_unit]
    return seen / span if span > 0 else None
