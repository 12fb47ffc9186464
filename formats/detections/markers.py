"""visualization_msgs/Marker and MarkerArray as people detections (:class:`MarkerExtractor`):
which markers draw people, one detection per person per message (or per scan of lone
Markers), and whether a namespace's ids are track ids or count the markers.

Split from :mod:`.builtin` (the other types' extractors): markers need more rules than a field
path, and one topic's markers are read across messages (a scan of lone Markers, the ids of a
sample of the topic)."""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from typing import Any, Literal

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
#: Messages of a Marker(Array) topic, from its start, whose ids decide per namespace whether
#: they count the markers or name people (:meth:`MarkerExtractor.learn`, :func:`ids_verdict`).
ID_SAMPLE = 200
#: Lone Markers one scan holds at most: a publisher that gives every Marker one stamp would
#: otherwise make one scan of the whole topic (its markers kept, each place compared with
#: all before); past this many a scan starts afresh.
MAX_SCAN = 10_000


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
    Where a log is at hand, the topic's first :data:`ID_SAMPLE` messages decide this per
    namespace for every message (:meth:`learn`, :func:`ids_verdict`): a namespace that
    counts in some message (0..k-1, k >= 2) counts in those of one marker too, one that
    names people somewhere (a gap) keeps its ids 0..k-1 too, and where the only id is 0, in
    every message, a lone id 0 is one person's track id 0. A namespace the sample cannot
    tell is judged message by message.

    Lone Markers: ``joint_leg_tracker.py`` publishes those five markers per person as
    separate ``Marker`` messages on one topic, all stamped with the scan's stamp (``now``), ids
    counted up from 0 per scan, then DELETEs for the ids the last scan used beyond them. So
    the lone Markers of consecutive messages with the same non-zero stamp and frame are one
    *cycle*, read as one MarkerArray (one detection per person, numbering judged over the
    cycle, as in an array). A lone Marker with a zero stamp is read alone (no cycle can be
    told), its id a track id unless the sample says the namespace counts.
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
        #: per namespace learnt from a sample of the topic (:meth:`learn`, :func:`ids_verdict`)
        self.verdicts: dict[str, Verdict] = {}
        #: whether the sample was of lone Markers read a scan at a time, and the namespaces
        #: of :data:`NOT_PEOPLE_NS` it held (for :meth:`describe`)
        self.cycles = False
        self.not_people: list[str] = []

    def learn(self, sample: Sequence[Any]) -> None:
        """Learn from ``sample`` (the topic's first messages, deserialized, in log order)
        per namespace whether its ids count markers or name people (:func:`ids_verdict` of
        its ids in each message, or scan of lone Markers)."""
        groups: dict[str, list[list[int]]] = {}
        self.cycles = any(not hasattr(m, "markers") and stamp_ns(m.header.stamp) for m in sample)
        scans = _messages_or_scans(sample)
        if self.cycles and len(scans) > 1:
            scans = scans[:-1]  # the sample may end inside a scan: a part of its ids
        for markers in scans:
            per_ns: dict[str, list[int]] = {}
            for mk in markers:
                per_ns.setdefault(mk.ns, []).append(int(mk.id))
            for ns, ids in per_ns.items():
                groups.setdefault(ns, []).append(ids)
        self.not_people = sorted(NOT_PEOPLE_NS & groups.keys())
        for ns in self.not_people:  # dropped whatever their ids
            del groups[ns]
        self.verdicts = {}
        for ns, got in groups.items():
            verdict = ids_verdict(got)
            if verdict is not None:
                self.verdicts[ns] = verdict

    def describe(self) -> str | None:
        """What :meth:`learn` found, as a sentence of a note (None when there is nothing to
        say: a sample of MarkerArrays whose namespaces it could not tell)."""
        parts = []
        if self.cycles:
            parts.append(
                "lone Markers read a scan at a time (the messages of one stamp and frame as "
                "one MarkerArray: one detection per person per scan)"
            )
        said = {
            "counts": "count the markers (no track ids: linked)",
            "names": "are track ids",
            "one": "are only 0, one person's track id",
        }
        ids = []
        for verdict, text in said.items():
            named = sorted(ns for ns, v in self.verdicts.items() if v == verdict)
            if named:
                ids.append(f"of {_ns_list(named)} {text}")
        if ids:
            parts.append(f"in its first {ID_SAMPLE} messages, the ids " + ", those ".join(ids))
        if self.not_people:
            parts.append(f"markers of {_ns_list(self.not_people)} are no people (leg_tracker's)")
        if not parts:
            return None
        return "; ".join(parts)

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
        if len(self._pending) + len(self._read) >= MAX_SCAN:
            self._read_pending(rows)
            self._read = []

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
        numbered = _numbered_namespaces([*earlier, *markers], self.verdicts, judge)
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


def _numbered_namespaces(
    markers: Sequence[Any], verdicts: dict[str, Verdict], judge: bool = True
) -> set[str]:
    """The namespaces of ``markers`` (one message, or scan) whose ids count the markers, not
    people (see :class:`MarkerExtractor`): as ``verdicts`` says (:meth:`MarkerExtractor.
    learn`), else, when ``judge``, those whose ids here are 0, 1, ..., k-1."""
    ids: dict[str, list[int]] = {}
    for mk in markers:
        ids.setdefault(mk.ns, []).append(int(mk.id))
    out = set()
    for ns, got in ids.items():
        verdict = verdicts.get(ns)
        # "one": a lone id 0 is a track id, ids 0..k-1 (k >= 2) still a count
        judged = judge and is_numbering(got) and (verdict is None or len(got) > 1)
        if verdict == "counts" or (verdict != "names" and judged):
            out.add(ns)
    return out


def _messages_or_scans(sample: Sequence[Any]) -> list[list[Any]]:
    """The markers of each message of ``sample`` (MarkerArrays), or of each scan (lone
    Markers: consecutive messages with one non-zero stamp and frame; one with a zero stamp
    is left out, as it is read alone)."""
    out: list[list[Any]] = []
    last = None
    for msg in sample:
        if hasattr(msg, "markers"):
            out.append(list(msg.markers))
            continue
        stamp = stamp_ns(msg.header.stamp)
        key = (stamp, msg.header.frame_id)
        if not stamp:
            last = None
        elif key == last:
            out[-1].append(msg)
        else:
            out.append([msg])
            last = key
    return out


def _ns_list(names: list[str]) -> str:
    return ", ".join(f"{n!r}" for n in names)


Verdict = Literal["counts", "names", "one"]
"""What a sample of a topic says of one namespace's ids (:func:`ids_verdict`)."""


def ids_verdict(groups: Sequence[list[int]]) -> Verdict | None:
    """What one namespace's ids are, from its ids in each message (or scan) of a sample of
    the topic (``groups``); None when the sample cannot tell:

    - ``"names"``: ids that are not 0, 1, ..., k-1 in some message: people's ids (a count
      has no gap), in every message;
    - else ``"counts"``: ids 0, 1, ..., k-1 with k >= 2 in some message: a count
      (leg_tracker's), in every message, those of one marker too;
    - else ``"one"``: the one id 0 in every message, in two or more: a lone id 0 is one
      person's track id 0 (a real track id 0 is common, and read as a count it lost its id:
      the rows were linked instead). A message with ids 0..k-1, k >= 2, later on is still
      judged a count, so a count that had one marker throughout the sample keeps its later
      counts of two or more from becoming track ids;
    - one message of the one id 0: cannot tell."""
    if any(not is_numbering(ids) for ids in groups):
        return "names"
    if any(len(ids) > 1 for ids in groups):
        return "counts"
    return "one" if len(groups) > 1 else None


def is_numbering(ids: list[int]) -> bool:
    """Whether the ids of one message (one namespace) are 0, 1, ..., k-1 in any order: they
    count the message's items, not people (see :class:`MarkerExtractor`)."""
    return sorted(ids) == list(range(len(ids)))


def learn_ids(adapter: Any, messages: Iterable[Any], encoding: str) -> None:
    """Let ``adapter``'s Marker reader learn its topic's id rule (:meth:`MarkerExtractor.
    learn`) from ``messages`` (RawMessages: the topic's first :data:`ID_SAMPLE`, from the
    start of the logs whichever part of them a build reads, so that every part of a
    parallel build judges alike); those of another type or encoding, or that do not decode
    (the build counts them), are left out. Nothing for another adapter."""
    from aion_cli.errors import MessageDecodeError
    from aion_cli.formats.raw import normalize_msgtype

    extract = adapter.extract
    if not isinstance(extract, MarkerExtractor):
        return
    sample = []
    for m in messages:
        if m.encoding != encoding or normalize_msgtype(m.msgtype) != adapter.msgtype:
            continue
        try:
            sample.append(adapter.deserialize(m))
        except MessageDecodeError:
            continue
    extract.learn(sample)
