"""Which detection frames a log's TF cannot bring into the map frame, found before a build.

``aion info`` reads the first messages of every detection topic (their frames) and the first
messages of every TF topic (the static transforms all come early; the dynamic ones name their
frames from the start), joins the frames the transforms connect, and names the detection
frames left apart from ``map``. A build would stop on them with "no TF to 'map'"; info says
so first, with the ``--map-frame`` that builds such a log. Reading a sample keeps info fast on
any log; a chain that only later TF messages complete is reported too (the note says what was
read).
"""

from __future__ import annotations

from itertools import islice
from typing import Any

from aion_cli.build_options import DEFAULT_MAP_FRAME

#: detection messages per topic whose frames are read
DETECTION_SAMPLE = 20
#: TF messages per TF topic that are read
TF_SAMPLE = 500


def unconnected_frames(logset: Any, plan: Any, mappings: list[Any]) -> dict[str, list[str]]:
    """Per detection topic of ``plan``, the frames of its first messages that the log's TF
    (its first messages per TF topic) does not connect to ``map``; topics whose frames are
    all connected, or that cannot be decoded (the build reports those), are left out."""
    from aion_cli.formats.tf import normalize_frame

    frames = detection_frames(logset, plan, mappings)
    if not frames:
        return {}
    linked = _connected_to_map(logset, plan)
    out: dict[str, list[str]] = {}
    for topic, names in frames.items():
        apart = sorted(
            f for f in {normalize_frame(n) for n in names} if f and f not in linked
        )
        if apart:
            out[topic] = apart
    return out


def detection_frames(logset: Any, plan: Any, mappings: list[Any]) -> dict[str, set[str]]:
    """The frames of each detection topic's first :data:`DETECTION_SAMPLE` messages, decoded
    as the build decodes them (with ``mappings``, the ``--detections-mapping`` topics)."""
    from aion_cli.detection_feed import log_adapters
    from aion_cli.errors import AionError

    try:
        adapters, _factory, _notes = log_adapters(
            logset, plan.detections, {m.topic: m for m in mappings}
        )
    except AionError:
        return {}
    out: dict[str, set[str]] = {}
    for info in plan.detections:
        sample = _first(logset, info.topic, DETECTION_SAMPLE)
        adapter = adapters.get((info.topic, info.msgtype, info.encoding))
        if adapter is None or not sample:
            continue
        try:
            out[info.topic] = set(adapter.decode(sample).frame_names())
        except AionError:
            continue
    return out


def _connected_to_map(logset: Any, plan: Any) -> set[str]:
    """The frames the first :data:`TF_SAMPLE` messages of each TF topic join to ``map``
    (read as a build reads TF: :class:`aion_cli.tf_feed.TfReader`), ``map`` included."""
    from aion_cli.formats.tf import TfBuffer
    from aion_cli.tf_feed import TfReader, TfStats

    reader = TfReader(logset, TfBuffer(), TfStats())
    for info in plan.tf:
        reader.add(_first(logset, info.topic, TF_SAMPLE))
    return reader.buffer.connected(DEFAULT_MAP_FRAME)


def _first(logset: Any, topic: str, n: int) -> list[Any]:
    return list(islice(logset.messages([topic]), n))
