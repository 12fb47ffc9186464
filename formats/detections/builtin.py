"""Generic (rosbags-object) extractors of the built-in detection types, DESIGN.md §6 and
notes-formats.md §3. Most are plain :class:`ItemSpec` field paths; Detection3DArray and ZED
need a few lines of logic (class filters, id fields that differ between ROS versions);
Marker and MarkerArray have a module of their own (:mod:`.markers`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from aion_cli.formats.detections.frame import hash_id
from aion_cli.formats.detections.generic import NAN_Q, NAN_V, ItemSpec, Rows
from aion_cli.formats.detections.paths import quat4, stamp_ns, vec3

#: spencer convention: a variance above this means "this component is not set".
UNSET_VARIANCE = 99999.0


@dataclass(frozen=True)
class AdapterOptions:
    """Per-adapter choices.

    - ``class_names``: vision_msgs ROS 2 ``class_id`` values that are people (exact match;
      ZED labels match case-insensitively); None keeps every detection.
    - ``class_ids``: vision_msgs ROS 1 integer class ids that are people; None keeps all
      (ROS 1 ids are dataset-specific, so there is no default).
    - ``marker_ns``: regular expression a MarkerArray marker's ``ns`` must match (search).
    """

    class_names: tuple[str, ...] | None = ("person",)
    class_ids: tuple[int, ...] | None = None
    marker_ns: str | None = None


def _spencer_adjust(
    it: Any, vel: tuple[float, float, float], q: tuple[float, float, float, float]
) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
    """Velocity components / yaw whose variance exceeds 99999 are unset (spencer)."""
    tw = getattr(it, "twist", None)
    if tw is not None:
        cov = np.asarray(tw.covariance, np.float64)
        vel = tuple(  # type: ignore[assignment]
            math.nan if cov[k * 7] > UNSET_VARIANCE else v for k, v in enumerate(vel)
        )
    if np.asarray(it.pose.covariance, np.float64)[35] > UNSET_VARIANCE:
        q = NAN_Q
    return vel, q


SPECS: dict[str, ItemSpec] = {
    "geometry_msgs/msg/PoseArray": ItemSpec.of("poses", "position", orientation="orientation"),
    "geometry_msgs/msg/PoseStamped": ItemSpec.of(
        None, "pose.position", orientation="pose.orientation"
    ),
    "geometry_msgs/msg/PoseWithCovarianceStamped": ItemSpec.of(
        None, "pose.pose.position", orientation="pose.pose.orientation"
    ),
    "geometry_msgs/msg/PointStamped": ItemSpec.of(None, "point"),
    "spencer_tracking_msgs/msg/TrackedPersons": ItemSpec.of(
        "tracks", "pose.pose.position", "twist.twist.linear", "pose.pose.orientation",
        "track_id", adjust=_spencer_adjust,
    ),
    "spencer_tracking_msgs/msg/DetectedPersons": ItemSpec.of(
        "detections", "pose.pose.position", orientation="pose.pose.orientation",
        adjust=_spencer_adjust,
    ),
    "people_msgs/msg/People": ItemSpec.of("people", "position", "velocity", track_id="name"),
    "people_msgs/msg/PositionMeasurementArray": ItemSpec.of(
        "people", "pos", track_id="object_id", item_header="header"
    ),
    "leg_tracker/msg/PersonArray": ItemSpec.of(
        "people", "pose.position", orientation="pose.orientation", track_id="id"
    ),
    "pedsim_msgs/msg/AgentStates": ItemSpec.of(
        "agent_states", "pose.position", "twist.linear", "pose.orientation", "id",
        item_header="header",
    ),
    "nav2_dynamic_msgs/msg/ObstacleArray": ItemSpec.of(
        "obstacles", "position", "velocity", track_id="uuid"
    ),
}


class Detection3DExtractor:
    """vision_msgs/Detection3DArray in its three layouts: ROS 1 noetic (int64 class ``id`` in
    results, ``source_cloud``, no track id), ROS 2 foxy (string ``id`` in results,
    ``tracking_id``) and ROS 2 >= galactic (``hypothesis.class_id``, string ``id``)."""

    def __init__(self, options: AdapterOptions) -> None:
        self.options = options

    def _is_person(self, det: Any) -> bool | None:
        """True/False under an active class filter, None when no filter applies. String class
        ids (ROS 2: foxy's ``results[].id``, later ``results[].hypothesis.class_id``) go
        through ``class_names``, integer ones (ROS 1 noetic) through ``class_ids``."""
        opts = self.options
        classes = [r.hypothesis.class_id if hasattr(r, "hypothesis") else r.id for r in det.results]
        ros2 = hasattr(det, "tracking_id") or not hasattr(det, "source_cloud")
        named = ros2 or any(isinstance(c, str) for c in classes)
        wanted: tuple[Any, ...] | None = opts.class_names if named else opts.class_ids
        if wanted is None:
            return None
        return any(c in wanted for c in classes)

    def __call__(self, msg: Any, owner: int, rows: Rows) -> None:
        stamp0 = stamp_ns(msg.header.stamp)
        frame0 = msg.header.frame_id
        for det in msg.detections:
            if self._is_person(det) is False:
                rows.drop("class")
                continue
            if hasattr(det, "tracking_id"):
                track = hash_id(det.tracking_id)
            elif hasattr(det, "source_cloud"):
                track = -1
            else:
                track = hash_id(det.id)
            c = det.bbox.center
            rows.add(
                owner, stamp_ns(det.header.stamp) or stamp0, det.header.frame_id or frame0,
                vec3(c.position, "bbox.center.position"), NAN_V,
                quat4(c.orientation, "bbox.center.orientation"), track,
            )


class ZedExtractor:
    """ZED ObjectsStamped (``zed_interfaces`` ROS 1 with ``instance_id``, ``zed_msgs`` /
    ROS 2 with the tracking id in ``label_id``): float32[3] position and velocity; objects
    whose non-empty ``label`` is not one of ``class_names`` (case-insensitive) are skipped."""

    def __init__(self, options: AdapterOptions) -> None:
        names = options.class_names
        self.labels = None if names is None else {n.lower() for n in names}

    def __call__(self, msg: Any, owner: int, rows: Rows) -> None:
        stamp = stamp_ns(msg.header.stamp)
        frame = msg.header.frame_id
        for ob in msg.objects:
            if self.labels is not None and ob.label and ob.label.lower() not in self.labels:
                rows.drop("class")
                continue
            ident = ob.instance_id if hasattr(ob, "instance_id") else ob.label_id
            track = int(ident) if ob.tracking_available and int(ident) >= 0 else -1
            rows.add(
                owner, stamp, frame, vec3(ob.position, "position"),
                vec3(ob.velocity, "velocity"), NAN_Q, track,
            )
