"""visualization_msgs/Marker and MarkerArray as people detections (:class:`MarkerExtractor`):
which markers draw people, one detection per person per message (or per scan of lone
Markers), and whether a namespace's ids are track ids or count the markers.

Split from :mod:`.builtin` (the other types' extractors): markers need more rules than a field
path, and one topic's markers are read across messages (a scan of lone Markers, the ids of a
sample of the topic)."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from aion_cli.formats.detections.builtin import AdapterOptions
from aion_cli.formats.detections.frame import hash_id
from aion_cli.formats.detections.generic import NAN_V, Rows
from aion_cli.formats.detections.paths import quat4, stamp_ns, vec3

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
