"""Which adapter reads which message type: ``adapter_for(msgtype)`` on normalised names
(``pkg/msg/Type``; other spellings are normalised first)."""

from __future__ import annotations

from functools import partial
from typing import TYPE_CHECKING

from formats.detections.adapter import DetectionAdapter, Extractor, FastDecoder
from formats.detections.builtin import (
    SPECS,
    AdapterOptions,
    Detection3DExtractor,
    MarkerExtractor,
    ZedExtractor,
)
from formats.detections.fast import (
    ClassFilter,
    decode_detection3d,
    decode_people,
    decode_pose_array,
    decode_tracked_persons,
)
from formats.raw import normalize_msgtype

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

#: Types decoded with numpy straight from the bytes (both encodings).
FAST_TYPES: tuple[str, ...] = (
    "geometry_msgs/msg/PoseArray",
    "spencer_tracking_msgs/msg/TrackedPersons",
    "people_msgs/msg/People",
    "vision_msgs/msg/Detection3DArray",
)

#: Every message type with a built-in adapter (normalised names).
SUPPORTED_TYPES: tuple[str, ...] = (
    *SPECS,
    "vision_msgs/msg/Detection3DArray",
    "visualization_msgs/msg/MarkerArray",
    "zed_interfaces/msg/ObjectsStamped",
    "zed_msgs/msg/ObjectsStamped",
)


def adapter_for(
    msgtype: str,
    typestore: Typestore | None = None,
    options: AdapterOptions | None = None,
) -> DetectionAdapter | None:
    """The adapter for ``msgtype``, or None if aion has no built-in adapter for it (a TOML
    mapping, :mod:`formats.detections.mapping`, can still read it).

    ``typestore``: deserialize generic types with it (e.g. a typestore built from the log's
    embedded definitions); None uses aion's shipped definitions."""
    name = normalize_msgtype(msgtype)
    opts = options or AdapterOptions()
    extract: Extractor
    fast: FastDecoder | None = None
    if name in SPECS:
        extract = SPECS[name].extract
    elif name == "vision_msgs/msg/Detection3DArray":
        extract = Detection3DExtractor(opts)
        fast = partial(decode_detection3d, flt=ClassFilter(opts.class_names, opts.class_ids))
    elif name == "visualization_msgs/msg/MarkerArray":
        extract = MarkerExtractor(opts)
    elif name in ("zed_interfaces/msg/ObjectsStamped", "zed_msgs/msg/ObjectsStamped"):
        extract = ZedExtractor(opts)
    else:
        return None
    if name == "geometry_msgs/msg/PoseArray":
        fast = decode_pose_array
    elif name == "spencer_tracking_msgs/msg/TrackedPersons":
        fast = decode_tracked_persons
    elif name == "people_msgs/msg/People":
        fast = decode_people
    return DetectionAdapter(name, extract, fast, typestore)
