"""The adapters of a build's detection topics: :func:`log_adapters` builds each topic's
adapter from the log's own definition of its type (or the user's TOML mapping) before anything
is read, so that a bad mapping or an unreadable definition stops the build at once;
:func:`default_factory` gives the built-in adapter with aion's shipped definitions when there is
no log at hand. :class:`aion_cli.detection_feed.DetectionFeeder` decodes with them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from itertools import islice
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from aion_cli.formats.detections import DetectionAdapter

#: Builds the adapter of one (topic, message type, encoding) the first time it is seen.
AdapterFactory = Callable[[str, str, str], "DetectionAdapter"]


def default_factory(topic: str, msgtype: str, encoding: str) -> DetectionAdapter:
    """The built-in adapter with aion's shipped definitions (no log at hand)."""
    from aion_cli.errors import TopicNotFoundError
    from aion_cli.formats.detections import adapter_for

    adapter = adapter_for(msgtype)
    if adapter is None:
        raise TopicNotFoundError(f"no people-detection adapter for {msgtype} on {topic!r}")
    return adapter


def log_adapters(
    logset: Any, topics: list[Any], mappings: Mapping[str, Any]
) -> tuple[dict[tuple[str, str, str], DetectionAdapter], AdapterFactory, list[str]]:
    """The adapters of a build's detection ``topics`` (TopicInfo) in ``logset``, built now so
    that a bad mapping or an unreadable definition stops the build before anything is read;
    a factory for the same topic in another encoding (logs of both ROS versions); and notes
    on topics whose log definition keeps them off the numpy fast path.

    Every adapter deserializes with a typestore built from the log's own definition of its
    topic's type; the fast decoder is kept only where that definition has the layout it was
    written for; a topic of ``mappings`` (topic -> TopicMapping) is read with its mapping,
    checked against the log's definition."""
    from aion_cli.errors import TopicNotFoundError
    from aion_cli.formats.detections.registry import log_adapter

    def factory(topic: str, msgtype: str, encoding: str) -> DetectionAdapter:
        store = logset.typestore(topic, msgtype, encoding)
        mapping = mappings.get(topic)
        if mapping is not None:
            adapter: DetectionAdapter = mapping.check(store).adapter(store)
            return adapter
        definition, idl = logset.definition(topic, msgtype, encoding)
        found = log_adapter(msgtype, encoding, definition, idl, store)
        if found is None:
            raise TopicNotFoundError(
                f"no people-detection adapter for {msgtype} on {topic!r}",
                hint="map it with --detections-mapping FILE",
            )
        if getattr(found.extract, "learn", None) is not None:  # the Marker reader's id rule
            from aion_cli.formats.detections.markers import ID_SAMPLE, learn_ids

            learn_ids(found, islice(logset.messages([topic]), ID_SAMPLE), encoding)
        return found

    adapters = {}
    notes = []
    for info in topics:
        key = (info.topic, info.msgtype, info.encoding)
        adapter = adapters[key] = factory(*key)
        said = getattr(adapter.extract, "describe", None)
        if said is not None and said():
            notes.append(f"{info.topic}: {said()}")
        if adapter.layout_differs:
            notes.append(
                f"{info.topic}: the log's definition of {info.msgtype} differs from the layout "
                "of aion's fast decoder; its messages are decoded with the log's own definition"
            )
    return adapters, factory, notes
