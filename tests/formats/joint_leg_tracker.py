"""Lone ``visualization_msgs/Marker`` messages as leg_tracker's ``joint_leg_tracker.py``
publishes them on its ``visualization_marker`` topic (angusleigh/leg_tracker,
``scripts/joint_leg_tracker.py``: ``publish_tracked_objects`` then ``publish_tracked_people``),
for the tests of the Marker reader. Per scan, all stamped with the scan's stamp and in one
frame:

- per tracked object that is no person: a CYLINDER (z 0.15) in ``objects_tracked``, ids
  counted up from 0, then DELETEs of the ids the previous scan used beyond them;
- per person: a body CYLINDER (z 0.8), a head SPHERE (z 1.5), a TEXT label (z 1.7), an ARROW
  whose pose is the origin (z 0.1) and whose two points go from the person along half its
  velocity, and a flat confidence-ellipse SPHERE (z 0), ids counted up from 0 in
  ``People_tracked`` (five per person), then DELETEs of the ids the previous scan used
  beyond them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

S = 1_000_000_000

Person = tuple[float, float, float, float]  # x, y, vx, vy


@dataclass(frozen=True)
class Scan:
    """One scan of the tracker: its stamp (ns), its people and its other tracked objects."""

    stamp_ns: int
    people: tuple[Person, ...]
    objects: tuple[tuple[float, float], ...] = ()


def _marker(scan: Scan, frame: str, ns: str, mid: int, mtype: int, xyz: tuple[float, ...],
            action: int = 0, **kw: Any) -> dict[str, Any]:  # fmt: skip
    sec, nsec = divmod(scan.stamp_ns, S)
    return {
        "header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": frame},
        "ns": ns, "id": mid, "type": mtype, "action": action,
        "pose": {"position": dict(zip("xyz", xyz, strict=True)), "orientation": {}},
        **kw,
    }  # fmt: skip


def lone_markers(scans: list[Scan], frame: str = "map") -> list[dict[str, Any]]:
    """The Marker messages (dicts, ROS 2 naming) of ``scans``, in publishing order."""
    out: list[dict[str, Any]] = []
    prev_objects = prev_people = 0
    for scan in scans:
        for i, (x, y) in enumerate(scan.objects):
            out.append(_marker(scan, frame, "objects_tracked", i, 3, (x, y, 0.15)))
        for m_id in range(len(scan.objects), prev_objects):
            out.append(_marker(scan, frame, "objects_tracked", m_id, 0, (0, 0, 0), action=2))
        prev_objects = len(scan.objects)
        mid = 0
        for x, y, vx, vy in scan.people:
            arrow = [{"x": x, "y": y}, {"x": x + 0.5 * vx, "y": y + 0.5 * vy}]
            out += [
                _marker(scan, frame, "People_tracked", mid, 3, (x, y, 0.8)),
                _marker(scan, frame, "People_tracked", mid + 1, 2, (x, y, 1.5)),
                _marker(scan, frame, "People_tracked", mid + 2, 9, (x, y, 1.7), text=str(mid)),
                _marker(scan, frame, "People_tracked", mid + 3, 0, (0.0, 0.0, 0.1), points=arrow),
                _marker(scan, frame, "People_tracked", mid + 4, 2, (x, y, 0.0)),
            ]  # fmt: skip
            mid += 5
        for m_id in range(mid, prev_people):
            out.append(_marker(scan, frame, "People_tracked", m_id, 0, (0, 0, 0), action=2))
        prev_people = mid
    return out


def walking_scans(n: int, t0: int, period_ns: int = 100_000_000) -> list[Scan]:
    """``n`` scans ``period_ns`` apart from ``t0``: person A walks +x at 1 m/s from (0, 0) in
    every scan; person B walks -y at 0.5 m/s from (3, 4) in the even scans only (dropping
    out and back, as occluded people do); one object (a leg not paired) stands at (-2, 1)
    in every third scan."""
    out = []
    for k in range(n):
        dt = k * period_ns / S
        people: tuple[Person, ...] = ((0.0 + dt, 0.0, 1.0, 0.0),)
        if k % 2 == 0:
            people += ((3.0, 4.0 - 0.5 * dt, 0.0, -0.5),)
        objects = ((-2.0, 1.0),) if k % 3 == 0 else ()
        out.append(Scan(t0 + k * period_ns, people, objects))
    return out
