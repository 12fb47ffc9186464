"""People detections from robot-log messages, as arrays.

``adapter_for(msgtype)`` returns a :class:`DetectionAdapter` for every type of
``SUPPORTED_TYPES``; ``adapter.decode(raw_messages)`` gives :class:`FrameDetections` (message
frames). The common types are decoded with numpy straight from the bytes (:mod:`.fast`), the
rest through rosbags objects (:mod:`.builtin`, :mod:`.generic`); for a log,
:func:`~formats.detections.registry.log_adapter` decodes with the log's own definitions and
keeps the numpy path only where they have its layout. :mod:`.mapping` reads any other type
from a TOML field mapping, and :mod:`.suggest` writes one from a type's definition.
Headings from tracks (``aion_cli.engine.heading.HeadingEstimator``) are the engine's job: it
turns map-frame detections into the engine's :class:`~aion_cli.engine.types.DetectionBatch`.
"""

from aion_cli.formats.detections.adapter import DetectionAdapter
from aion_cli.formats.detections.builtin import AdapterOptions
from aion_cli.formats.detections.frame import FrameDetections, hash_id
from aion_cli.formats.detections.mapping import TopicMapping, load_mapping
from aion_cli.formats.detections.registry import FAST_TYPES, SUPPORTED_TYPES, adapter_for

__all__ = [
    "FAST_TYPES",
    "SUPPORTED_TYPES",
    "AdapterOptions",
    "DetectionAdapter",
    "FrameDetections",
    "TopicMapping",
    "adapter_for",
    "hash_id",
    "load_mapping",
]
