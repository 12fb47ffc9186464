"""Detection decoding speed: the numpy fast path against rosbags' generic deserializer.

For geometry_msgs/PoseArray and spencer TrackedPersons (fixed-size elements) and
people_msgs/People (variable-size elements), in ROS 2 CDR and ROS 1 encoding,
``n`` messages (default 20 000) with 5-10 people each (random positions, velocities, ids,
frame ids of varying length so the CDR alignment varies) are decoded three ways in this
process. Times are the process's CPU time (``time.process_time``), best of the repeats, so other
processes on a shared machine distort the ratios less than wall-clock time would.

* **fast**: ``adapter_for(type).decode(messages)`` -> FrameDetections (the production path:
  joining payloads, numpy decoding, stamps, frame table);
* **rosbags**: ``typestore.deserialize_cdr`` / ``deserialize_ros1`` on every message, only
  deserializing (no field extraction): the baseline;
* **generic**: ``adapter.decode_generic`` (rosbags deserialization plus field extraction, the
  fallback path).

``ratio`` = rosbags time / fast time (target >= 5). Prints a table; no assertions (speed is
measured here, never in timed tests). Run: ``python -m benchmarks.bench_decode``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np

from aion_cli.formats import msgdefs
from aion_cli.formats.detections import adapter_for
from aion_cli.formats.raw import RawMessage

TYPES = (
    "geometry_msgs/msg/PoseArray",
    "spencer_tracking_msgs/msg/TrackedPersons",
    "people_msgs/msg/People",  # variable-size elements: the per-element-index walk
)


def _messages(msgtype: str, ros: int, n: int, seed: int = 0) -> list[RawMessage]:
    """``n`` serialized messages with 5-10 people each (rosbags objects, rosbags serializer)."""
    rng = np.random.default_rng(seed)
    store = msgdefs.typestore(1 if ros == 1 else 2)
    T = store.types
    Time = T["builtin_interfaces/msg/Time"]
    Point, Quat = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    Pose, Vec = T["geometry_msgs/msg/Pose"], T["geometry_msgs/msg/Vector3"]
    frames = ["map", "odom", "/base_link", "camera_depth_optical_frame"]
    serialize = store.serialize_ros1 if ros == 1 else store.serialize_cdr
    out = []
    for i in range(n):
        kw: dict[str, Any] = {
            "stamp": Time(sec=1_700_000_000 + i // 10, nanosec=i % 10 * 10**8),
            "frame_id": frames[i % len(frames)],
        }
        if ros == 1:
            kw["seq"] = i
        head = T["std_msgs/msg/Header"](**kw)
        k = int(rng.integers(5, 11))
        xyz = rng.normal(0.0, 10.0, (k, 3))
        yaw = rng.uniform(-np.pi, np.pi, k)
        poses = [
            Pose(
                position=Point(x=p[0], y=p[1], z=p[2]),
                orientation=Quat(x=0.0, y=0.0, z=np.sin(a / 2), w=np.cos(a / 2)),
            )
            for p, a in zip(xyz.tolist(), yaw.tolist(), strict=True)
        ]
        if msgtype.endswith("PoseArray"):
            msg = T[msgtype](header=head, poses=poses)
        elif msgtype.endswith("People"):
            people = [
                T["people_msgs/msg/Person"](
                    name=f"person_{j}",
                    position=Point(x=p[0], y=p[1], z=p[2]),
                    velocity=Point(x=1.0, y=0.0, z=0.0),
                    reliability=0.9,
                    tagnames=[],
                    tags=[],
                )
                for j, p in enumerate(xyz.tolist())
            ]
            msg = T[msgtype](header=head, people=people)
        else:
            tracks = [_track(T, j, p, Vec) for j, p in enumerate(poses)]
            msg = T[msgtype](header=head, tracks=tracks)
        out.append(
            RawMessage(
                "/t", msgtype, 0, bytes(serialize(msg, msgtype)), "ros1" if ros == 1 else "cdr"
            )
        )
    return out


def _track(T: Any, j: int, pose: Any, Vec: Any) -> Any:
    return T["spencer_tracking_msgs/msg/TrackedPerson"](
        track_id=j,
        is_occluded=False,
        is_matched=True,
        detection_id=j,
        age=T["builtin_interfaces/msg/Duration"](sec=1, nanosec=0),
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=T["geometry_msgs/msg/Twist"](
                linear=Vec(x=1.0, y=0.5, z=0.0), angular=Vec(x=0.0, y=0.0, z=0.0)
            ),
            covariance=np.zeros(36),
        ),
    )


def _deserialize_all(deser: Callable[[bytes, str], Any], msgs: list[RawMessage]) -> None:
    """The baseline: rosbags' generic deserializer on every message."""
    for m in msgs:
        deser(bytes(m.data), m.msgtype)  # bytes here: the same object


def _best(fn: Callable[[], Any], repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def run(n: int = 20_000, repeats: int = 3) -> list[dict[str, Any]]:
    """One dict per (type, encoding): times in s, rows, rows per s, ratios."""
    results: list[dict[str, Any]] = []
    for msgtype in TYPES:
        adapter = adapter_for(msgtype)
        assert adapter is not None
        for ros in (2, 1):
            msgs = _messages(msgtype, ros, n)
            store = msgdefs.typestore(1 if ros == 1 else 2)
            deser = store.deserialize_ros1 if ros == 1 else store.deserialize_cdr

            rows = len(adapter.decode(msgs))
            t_fast = _best(partial(adapter.decode, msgs), repeats)
            t_base = _best(partial(_deserialize_all, deser, msgs), repeats)
            t_gen = _best(partial(adapter.decode_generic, msgs), 1)
            results.append(
                {
                    "type": msgtype.rsplit("/", 1)[-1],
                    "encoding": "cdr" if ros == 2 else "ros1",
                    "messages": n,
                    "rows": rows,
                    "fast_s": t_fast,
                    "rosbags_s": t_base,
                    "generic_s": t_gen,
                    "fast_rows_per_s": rows / t_fast,
                    "ratio": t_base / t_fast,
                    "ratio_generic": t_gen / t_fast,
                }
            )
    return results


def main() -> None:
    rows = run()
    head = (
        f"{'type':<16}{'enc':<6}{'msgs':>7}{'rows':>8}{'fast s':>9}{'rosbags s':>11}"
        f"{'generic s':>11}{'rows/s fast':>13}{'x rosbags':>11}{'x generic':>11}"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        print(
            f"{r['type']:<16}{r['encoding']:<6}{r['messages']:>7}{r['rows']:>8}"
            f"{r['fast_s']:>9.3f}{r['rosbags_s']:>11.3f}{r['generic_s']:>11.3f}"
            f"{r['fast_rows_per_s']:>13,.0f}{r['ratio']:>11.1f}{r['ratio_generic']:>11.1f}"
        )


if __name__ == "__main__":
    main()
