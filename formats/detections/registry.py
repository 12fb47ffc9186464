"""Which adapter reads which message type: ``adapter_for(msgtype)`` on normalised names
(``pkg/msg/Type``; other spellings are normalised first)."""

from __future__ import annotations

from functools import partial
from typing import TYPE_CHECKING

from aion_cli.formats.detections.adapter import DetectionAdapter, Extractor, FastDecoder
from aion_cli.formats.detections.builtin import (
    SPECS,
    AdapterOptions,
    Detection3DExtractor,
    ZedExtractor,
)
from aion_cli.formats.detections.fast import (
    ClassFilter,
    decode_detection3d,
    decode_people,
    decode_pose_array,
    decode_tracked_persons,
)
from aion_cli.formats.detections.markers import MarkerExtractor
from aion_cli.formats.raw import normalize_msgtype

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
    "visualization_msgs/msg/Marker",
    "zed_interfaces/msg/ObjectsStamped",
    "zed_msgs/msg/ObjectsStamped",
)

#: Raw sensor data (normalised names): no positions of people in them for a mapping to read;
#: a people detector or tracker turns them into detections first. (sensor_msgs/PointCloud is
#: not one: its Point32 array may hold people, and a mapping reads it.)
RAW_SENSOR_TYPES: frozenset[str] = frozenset(
    f"sensor_msgs/msg/{name}"
    for name in (
        "LaserScan", "MultiEchoLaserScan", "PointCloud2", "Image",
        "CompressedImage", "CameraInfo", "Imu", "Range", "NavSatFix", "MagneticField",
        "JointState", "Temperature", "FluidPressure", "RelativeHumidity", "Illuminance",
        "BatteryState", "Joy", "LaserEcho", "TimeReference",
    )
)

#: Packages of ROS's own plumbing (logging, parameters, diagnostics, plain values): their
#: types hold no positions for a mapping to read either.
PLUMBING_PACKAGES: frozenset[str] = frozenset({
    "std_msgs", "rcl_interfaces", "rosgraph_msgs", "diagnostic_msgs", "actionlib_msgs",
    "lifecycle_msgs", "rosbag2_interfaces", "statistics_msgs", "service_msgs",
    "type_description_interfaces", "bond", "dynamic_reconfigure", "roscpp",
})


def unreadable_kind(msgtype: str) -> str | None:
    """What a type no adapter and no mapping can read people from is ("raw sensor data",
    "ROS plumbing": logging, parameters, plain values, or :data:`SERVICE_EVENTS`), None for a
    type a TOML mapping may read."""
    name = normalize_msgtype(msgtype)
    if name in RAW_SENSOR_TYPES:
        return "raw sensor data"
    if name.split("/", 1)[0] in PLUMBING_PACKAGES:
        return "ROS plumbing"
    if "/srv/" in name and name.endswith("_Event"):
        return SERVICE_EVENTS
    return None


SERVICE_EVENTS = "service events"
"""The kind of a ROS 2 service-introspection topic (``pkg/srv/Name_Event``, recorded calls of a
service): the log defines its type as the service (request ``---`` response), which no
mapping reads."""


RAW_SENSOR_HINT = (
    "record what a people detector or tracker makes of it (e.g. leg_tracker's /people_tracked, "
    "spencer's TrackedPersons) and build from that"
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
    elif name in ("visualization_msgs/msg/MarkerArray", "visualization_msgs/msg/Marker"):
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


def fast_layout_matches(msgtype: str, encoding: str, definition: str, idl: bool = False) -> bool:
    """Whether a log's own ``definition`` of ``msgtype`` (for messages in ``encoding``) has the
    layout aion's numpy fast decoder of that type was written for (:func:`msg_layouts.same_layout`
    against the shipped definition: ROS 1 noetic / ROS 2 galactic+ layouts). A log that embeds
    no definition is assumed to use the shipped one."""
    from aion_cli.formats import msg_layouts

    ros_version = 1 if encoding == "ros1" else 2
    return msg_layouts.same_layout(definition, normalize_msgtype(msgtype), ros_version, idl)


def log_adapter(
    msgtype: str,
    encoding: str,
    definition: str,
    idl: bool,
    typestore: Typestore | None,
    options: AdapterOptions | None = None,
) -> DetectionAdapter | None:
    """The built-in adapter for one topic of a log: messages are deserialized with
    ``typestore`` (built from the log's own definitions), and the numpy fast decoder is used
    only when :func:`fast_layout_matches` -- otherwise it would read another layout's bytes as
    its own, or reject every message. None when aion has no adapter for ``msgtype``."""
    adapter = adapter_for(msgtype, typestore, options)
    if adapter is None:
        return None
    if adapter.fast is not None and not fast_layout_matches(msgtype, encoding, definition, idl):
        adapter.fast = None
        adapter.layout_differs = True
    return adapter
