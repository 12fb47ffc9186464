"""Times that cannot belong together: warnings for declared ``--observed`` spans and for a
scene graph's agent (robot pose) layer whose times lie apart from the logs' messages.

The rule for a declared span ``[lo, hi)`` (docs/ROBUSTNESS.md, time sanity, "Times apart"),
against the logs' first and last message ``first``, ``last``:

* it lies wholly before ``first`` or wholly after ``last``: it holds no message of the logs,
  which is what a mistyped date, a time in another zone or a UNIX time with digits lost
  gives (UNIX milliseconds given as seconds are refused when read: beyond year 5000); or
* it reaches beyond the logs (before ``first`` or after ``last``) by more than
  :data:`FAR_NS` (7 days) and more than the logs' own span ``last - first``: one week is a
  whole cycle of the map's week model, so more than that adds every hour of the week again as
  observed and empty; and beyond the logs' own span, most of the time the map counts as
  observed rests on the declaration alone (a long deployment whose sensor was silent for a
  week stays quiet).

Both only warn: a sensor may really have run with nobody passing, which aion cannot know, so
no span is certainly wrong; the map is built as declared.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from aion_cli.build_options import BuildOptions
    from aion_cli.engine.time_text import Zone
    from aion_cli.engine.types import Trajectory

Span = tuple[int, int]

MOST = 3
"""The spans :func:`observed_apart_warnings` names one by one."""

FAR_NS = 7 * 86_400 * 10**9
"""How far (ns) a declared span may reach beyond the logs' messages without a warning, when
the logs themselves span less (module docstring)."""


def span_apart(lo: int, hi: int, first: int, last: int) -> str | None:
    """How the span ``[lo, hi)`` lies apart from messages from ``first`` to ``last`` (ns), in
    words ("lies wholly before", ...), or None where it belongs with them (module
    docstring)."""
    if hi <= first:
        return "lies wholly before"
    if lo > last:
        return "lies wholly after"
    limit = max(FAR_NS, last - first)
    beyond = max(first - lo, hi - 1 - last)
    if beyond > limit:
        return f"reaches {beyond / 86_400e9:,.1f} days beyond"
    return None


def observed_apart_warnings(
    texts: Sequence[str],
    spans: Sequence[tuple[int, int]],
    first: int | None,
    last: int | None,
    zone_name: Zone | str | None,
    what: str = "the logs' messages",
) -> list[str]:
    """One warning per ``--observed`` span (``texts`` as typed, ``spans`` as read, in the same
    order) that lies apart from ``what`` (first ``first``, last ``last``, ns; none: no
    warning) by :func:`span_apart`, naming both in ``zone_name`` (a name, None: UTC), the
    zone the spans were read in; the first :data:`MOST` of them, then one line counting the
    rest."""
    if first is None or last is None:
        return []
    from aion_cli.engine.time_text import Zone, format_ns
    from aion_cli.timeparse import resolve_zone

    zone = zone_name if isinstance(zone_name, Zone) else resolve_zone(zone_name or "UTC")
    out: list[str] = []
    for text, (lo, hi) in zip(texts, spans, strict=True):
        how = span_apart(int(lo), int(hi), int(first), int(last))
        if how is None:
            continue
        if len(out) == MOST:
            out.append("")
        if len(out) > MOST:
            continue
        out.append(
            f'--observed "{text}" ({format_ns(int(lo), zone)} .. {format_ns(int(hi), zone)}) '
            f"{how} {what} ({format_ns(int(first), zone)} .. {format_ns(int(last), zone)}): "
            "its windows without a message still count as observed and empty; hint: a "
            "mistyped date, a time in another zone, a UNIX time with digits lost? If the "
            "sensor really ran then with nobody passing, this is right"
        )
    if len(out) > MOST:  # the count of the rest, in place of the first one left out
        rest = sum(
            span_apart(int(lo), int(hi), int(first), int(last)) is not None for lo, hi in spans
        ) - MOST
        out[MOST] = f"--observed: {rest:,} more span(s) lie apart from {what} likewise"
    return out


def agents_apart_warning(
    agents: tuple[int, int] | None, first: int | None, last: int | None, zone_name: str | None
) -> str | None:
    """The warning for a scene graph's agent layer whose robot poses (``agents``: first and
    last pose time, ns) overlap none of the logs' messages (``first`` .. ``last``): the
    robot's trajectory then observes none of the log's time, so only the windows in which an
    entry holds a detection count as observed (for that entry), and no empty window of the
    log's time is learnt. None where they overlap or a time is unknown."""
    if agents is None or first is None or last is None:
        return None
    lo, hi = agents
    if hi >= first and lo <= last:
        return None
    from aion_cli.engine.time_text import format_ns
    from aion_cli.timeparse import resolve_zone

    zone = resolve_zone(zone_name or "UTC")
    return (
        f"the scene graph's agent layer holds robot poses from {format_ns(lo, zone)} to "
        f"{format_ns(hi, zone)}, none in the logs' time ({format_ns(first, zone)} .. "
        f"{format_ns(last, zone)}): the robot's trajectory observes none of it, so only the "
        "windows in which a place or cell holds a detection count as observed there, and no "
        "window of the logs' time counts as observed and empty; hint: a graph of another "
        "recording? Give the robot's TF, or the graph as --graph FILE (its agent layer is "
        "then not used: the log is taken as a fixed sensor over its windows)"
    )


def joined_times(
    times: tuple[int, int] | None, agents: Trajectory | None
) -> tuple[int, int] | None:
    """``times`` (first, last; None: none yet) widened by the robot poses of ``agents`` (a
    snapshot's agent layer)."""
    if agents is None or len(agents) == 0:
        return times
    t = np.asarray(agents.t_ns, dtype=np.int64)
    lo, hi = int(t.min()), int(t.max())
    return (lo, hi) if times is None else (min(times[0], lo), max(times[1], hi))


def apart_warnings(
    opts: BuildOptions, messages: Span | None, agents: Span | None, observation: str, zone: str
) -> list[str]:
    """A build's warnings on times apart from its logs' messages (``messages``: the first and
    last, ns; None: none): the ``--observed`` spans as typed (``opts.observed_typed``) unless
    a robot trajectory observed instead (``observation`` of TF or the agent layer: the spans
    were set aside with a warning of their own, so they count nothing), and the robot poses
    of the agent layer (``agents``, first and last) when the build observed with it, named
    in ``zone``: the table's (its config's ``timezone``: ``--tz``, the zone the logs declare,
    the continued map's; for ``evaluate holdout``, the map's), which the spans were read in."""
    first, last = messages if messages is not None else (None, None)
    robot = observation.startswith(("tf ", "scene-graph"))
    typed = () if robot else opts.observed_typed
    out = observed_apart_warnings(
        [text for text, _ in typed], [span for _, span in typed], first, last, zone
    )
    apart = agents_apart_warning(agents, first, last, zone)
    if apart is not None and observation.startswith("scene-graph"):
        out.append(apart)
    return out


def joined(spans: Sequence[Span | None]) -> Span | None:
    """The span from the first start to the last end of ``spans`` (None: none given)."""
    given = [s for s in spans if s is not None]
    if not given:
        return None
    return min(a for a, _ in given), max(b for _, b in given)
