"""Maps of one recording read from two log files (:func:`check_same_recording`), which the
provenance check of ``aion merge`` cannot see.

A log is never counted twice: :mod:`aion_cli.merging` refuses a log (by sha256) that two
maps hold. A recording written to two files (converted to another container, re-recorded
with ``ros2 bag convert``, copied with other metadata) has two sha256s, so the maps built from
each passed that check, and the merge counted every detection twice with nothing but the
note that their times overlap (two robots at once overlap as well). Such maps hold the same
entries (their cells, nodes, counts, speed and heading sums) over the same time span, byte
for byte: the manifest's member checksums say so without reading a state. Two recordings of
different people cannot give that (their sums would differ), so the merge refuses them; maps
that hold no detection are left out (two robots that saw nobody along the same route may
well hold the same empty entries).

That holds only for two maps of nothing else over the very same span: a copy inside a
larger merged map, or one observed over other spans or cut at another start, has other
entries. Maps whose builds sampled their detections (the manifest's ``recordings``) are
compared by those samples first (:mod:`aion_cli.recording_twins`), which catches them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from aion_cli.manifest import Manifest
    from aion_cli.mapquery import MapHead

#: the members that hold a map's entries (cells and nodes, their counts, speed and heading
#: sums; the open window's included) and the times of their detections (the counts' Fourier
#: sums and hour-of-week profile, absorbed and pending): equal in two maps, they hold the same
#: detections at the same times. The entries alone are not enough: a log of the same people a
#: day later, built with the same declared span, holds the same entries at other times
TWIN_PREFIXES = ("entry_", "temporal_cnt_", "pending_cnt_")


class TwinInput(Protocol):
    """What the check reads of an input map."""

    @property
    def name(self) -> str: ...

    head: MapHead
    manifest: Manifest


def check_same_recording(maps: Sequence[TwinInput]) -> None:
    """:class:`~aion_cli.errors.InputError` naming two maps (and their logs) of which
    builds sampled one recording (:func:`aion_cli.recording_twins.check_merge`), or, for
    maps written before they were sampled, that hold the same detections over the same time
    span (see the module docstring)."""
    from aion_cli.errors import InputError
    from aion_cli.recording_twins import check_merge

    check_merge(maps)

    seen: dict[tuple[object, ...], TwinInput] = {}
    for m in maps:
        key = _fingerprint(m)
        if key is None:
            continue
        first = seen.setdefault(key, m)
        if first is m:
            continue
        logs = [", ".join(log.name for log in x.manifest.inputs) or "no log" for x in (first, m)]
        raise InputError(
            f"{first.name} ({logs[0]}) and {m.name} ({logs[1]}) hold the same detections over "
            "the same time: one recording in two log files (converted or copied), whose "
            "people would count twice",
            hint="merge one of the two maps (aion info MAP lists a map's logs)",
        )


def _fingerprint(m: TwinInput) -> tuple[object, ...] | None:
    """The map's time span and the checksums of its entry and count members; None for a map without
    detections or without a span or member checksums (nothing to compare)."""
    members = m.head.manifest.get("members")
    if m.head.accepted <= 0 or m.manifest.start_ns is None or not isinstance(members, dict):
        return None
    sums = sorted(
        (name, str(record.get("sha256")))
        for name, record in members.items()
        if name.startswith(TWIN_PREFIXES) and isinstance(record, dict)
    )
    if not sums:
        return None
    return (m.manifest.start_ns, m.manifest.end_ns, *sums)
