"""ROS 1 and ROS 2 message definitions of every message type aion reads or writes.

Robot logs normally embed their own definitions, but old ROS 2 ``.db3`` bags do not, and the test
and simulator logs are written without a ROS installation. This module therefore ships the
definitions of the Hydra scene-graph message, TF and the people-detection messages of DESIGN.md §6
(field order as upstream, so the wire layout matches real logs), registers them in rosbags
typestores, and renders full definition texts (main type plus ``MSG: pkg/Type`` dependency blocks)
for MCAP schemas and bag connection headers.

Standard packages (std_msgs, geometry_msgs, sensor_msgs, visualization_msgs, ...) come from the
rosbags base stores ``ROS1_NOETIC`` and ``ROS2_HUMBLE``; only the types those stores lack are
defined here.
"""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING, Literal

from aion_cli.errors import InputError
from aion_cli.formats.raw import normalize_msgtype

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

RosVersion = Literal[1, 2]


class UnknownMessageTypeError(InputError):
    """A message type is not among the definitions aion ships."""


# --- definitions shared by ROS 1 and ROS 2 (the header line differs only in spelling) ---------

_COMMON: dict[str, str] = {
    "hydra_msgs/msg/DsgUpdate": """
std_msgs/Header header
uint8[] layer_contents  # serialized nodes that are active
uint64[] deleted_nodes  # node ids that were deleted
uint64[] deleted_edges  # node ids for edges that were deleted
bool full_update       # whether or not the message contains the entire scene graph
int64 sequence_number  # update index
""",
    "spencer_tracking_msgs/msg/TrackedPerson": """
uint64 track_id
bool is_occluded
bool is_matched
uint64 detection_id
builtin_interfaces/Duration age
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist
""",
    "spencer_tracking_msgs/msg/TrackedPersons": """
std_msgs/Header header
spencer_tracking_msgs/TrackedPerson[] tracks
""",
    "spencer_tracking_msgs/msg/DetectedPerson": """
uint64 detection_id
float64 confidence
geometry_msgs/PoseWithCovariance pose
string modality
string MODALITY_GENERIC_LASER_2D = "laser2d"
string MODALITY_GENERIC_LASER_3D = "laser3d"
string MODALITY_GENERIC_MONOCULAR_VISION = "mono"
string MODALITY_GENERIC_STEREO_VISION = "stereo"
string MODALITY_GENERIC_RGBD = "rgbd"
""",
    "spencer_tracking_msgs/msg/DetectedPersons": """
std_msgs/Header header
spencer_tracking_msgs/DetectedPerson[] detections
""",
    "people_msgs/msg/Person": """
string name
geometry_msgs/Point position
geometry_msgs/Point velocity
float64 reliability
string[] tagnames
string[] tags
""",
    "people_msgs/msg/People": """
std_msgs/Header header
people_msgs/Person[] people
""",
    "people_msgs/msg/PositionMeasurement": """
std_msgs/Header header
string name
string object_id
geometry_msgs/Point pos
float64 reliability
float64[9] covariance
byte initialization
""",
    "people_msgs/msg/PositionMeasurementArray": """
std_msgs/Header header
people_msgs/PositionMeasurement[] people
float32[] cooccurrence
""",
    "leg_tracker/msg/Person": """
geometry_msgs/Pose pose
uint32 id
""",
    "leg_tracker/msg/PersonArray": """
std_msgs/Header header
leg_tracker/Person[] people
""",
    "pedsim_msgs/msg/AgentForce": """
geometry_msgs/Vector3 desired_force
geometry_msgs/Vector3 obstacle_force
geometry_msgs/Vector3 social_force
geometry_msgs/Vector3 group_coherence_force
geometry_msgs/Vector3 group_gaze_force
geometry_msgs/Vector3 group_repulsion_force
geometry_msgs/Vector3 random_force
geometry_msgs/Vector3 keep_distance_force
""",
    "pedsim_msgs/msg/AgentState": """
std_msgs/Header header
uint64 id
uint16 type
string social_state
geometry_msgs/Pose pose
geometry_msgs/Twist twist
pedsim_msgs/AgentForce forces
string TYPE_STANDING = "standing"
string TYPE_INDIVIDUAL_MOVING = "individual_moving"
string TYPE_WAITING_IN_QUEUE = "waiting_in_queue"
string TYPE_GROUP_MOVING = "group_moving"
""",
    "pedsim_msgs/msg/AgentStates": """
std_msgs/Header header
pedsim_msgs/AgentState[] agent_states
""",
    "nav2_dynamic_msgs/msg/Obstacle": """
unique_identifier_msgs/UUID uuid
float32 score
geometry_msgs/Point position
geometry_msgs/Vector3 velocity
geometry_msgs/Vector3 size
""",
    "nav2_dynamic_msgs/msg/ObstacleArray": """
std_msgs/Header header
nav2_dynamic_msgs/Obstacle[] obstacles
""",
    "vision_msgs/msg/BoundingBox3D": """
geometry_msgs/Pose center
geometry_msgs/Vector3 size
""",
}

# --- ROS 1 only ---------------------------------------------------------------------------------

_ROS1: dict[str, str] = {
    "tf2_msgs/msg/TFMessage": """
geometry_msgs/TransformStamped[] transforms
""",
    "unique_identifier_msgs/msg/UUID": """
uint8[16] uuid
""",
    # vision_msgs 0.0.x (noetic): class id as int64, the source cloud inside each detection.
    "vision_msgs/msg/ObjectHypothesisWithPose": """
int64 id
float64 score
geometry_msgs/PoseWithCovariance pose
""",
    "vision_msgs/msg/Detection3D": """
std_msgs/Header header
vision_msgs/ObjectHypothesisWithPose[] results
vision_msgs/BoundingBox3D bbox
sensor_msgs/PointCloud2 source_cloud
""",
    "vision_msgs/msg/Detection3DArray": """
std_msgs/Header header
vision_msgs/Detection3D[] detections
""",
}

# --- ROS 2 only ---------------------------------------------------------------------------------

_ROS2: dict[str, str] = {
    # vision_msgs >= 3 (galactic and later): string class id, string tracking id per detection.
    "vision_msgs/msg/ObjectHypothesis": """
string class_id
float64 score
""",
    "vision_msgs/msg/ObjectHypothesisWithPose": """
vision_msgs/ObjectHypothesis hypothesis
geometry_msgs/PoseWithCovariance pose
""",
    "vision_msgs/msg/Detection3D": """
std_msgs/Header header
vision_msgs/ObjectHypothesisWithPose[] results
vision_msgs/BoundingBox3D bbox
string id
""",
    "vision_msgs/msg/Detection3DArray": """
std_msgs/Header header
vision_msgs/Detection3D[] detections
""",
}


def _zed(pkg: str, ros_version: RosVersion) -> dict[str, str]:
    """The ZED object-detection messages: ``zed_interfaces`` (ROS 1 and ROS 2 before the
    2024-11 rename) and ``zed_msgs`` (ROS 2). ROS 1 carries ``instance_id``; ROS 2 drops it and
    adds ``body_format``, 70-keypoint skeletons and per-keypoint confidences."""
    if ros_version == 1:
        obj = f"""
string label
int16 label_id
int16 instance_id
string sublabel
float32 confidence
float32[3] position
float32[6] position_covariance
float32[3] velocity
bool tracking_available
int8 tracking_state
int8 action_state
{pkg}/BoundingBox2Di bounding_box_2d
{pkg}/BoundingBox3D bounding_box_3d
float32[3] dimensions_3d
bool skeleton_available
{pkg}/BoundingBox2Df head_bounding_box_2d
{pkg}/BoundingBox3D head_bounding_box_3d
float32[3] head_position
{pkg}/Skeleton2D skeleton_2d
{pkg}/Skeleton3D skeleton_3d
"""
        keypoints = 18
    else:
        obj = f"""
string label
int16 label_id
string sublabel
float32 confidence
float32[3] position
float32[6] position_covariance
float32[3] velocity
bool tracking_available
int8 tracking_state
int8 action_state
{pkg}/BoundingBox2Di bounding_box_2d
{pkg}/BoundingBox3D bounding_box_3d
float32[3] dimensions_3d
bool skeleton_available
int8 body_format
{pkg}/BoundingBox2Df head_bounding_box_2d
{pkg}/BoundingBox3D head_bounding_box_3d
float32[3] head_position
{pkg}/Skeleton2D skeleton_2d
{pkg}/Skeleton3D skeleton_3d
float32[70] skeleton_keypoint_confidence
"""
        keypoints = 70
    return {
        f"{pkg}/msg/Keypoint2Di": "uint32[2] kp\n",
        f"{pkg}/msg/Keypoint2Df": "float32[2] kp\n",
        f"{pkg}/msg/Keypoint3D": "float32[3] kp\n",
        f"{pkg}/msg/BoundingBox2Di": f"{pkg}/Keypoint2Di[4] corners\n",
        f"{pkg}/msg/BoundingBox2Df": f"{pkg}/Keypoint2Df[4] corners\n",
        f"{pkg}/msg/BoundingBox3D": f"{pkg}/Keypoint3D[8] corners\n",
        f"{pkg}/msg/Skeleton2D": f"{pkg}/Keypoint2Df[{keypoints}] keypoints\n",
        f"{pkg}/msg/Skeleton3D": f"{pkg}/Keypoint3D[{keypoints}] keypoints\n",
        f"{pkg}/msg/Object": obj,
        f"{pkg}/msg/ObjectsStamped": f"std_msgs/Header header\n{pkg}/Object[] objects\n",
    }


def _sources(ros_version: RosVersion) -> dict[str, str]:
    """Definition texts of the types aion adds to the base store of ``ros_version``."""
    if ros_version == 1:
        return {**_COMMON, **_ROS1, **_zed("zed_interfaces", 1)}
    return {**_COMMON, **_ROS2, **_zed("zed_interfaces", 2), **_zed("zed_msgs", 2)}


_TOP_LEVEL_BOTH = (
    "hydra_msgs/msg/DsgUpdate",
    "tf2_msgs/msg/TFMessage",
    "geometry_msgs/msg/PoseArray",
    "geometry_msgs/msg/PoseStamped",
    "spencer_tracking_msgs/msg/TrackedPersons",
    "spencer_tracking_msgs/msg/DetectedPersons",
    "people_msgs/msg/People",
    "people_msgs/msg/PositionMeasurementArray",
    "leg_tracker/msg/PersonArray",
    "vision_msgs/msg/Detection3DArray",
    "visualization_msgs/msg/MarkerArray",
    "pedsim_msgs/msg/AgentStates",
    "nav2_dynamic_msgs/msg/ObstacleArray",
    "zed_interfaces/msg/ObjectsStamped",
)

SUPPORTED_MSGTYPES: dict[int, tuple[str, ...]] = {
    1: _TOP_LEVEL_BOTH,
    2: (*_TOP_LEVEL_BOTH, "zed_msgs/msg/ObjectsStamped"),
}
"""The top-level message types with shipped definitions, per ROS version (normalised names)."""


def _check_version(ros_version: int) -> RosVersion:
    if ros_version == 1:
        return 1
    if ros_version == 2:
        return 2
    raise ValueError(f"ros_version must be 1 or 2, not {ros_version!r}")


_TIME = "builtin_interfaces/msg/Time"


def base_typestore(ros_version: int) -> Typestore:
    """A new rosbags base store (``ROS1_NOETIC`` or ``ROS2_HUMBLE``), every ROS 1 ``time``
    read and written with unsigned seconds.

    ROS 1 ``time`` is two uint32 (seconds to 2106-02-07), but rosbags maps it to ROS 2's
    ``builtin_interfaces/msg/Time``, whose seconds are an int32: a ROS 1 stamp after
    2038-01-19 03:14:07 UTC was read 2^32 s early (TF and scene graphs of a 2040 bag in 1903)
    and could not be written (``struct.error``). The ROS 1 store's Time has uint32 seconds
    instead; the bytes of every stamp to 2038 and every definition text and MD5 sum are
    unchanged (rosbags renders the type as ``time``). ROS 2's Time keeps its signed seconds.
    """
    from rosbags.typesys import Stores, get_typestore
    from rosbags.typesys.base import Nodetype

    store = get_typestore(Stores.ROS1_NOETIC if ros_version == 1 else Stores.ROS2_HUMBLE)
    if ros_version == 1:  # the store's own copy of the definitions: nothing shared changes
        store.fielddefs[_TIME] = (
            [],
            [
                ("sec", (Nodetype.BASE, ("uint32", 0))),
                ("nanosec", (Nodetype.BASE, ("uint32", 0))),
            ],
        )
    return store


@cache
def typestore(ros_version: RosVersion) -> Typestore:
    """A rosbags typestore (``ROS1_NOETIC`` or ``ROS2_HUMBLE`` base) with every shipped type.

    Cached per version: building it compiles serializers, so callers share one instance and
    must not register conflicting types in it.
    """
    from rosbags.typesys import get_types_from_msg

    version = _check_version(ros_version)
    store = base_typestore(version)
    types = {}
    for name, text in _sources(version).items():
        if name not in store.fielddefs:
            types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


@cache
def _rendered(msgtype: str, ros_version: RosVersion) -> tuple[str, str]:
    store = typestore(ros_version)
    if msgtype not in store.fielddefs:
        known = ", ".join(SUPPORTED_MSGTYPES[ros_version])
        raise UnknownMessageTypeError(
            f"no ROS {ros_version} definition for message type {msgtype!r}",
            hint=f"aion ships definitions for: {known} (and their dependencies)",
        )
    text, md5 = store.generate_msgdef(msgtype, ros_version=ros_version)
    return text, md5


def definition(msgtype: str, ros_version: int) -> str:
    """Full definition text of ``msgtype`` for ROS ``ros_version``: the type's own fields, then
    one ``====`` separated ``MSG: pkg/Type`` block per dependency (the ``ros1msg`` / ``ros2msg``
    schema format of MCAP and the connection header format of ROS 1 bags).

    ``msgtype`` may be spelled ``pkg/Type`` or ``pkg/msg/Type``; standard types from the rosbags
    base store are accepted too. Raises :class:`UnknownMessageTypeError` for anything else.
    """
    return _rendered(normalize_msgtype(msgtype), _check_version(ros_version))[0]


def md5sum(msgtype: str) -> str:
    """ROS 1 md5sum of ``msgtype`` (what ``rosmsg md5`` and bag connection headers carry)."""
    return _rendered(normalize_msgtype(msgtype), 1)[1]
