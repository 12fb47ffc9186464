"""Generic (rosbags-object) extractors of the built-in detection types, DESIGN.md §6 and
notes-formats.md §3. Most are plain :class:`ItemSpec` field paths; Detection3DArray, MarkerArray
and ZED need a few lines of logic (class filters, DELETE actions, id fields that differ between
ROS versions)."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
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


#: visualization_msgs/Marker types whose ``points`` are the detections.
LIST_TYPES = (6, 7, 8)  # CUBE_LIST, SPHERE_LIST, POINTS
DELETE_ACTIONS = (2, 3)  # DELETE, DELETEALL
ARROW, TEXT_VIEW_FACING = 0, 9
#: LINE_STRIP, LINE_LIST: a path walked or an outline, not where a person is
LINE_TYPES = (4, 5)
_ORIGIN = (0.0, 0.0, 0.0)
#: Marker namespaces of tracked things that are no people: ``joint_leg_tracker.py``'s
#: ``publish_tracked_objects`` draws its tracks that are *not* people (legs not yet paired,
#: clutter: ``if track.is_person: continue``) under ``objects_tracked`` on the same topic as
#: its people (``People_tracked``).
NOT_PEOPLE_NS = frozenset({"objects_tracked"})


def _rotate(q: tuple[float, float, float, float], p: np.ndarray) -> np.ndarray:
    """Rotate points float64[n,3] by quaternion (x, y, z, w); a zero quaternion = identity."""
    x, y, z, w = q
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm == 0.0 or not math.isfinite(norm):
        return p
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    u = np.array([x, y, z])
    t = 2.0 * np.cross(u, p)
    return p + w * t + np.cross(u, t)


class MarkerExtractor:
    """visualization_msgs/MarkerArray (or lone Markers): one detection per marker at
    ``pose.position`` (track id = hash of ``ns/id``), or one per point for list markers
    (points transformed by the marker pose, no track id). DELETE/DELETEALL markers are
    skipped, and so are markers whose ``ns`` does not match ``marker_ns`` and those of
    :data:`NOT_PEOPLE_NS` (``marker_not_person``).

    Trackers draw each person with several markers (leg_tracker's ``joint_leg_tracker.py``:
    a body cylinder, a head sphere, an id label, a velocity arrow and a confidence ellipse),
    so: text labels (``marker_text``) and lines (``marker_line``: paths, outlines) are no
    people; an arrow given by points stands at its first point (its pose is the origin the
    points are drawn from); and a marker at the x, y of an earlier one of the same message
    and frame is the same person (``marker_same_place``).

    A namespace whose markers in one MarkerArray are numbered 0, 1, ..., k-1 (in any order,
    any action) numbers the markers of that message, not people: leg_tracker counts its ids up
    from 0 in every message (``joint_leg_tracker.py``'s ``marker_id += 1``,
    ``extract_positive_training_clusters``' ``m.id = i``), so id 0 is whoever comes first
    and moves from person to person. Such markers get no track id (they are linked into
    tracks, as a PoseArray's poses are); ids that skip a number are taken as track ids.

    Lone Markers: ``joint_leg_tracker.py`` publishes those five markers per person as
    separate ``Marker`` messages on one topic, all stamped with the scan's stamp (``now``), ids
    counted up from 0 per scan, then DELETEs for the ids the last scan used beyond them. So
    the lone Markers of consecutive messages with the same non-zero stamp and frame are one
    *cycle*, read as one MarkerArray (one detection per person, numbering judged over the
    cycle, as in an array: a cycle of one marker with id 0 numbers it). A lone Marker with a
    zero stamp is read alone (no cycle can be told), its id a track id.
    A cycle cut by the end of a decode call goes on in the next call of the same extractor
    (:meth:`begin` / :meth:`flush`): the earlier part's places and ids count for the rest."""

    def __init__(self, options: AdapterOptions) -> None:
        self.ns = re.compile(options.marker_ns) if options.marker_ns else None
        #: the cycle of lone Markers the last completed call ended in: its key (stamp ns,
        #: frame) and its markers already read (what a call's first markers may continue)
        self.carry: tuple[tuple[int, str] | None, tuple[Any, ...]] = (None, ())
        self._key: tuple[int, str] | None = None
        self._read: list[Any] = []
        self._pending: list[tuple[int, Any]] = []

    def begin(self) -> None:
        """Start a decode call from the state the last completed call left (:attr:`carry`);
        what a failed call had gathered is forgotten."""
        self._key, read = self.carry
        self._read = list(read)
        self._pending = []

    def flush(self, rows: Rows) -> None:
        """Read the lone Markers still held (the end of a decode call) and keep their cycle
        for the next call (:attr:`carry`)."""
        self._read_pending(rows)
        self.carry = (self._key, tuple(self._read))

    def __call__(self, msg: Any, owner: int, rows: Rows) -> None:
        if hasattr(msg, "markers"):
            self._markers(msg.markers, [owner] * len(msg.markers), rows)
            return
        stamp = stamp_ns(msg.header.stamp)
        key = (stamp, msg.header.frame_id)
        if key != self._key:
            self._read_pending(rows)
            self._key, self._read = (key if stamp else None), []
        if self._key is None:  # no stamp: no cycle can be told
            self._markers([msg], [owner], rows, judge=False)
            return
        self._pending.append((owner, msg))

    def _read_pending(self, rows: Rows) -> None:
        """Read the held lone Markers of the current cycle, after its earlier ones."""
        if self._pending:
            owners = [o for o, _ in self._pending]
            markers = [m for _, m in self._pending]
            self._markers(markers, owners, rows, self._read)
            self._read += markers
            self._pending = []

    def _markers(
        self,
        markers: Sequence[Any],
        owners: Sequence[int],
        rows: Rows,
        earlier: Sequence[Any] = (),
        judge: bool = True,
    ) -> None:
        """The detections of the markers of one message (or cycle): ``earlier`` are markers
        of the same cycle already read (their places are taken, their ids count); ``judge``:
        whether the ids may be a numbering (False for a lone Marker alone)."""
        seen = {
            (mk.header.frame_id, p[0], p[1])
            for mk in earlier
            for drop, p, _ in self._places(mk)
            if not drop
        }
        numbered = _numbered_namespaces([*earlier, *markers]) if judge else set()
        for mk, owner in zip(markers, owners, strict=True):
            for drop, p, listed in self._places(mk):
                if drop:
                    rows.drop(drop)
                    continue
                key = (mk.header.frame_id, p[0], p[1])
                if key in seen:
                    rows.drop("marker_same_place")
                    continue
                seen.add(key)
                t = stamp_ns(mk.header.stamp)
                if listed:
                    rows.add(owner, t, mk.header.frame_id, p)
                else:
                    q = quat4(mk.pose.orientation, "pose.orientation")
                    track = -1 if mk.ns in numbered else hash_id(f"{mk.ns}/{mk.id}")
                    rows.add(owner, t, mk.header.frame_id, p, NAN_V, q, track)

    def _places(self, mk: Any) -> list[tuple[str, tuple[float, float, float], bool]]:
        """Where one marker puts people: ``(drop reason, (0, 0, 0), _)`` for a marker that is
        none, else ``("", xyz, listed)`` per place (``listed``: a point of a list marker or
        an arrow, which has no track id)."""
        if mk.action in DELETE_ACTIONS:
            return [("marker_delete", _ORIGIN, False)]
        if self.ns is not None and not self.ns.search(mk.ns):
            return [("marker_ns", _ORIGIN, False)]
        if mk.ns in NOT_PEOPLE_NS:
            return [("marker_not_person", _ORIGIN, False)]
        if mk.type == TEXT_VIEW_FACING or mk.type in LINE_TYPES:
            return [("marker_text" if mk.type == TEXT_VIEW_FACING else "marker_line", _ORIGIN,
                     False)]  # fmt: skip
        pos = vec3(mk.pose.position, "pose.position")
        listed = mk.type in LIST_TYPES or mk.type == ARROW
        if listed and len(mk.points):
            q = quat4(mk.pose.orientation, "pose.orientation")
            points = mk.points[:1] if mk.type == ARROW else mk.points
            pts = np.array([vec3(p, "points[]") for p in points], np.float64)
            moved = (_rotate(q, pts) + np.asarray(pos)).tolist()
            return [("", (p[0], p[1], p[2]), True) for p in moved]
        return [("", pos, False)]


def _numbered_namespaces(markers: Any) -> set[str]:
    """The namespaces whose markers in this message have the ids 0, 1, ..., k-1: a count of
    the message's markers (see :class:`MarkerExtractor`), not track ids."""
    ids: dict[str, list[int]] = {}
    for mk in markers:
        ids.setdefault(mk.ns, []).append(int(mk.id))
    return {ns for ns, got in ids.items() if is_numbering(got)}


def is_numbering(ids: list[int]) -> bool:
    """Whether the ids of one message (one namespace) are 0, 1, ..., k-1 in any order: they
    count the message's items, not people (see :class:`MarkerExtractor`)."""
    return sorted(ids) == list(range(len(ids)))


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
