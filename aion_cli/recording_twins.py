"""One recording read from two log files, told from what maps' manifests store: the
``recordings`` field, per build its logs and a sample of their detections
(:class:`~aion_cli.engine.detection_sketch.DetectionSketch`).

Why beside the sha256 check (:mod:`aion_cli.provenance`, :mod:`aion_cli.merging`): a recording
converted again (``aion convert`` to another container, with other ``--observed`` spans),
copied with other metadata or cut at another start has another sha256, and the check of
equal map members (:mod:`aion_cli.merge_twins`) holds only for two maps of nothing else over
the very same span: a copy of a log inside a larger merged map, or one observed over other
spans, passed both, and its people counted twice. The samples hold the same detections
whatever the file, cut or build; two robots at the same hours or one place on other days
share none. So:

* ``aion merge`` refuses two input maps of which one's build and the other's sample one
  recording (:func:`check_merge`);
* ``aion build --map MAP`` refuses logs whose detections the map's builds sampled already:
  at the first batch of detections before the map's open window (which would otherwise be
  refused as out of time order, with a hint to rebuild from all logs, the copy included:
  :func:`check_batch`) and before writing (:func:`check_continued`).

Maps written before the field existed have no samples and are checked as before. Nothing
here reads a log.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from aion_cli.engine.detection_sketch import DetectionSketch, batch_alike, one_recording
from aion_cli.errors import InputError

if TYPE_CHECKING:
    from aion_cli.engine.types import F64, I64
    from aion_cli.manifest import Manifest

#: how far (ns) the logs' first and last message times may lie outside a recording's first
#: and last sampled detection for one to lie inside the other (:func:`check_batch`): log
#: times come a little after the stamps
SLACK_NS = 60 * 1_000_000_000
#: what a refusal says the two files are
_SAME = "hold the same detections"
_WHY = "one recording in two log files (converted, copied or cut), whose people would count twice"


def recording_entry(
    sketch: DetectionSketch, inputs: Sequence[dict[str, Any]]
) -> dict[str, Any] | None:
    """The ``recordings`` entry of a build: its logs (``inputs``: the report's, name and
    sha256) and the sample of their detections; None when it hashed no detection."""
    if sketch.first_ns is None:
        return None
    logs = [{"name": str(i.get("name", "")), "sha256": str(i.get("sha256", ""))} for i in inputs]
    return {"logs": logs, **sketch.to_dict()}


def recordings_after(
    previous: Manifest | None, entry: dict[str, Any] | None
) -> tuple[dict[str, Any], ...]:
    """A built map's ``recordings``: the continued map's, then this build's."""
    before = previous.recordings if previous is not None else ()
    return before if entry is None else (*before, entry)


def _sampled(recordings: Sequence[dict[str, Any]]) -> list[tuple[str, DetectionSketch]]:
    """The readable entries as (their logs' names, their sketch)."""
    out = []
    for entry in recordings:
        sketch = DetectionSketch.from_dict(entry)
        logs = entry.get("logs")
        if sketch is None or not isinstance(logs, list):
            continue
        names = [str(log.get("name", "?")) for log in logs if isinstance(log, dict)]
        out.append((", ".join(names) or "no log", sketch))
    return out


def _alike_text(same: int, compared: int) -> str:
    return f"{same} of {compared} sampled detections alike"


def check_continued(
    recordings: Sequence[dict[str, Any]], map_name: str, logs: str, sketch: DetectionSketch
) -> None:
    """:class:`InputError` when this build's detections (``sketch``, of the logs named
    ``logs``) are a recording the continued map ``map_name`` holds already (its
    ``recordings``; a parallel build's fold checks each shard's)."""
    for names, theirs in _sampled(recordings):
        found = one_recording(sketch, theirs)
        if found is not None:
            raise _continued_error(logs, names, map_name, _alike_text(*found))


def check_batch(
    previous: Manifest | None,
    map_name: str,
    logs: str,
    span: tuple[int | None, int | None],
    t_ns: I64,
    xyz: F64,
) -> None:
    """:class:`InputError` when a batch of detections of ``logs`` (whose messages span
    ``span``, log time) repeats those of a recording the continued map holds (every sample
    of it within the batch's time, at least :data:`~aion_cli.engine.detection_sketch.
    MIN_ALIKE`) and the logs' time and that recording's lie one inside the other (within
    :data:`SLACK_NS`): a copy, an excerpt or the original of one. Logs that only overlap the
    recording by some minutes are left to the refusal of data out of time order."""
    from aion_cli.engine.detection_sketch import MIN_ALIKE

    lo, hi = span
    if previous is None or lo is None or hi is None:
        return
    for names, theirs in _sampled(previous.recordings):
        first, last = theirs.first_ns, theirs.last_ns
        if first is None or last is None:  # (a stored sketch has them)
            continue
        inside = (lo >= first - SLACK_NS and hi <= last + SLACK_NS) or (
            first >= lo - SLACK_NS and last <= hi + SLACK_NS
        )
        if not inside:
            continue
        same, compared = batch_alike(theirs, t_ns, xyz)
        if same >= MIN_ALIKE and same == compared:
            raise _continued_error(logs, names, map_name, _alike_text(same, compared))


def _continued_error(logs: str, names: str, map_name: str, alike: str) -> InputError:
    return InputError(
        f"{logs} and {names} (in {map_name}) {_SAME} ({alike}): {_WHY}; nothing was added",
        hint=f"leave {logs} out: {map_name} holds its recording already "
        "(aion info MAP lists a map's logs)",
    )


def check_merge(maps: Sequence[Any]) -> None:
    """:class:`InputError` naming two input maps (each ``.name`` and ``.manifest``) and
    their logs when a build of one and a build of the other sampled one recording."""
    sampled = [(m, _sampled(m.manifest.recordings)) for m in maps]
    for k, (first, mine) in enumerate(sampled):
        for other, theirs in sampled[k + 1 :]:
            for names, a in mine:
                for other_names, b in theirs:
                    found = one_recording(a, b)
                    if found is not None:
                        raise InputError(
                            f"{first.name} ({names}) and {other.name} ({other_names}) {_SAME} "
                            f"({_alike_text(*found)}): {_WHY}",
                            hint=f"merge without {other.name}, or rebuild it without "
                            f"{other_names} (aion info MAP lists a map's logs)",
                        )
