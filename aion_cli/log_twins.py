"""Whether two logs that cover the same time on the same detection topic hold the same
people: the test behind the build's "count twice" warning (``log_order.overlap_warnings``).

Overlapping time spans alone do not say so: two sensors, two robots, or the train and test
splits of one recording (ATC's hours, split 90/10 by person) hold different people at the
same moments. A repeat of one log in the other (a copy in another container, an excerpt, a
merged file, or another processing of one recording, as Lincoln's 2017-05-24_25 and
2017-05-25 files are: other stamps and rounding, the same people) has a detection near
nearly every one of the other's. So the first :data:`SAMPLE_MESSAGES` messages of one file
within the shared span are decoded, and so are the other file's messages of the same
stretch of time; the two logs hold the same people when at least half of one's detections
have one of the other's within :data:`NEAR_S` and :data:`NEAR_M` on each axis (same topic,
same frame). Measured: Lincoln's two files 75 % and 85 % (either way round), ATC's train
and test of 10:00 0.6 % and 5 %. Logs that share less than :data:`TOLERANCES_PER_OVERLAP`
times :data:`NEAR_S` need evidence in proportion: a tolerance that short a stretch holds four
times over, and a share twice what chance proximity gives there (the leg_tracker bags
``positive_1`` and ``positive_2``, whose log times are their extraction's and share 0.27 s:
63 % at 0.05 s, but 90 % by chance, so no warning). Array work on a bounded sample.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from aion_cli.engine.types import F64
from aion_cli.formats.log_overlaps import Overlap, file_messages
from aion_cli.formats.raw import RawMessage

if TYPE_CHECKING:
    from aion_cli.formats.detections.adapter import DetectionAdapter

#: messages of the first log compared (its detections in them against the other's)
SAMPLE_MESSAGES = 1000
#: the other log's messages read at most, whatever its rate
MAX_OTHER_MESSAGES = 20 * SAMPLE_MESSAGES
#: how near in time (s) and on each axis (m) a detection of the other log is the same one
NEAR_S = 0.5
NEAR_M = 0.5
#: the stretch of time compared holds at least this many time tolerances (else it is shorter)
TOLERANCES_PER_OVERLAP = 4
#: two logs hold the same people when at least this share of one's detections match...
SAME_SHARE = 0.5
#: ... and this many times the share chance proximity gives (``_shared_time_share``)
ABOVE_CHANCE = 2.0
#: pairs of detections compared at most (memory: about 100 bytes each)
MAX_PAIRS = 2_000_000
#: stamps are taken relative to this (2020) so that seconds keep sub-microsecond precision
_EPOCH = 1_600_000_000 * 1_000_000_000

#: the adapter that decodes a (topic, msgtype, encoding): the build's own
AdapterOf = Callable[[str, str, str], "DetectionAdapter"]


def _read(
    logset: Any, index: int, topics: set[str], between: tuple[int, int], limit: int
) -> list[RawMessage]:
    """At most ``limit`` messages of file ``index`` with log times in ``between``."""
    out = []
    for m in file_messages(logset, index, topics, between):
        if between[0] <= m.log_time_ns < between[1]:
            out.append(m)
            if len(out) >= limit:
                break
    return out


def _detections(
    messages: list[RawMessage], adapter_of: AdapterOf, topics: tuple[str, ...] = ()
) -> F64:
    """Rows ``t (s), x, y, z, source`` of the detections of ``messages`` sorted by time;
    ``source`` tells topic (one of ``topics``; none when empty) and frame apart (detections
    of two sources never match)."""
    groups: dict[tuple[str, str, str], list[RawMessage]] = {}
    for m in messages:
        groups.setdefault((m.topic, m.msgtype, m.encoding), []).append(m)
    parts = [np.empty((0, 5))]
    for key, group in groups.items():
        found = adapter_of(*key).decode(group, on_error="skip")
        frames = np.array([zlib.crc32(f.encode()) for f in found.frames] or [0], np.float64)
        source = (topics.index(key[0]) * 2.0**32 if topics else 0.0) + frames[found.frame_id]
        rows = np.c_[(found.t_ns - _EPOCH) * 1e-9, found.xyz, source]
        parts.append(rows[np.isfinite(rows).all(axis=1)])
    rows = np.concatenate(parts)
    return rows[np.argsort(rows[:, 0], kind="stable")]


def _near_share(a: F64, b: F64, near_s: float = NEAR_S) -> float:
    """The share of ``a``'s rows that have a row of ``b`` (both sorted by time) within
    ``near_s`` in time and :data:`NEAR_M` on each axis, of the same source."""
    lo = np.searchsorted(b[:, 0], a[:, 0] - near_s, side="left")
    hi = np.searchsorted(b[:, 0], a[:, 0] + near_s, side="right")
    n = hi - lo
    if n.sum() > MAX_PAIRS:  # a dense stretch: compare its first rows only
        keep = int(np.searchsorted(np.cumsum(n), MAX_PAIRS, side="right"))
        a, lo, n = a[:keep], lo[:keep], n[:keep]
    if len(a) == 0:
        return 0.0
    ia = np.repeat(np.arange(len(a)), n)
    ib = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n) + np.repeat(lo, n)
    d = np.abs(a[ia, 1:4] - b[ib, 1:4]).max(axis=1)
    hit = (d <= NEAR_M) & (a[ia, 4] == b[ib, 4])
    matched = np.zeros(len(a), bool)
    matched[ia[hit]] = True
    return float(matched.mean())


def same_people(logset: Any, o: Overlap, adapter_of: AdapterOf) -> bool | None:
    """Whether the two files of ``o`` hold the same people in the time both cover (see the
    module docstring); ``None`` when there is nothing to compare (no detection of one in
    the stretch of time sampled, or of the other there)."""
    (i, j), topics = o.pair, set(o.topics)
    first = _read(logset, i, topics, (o.start_ns, o.end_ns + 1), SAMPLE_MESSAGES)
    if not first:
        return None
    span = (first[0].log_time_ns, first[-1].log_time_ns + 1)
    a = _detections(first, adapter_of, o.topics)
    b = _detections(_read(logset, j, topics, span, MAX_OTHER_MESSAGES), adapter_of, o.topics)
    shares = _shared_time_share(a, b)
    return None if shares is None else _same(shares)


class Shares(NamedTuple):
    """What :func:`_shared_time_share` found: the match ``share``, the share ``chance``
    proximity gives, and the time tolerance ``near_s`` (s) both were taken within."""

    share: float
    chance: float
    near_s: float


def _same(shares: Shares) -> bool:
    """Whether a match share says two logs (or topics) hold the same people: at least
    :data:`SAME_SHARE`, and :data:`ABOVE_CHANCE` times the chance share."""
    return shares.share >= SAME_SHARE and shares.share >= ABOVE_CHANCE * shares.chance


def _shared_time_share(a: F64, b: F64) -> Shares | None:
    """The larger :func:`_near_share` either way round, each against the other where both
    have detections (the other may start later, or a sample end sooner), and the share
    chance proximity gives there. Over a stretch of :data:`TOLERANCES_PER_OVERLAP` times
    :data:`NEAR_S` or more, time tells detections apart: the tolerance is :data:`NEAR_S`
    and chance 0. A shorter stretch (logs that share 0.3 s: two excerpts of one recording,
    their log times the extraction's) would match any detection of the one to any of the
    other nearby: the tolerance is a :data:`TOLERANCES_PER_OVERLAP`-th of it, and chance
    the share with ``b``'s times turned round by half the stretch (within it), so that no
    detection meets its own twin: people standing or walking in one place match so too, a
    copy's detections that move do not. None when there is no such time."""
    if len(a) == 0 or len(b) == 0:
        return None
    t0, t1 = max(a[0, 0], b[0, 0]) - NEAR_S, min(a[-1, 0], b[-1, 0]) + NEAR_S
    a, b = a[(a[:, 0] >= t0) & (a[:, 0] <= t1)], b[(b[:, 0] >= t0) & (b[:, 0] <= t1)]
    if len(a) == 0 or len(b) == 0:
        return None
    start = min(a[0, 0], b[0, 0])
    length = max(a[-1, 0], b[-1, 0]) - start
    near_s = min(NEAR_S, length / TOLERANCES_PER_OVERLAP)
    if near_s == 0:  # one instant: nothing tells a twin from a neighbour
        return None
    share = max(_near_share(a, b, near_s), _near_share(b, a, near_s))
    if near_s == NEAR_S:  # long enough for time to tell
        return Shares(share, 0.0, near_s)
    turned = b.copy()  # half the stretch later, the end's detections wrapped to its start
    turned[:, 0] = start + (b[:, 0] - start + length / 2) % (length + near_s)
    turned = turned[np.argsort(turned[:, 0], kind="stable")]
    chance = max(_near_share(a, turned, near_s), _near_share(turned, a, near_s))
    return Shares(share, chance, near_s)


def topic_twin_warnings(logset: Any, topics: list[str], adapter_of: AdapterOf) -> list[str]:
    """A warning per pair of the build's detection topics that hold the same people (two
    trackers of one sensor, a tracker's detections beside its tracks): at least half of one
    topic's detections in its first :data:`SAMPLE_MESSAGES` messages have one of the other's
    within :data:`NEAR_S` and :data:`NEAR_M`, in the same frame. Every topic is used, so each
    such person counts once per topic. Topics in other frames, or of other people, do not
    warn; nor does a topic the comparison cannot decode (the build says why)."""
    from itertools import islice

    from aion_cli.errors import AionError

    if len(topics) < 2:
        return []
    rows: dict[str, F64] = {}
    for topic in topics:
        first = list(islice(logset.messages([topic]), SAMPLE_MESSAGES))
        try:
            rows[topic] = _detections(first, adapter_of)
        except AionError:
            continue
    out = []
    named = [t for t in topics if t in rows and len(rows[t])]
    for i, a in enumerate(named):
        for b in named[i + 1 :]:
            shares = _shared_time_share(rows[a], rows[b])
            if shares is not None and _same(shares):
                share, near_s = shares.share, shares.near_s  # a short stretch: a finer time
                out.append(
                    f"{a} and {b} hold the same people at the same times and places ({share:.0%} "
                    f"of one's detections have one of the other's within {near_s:.3g} s and "
                    f"{NEAR_M:g} m): every person they both saw counts twice; build from one "
                    f"of them with --detections-topic {a}"
                )
    return out
