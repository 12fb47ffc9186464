"""A small synthetic office log with known contents, written with ``formats.writers.LogWriter``.

Layout (map frame, metres)::

    p0 (0,0) -- p1 (2,0) -- p2 (4,0) -- p3 (6,0)          p5 (20,0) -- p6 (22,0)
                             |                           (a second, disconnected part)
                            p4 (4,2)

Rooms: R0 = {p0, p1}, R1 = {p2, p3, p4}, R2 = {p5, p6}; building B0 above them.

People (``spencer_tracking_msgs/TrackedPersons`` on ``/tracks``, frame ``map``), one message
every 10 s from T0 + 5 s for 20 minutes (two 600-s windows):

* track 1 stands at (2.1, 0.1) near p1, velocity (+1, 0): heading 0 -> bin 4 (of 8);
* track 2 at (4.1, 1.9) near p4, velocity (0, -1): heading -pi/2 -> bin 2;
* track 3 at (6.1, -0.1) near p3, velocity (-1, 0): heading pi -> bin 0, first window only.

The robot (``/tf`` map -> base_link, every 5 s) stays at (3, 0, 0), so p5/p6 are out of its
8-m sensor range. A ``DsgUpdate`` with the whole graph is on ``/hydra/backend/dsg`` every 60 s.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

S = 1_000_000_000
# Monday 2026-11-23 08:00:00 UTC, aligned to 600-s windows.
T0 = int(datetime(2026, 11, 23, 8, 0, tzinfo=UTC).timestamp()) * S
DURATION_S = 1200
MSG_PERIOD_S = 10

PLACES = {
    0: (0.0, 0.0, 0.0),
    1: (2.0, 0.0, 0.0),
    2: (4.0, 0.0, 0.0),
    3: (6.0, 0.0, 0.0),
    4: (4.0, 2.0, 0.0),
    5: (20.0, 0.0, 0.0),
    6: (22.0, 0.0, 0.0),
}
EDGES = [(0, 1), (1, 2), (2, 3), (2, 4), (5, 6)]
ROOMS = {0: (0, 1), 1: (2, 3, 4), 2: (5, 6)}
TRACKS = {
    1: {"xyz": (2.1, 0.1, 0.0), "vel": (1.0, 0.0), "until_s": 10**9},
    2: {"xyz": (4.1, 1.9, 0.0), "vel": (0.0, -1.0), "until_s": 10**9},
    3: {"xyz": (6.1, -0.1, 0.0), "vel": (-1.0, 0.0), "until_s": 600},
}
ROBOT_XYZ = (3.0, 0.0, 0.0)


def sym(category: str, index: int) -> int:
    """spark_dsg NodeSymbol value."""
    return (ord(category) << 56) | index


@dataclass(frozen=True)
class Expected:
    """What the log holds, for the tests' assertions."""

    detections: int
    per_track: dict[int, int]
    track_messages: int
    graph_messages: int
    tf_messages: int
    start_ns: int
    end_ns: int


def detection_times(track: int, duration_s: int = DURATION_S) -> list[int]:
    until = int(TRACKS[track]["until_s"])  # type: ignore[call-overload]
    return [
        T0 + (5 + k * MSG_PERIOD_S) * S
        for k in range(duration_s // MSG_PERIOD_S)
        if 5 + k * MSG_PERIOD_S < until
    ]


def build_graph(
    places: dict[int, tuple[float, float, float]] | None = None,
    edges: list[tuple[int, int]] | None = None,
    rooms: dict[int, tuple[int, ...]] | None = None,
    agents: list[tuple[int, tuple[float, float, float]]] | None = None,
) -> Any:
    """The spark_dsg graph of the office (or of the given places, edges and rooms), with an
    agent layer of robot poses ``agents`` ((t_ns, xyz) pairs)."""
    import datetime

    import spark_dsg

    if places is None:
        places, edges, rooms = PLACES, EDGES, ROOMS
    G = spark_dsg.DynamicSceneGraph()
    for i, xyz in places.items():
        attrs = spark_dsg.PlaceNodeAttributes()
        attrs.position = np.array(xyz)
        attrs.real_place = True
        G.add_node(spark_dsg.DsgLayers.PLACES, spark_dsg.NodeSymbol("p", i), attrs)
    for r, members in (rooms or {}).items():
        room = spark_dsg.RoomNodeAttributes()
        room.position = np.mean([places[m] for m in members], axis=0)
        room.name = f"room{r}"
        G.add_node(spark_dsg.DsgLayers.ROOMS, spark_dsg.NodeSymbol("R", r), room)
        for m in members:
            G.insert_edge(spark_dsg.NodeSymbol("p", m), spark_dsg.NodeSymbol("R", r))
    building = spark_dsg.SemanticNodeAttributes()
    building.position = np.array([10.0, 0.0, 3.0])
    G.add_node(spark_dsg.DsgLayers.BUILDINGS, spark_dsg.NodeSymbol("B", 0), building)
    for r in rooms or {}:
        G.insert_edge(spark_dsg.NodeSymbol("R", r), spark_dsg.NodeSymbol("B", 0))
    for a, b in edges or []:
        G.insert_edge(spark_dsg.NodeSymbol("p", a), spark_dsg.NodeSymbol("p", b))
    for k, (t_ns, xyz) in enumerate(agents or []):
        agent = spark_dsg.AgentNodeAttributes()
        agent.position = np.array(xyz)
        agent.timestamp = datetime.timedelta(microseconds=t_ns // 1000)
        G.add_node(2, spark_dsg.NodeSymbol("a", k), agent, ord("a"))
    return G


def save_graph_file(
    path: Path,
    places: dict[int, tuple[float, float, float]] | None = None,
    edges: list[tuple[int, int]] | None = None,
) -> Path:
    """The office graph (or the given places and edges) as a Hydra ``dsg.json`` file."""
    build_graph(places, edges).save(str(path), include_mesh=False)
    return path


def graph_payload(places: dict[int, tuple[float, float, float]]) -> bytes:
    """A DsgUpdate payload: the office graph with these places (the edges and rooms of the
    office between them)."""
    edges = [(a, b) for a, b in EDGES if a in places and b in places]
    rooms = {r: kept for r, ms in ROOMS.items() if (kept := tuple(m for m in ms if m in places))}
    return bytes(build_graph(places, edges, rooms).to_binary(False))


def _stamp(t_ns: int) -> dict[str, int]:
    return {"sec": t_ns // S, "nanosec": t_ns % S}


def _tracked_persons(t_ns: int, t0: int, frame: str) -> dict[str, Any]:
    tracks = []
    for track, spec in TRACKS.items():
        if t_ns - t0 >= int(spec["until_s"]) * S:  # type: ignore[call-overload]
            continue
        x, y, z = spec["xyz"]  # type: ignore[misc]
        if frame != "map":  # the robot's frame: same map positions seen from the robot
            x, y, z = x - ROBOT_XYZ[0], y - ROBOT_XYZ[1], z - ROBOT_XYZ[2]
        vx, vy = spec["vel"]  # type: ignore[misc]
        tracks.append(
            {
                "track_id": track,
                "is_matched": True,
                "pose": {"pose": {"position": {"x": x, "y": y, "z": z}, "orientation": {"w": 1.0}}},
                "twist": {"twist": {"linear": {"x": vx, "y": vy, "z": 0.0}}},
            }
        )
    return {"header": {"stamp": _stamp(t_ns), "frame_id": frame}, "tracks": tracks}


def write_office_log(
    path: Path,
    container: str = "mcap",
    *,
    graph: bool = True,
    tf: bool = True,
    frame: str = "map",
    shift_s: int = 0,
    agents: bool = False,
    duration_s: int = DURATION_S,
    second_topic: str | None = None,
    later_sessions_s: tuple[int, ...] = (),
    agents_since_s: int | None = None,
    places: dict[int, tuple[float, float, float]] | None = None,
    early_graph: tuple[int, bytes] | None = None,
    second_graph: tuple[str, dict[int, tuple[float, float, float]]] | None = None,
    partial_places: dict[int, tuple[float, float, float]] | None = None,
) -> Expected:
    """Write the office log to ``path`` (``shift_s`` seconds after T0) and return what it
    holds. ``later_sessions_s``: the same recording again in the same log, starting that many
    seconds after the first (the log is silent in between). ``agents_since_s``: the agent
    layer's trajectory starts that many seconds after T0 (a Hydra session that began before
    this log: every graph repeats the poses since then), not at the log's start. ``places``:
    the scene graph's places (None: the office's, :data:`PLACES`). ``early_graph``: one more
    DsgUpdate first, ``(seconds before the log, payload)`` (two days: a stray log time the
    build drops; :func:`graph_payload` or damaged bytes), not counted in the graph messages.
    ``second_graph``: a second scene-graph stream, ``(topic, places)``, 30 s after each graph
    (frame ``odom``; not counted either). ``partial_places``: a partial update of these places
    (``full_update`` false) on the graph topic 30 s after each graph time (not counted)."""
    from aion_cli.formats.writers import LogWriter

    n_tracks = n_graph = n_tf = 0
    t0 = T0 + shift_s * S
    end = t0 + duration_s * S
    # agent-layer poses: the robot stands at ROBOT_XYZ for the first window, then far away
    since = t0 if agents_since_s is None else T0 + agents_since_s * S
    poses = (
        [
            (t, ROBOT_XYZ if t - since < 600 * S else (30.0, 0.0, 0.0))
            for t in range(since, end + 60 * S, 5 * S)
        ]
        if agents
        else None
    )
    graph_obj = build_graph(places or PLACES, EDGES, ROOMS, poses) if graph else None
    payload = np.frombuffer(graph_obj.to_binary(False), dtype=np.uint8) if graph else None
    written: list[int] = []
    starts = [t0] + [t0 + later * S for later in later_sessions_s]
    with LogWriter(path, container) as writer:
        if early_graph is not None:
            early = t0 - early_graph[0] * S
            writer.write(
                "/hydra/backend/dsg",
                "hydra_msgs/msg/DsgUpdate",
                {
                    "header": {"stamp": _stamp(early), "frame_id": "map"},
                    "layer_contents": np.frombuffer(early_graph[1], np.uint8),
                    "full_update": True,
                },
                early,
            )
        # one pass over every second of each session, in time order
        for t0, end in ((start, start + duration_s * S) for start in starts):
            for t in range(t0, end, S):
                if graph and (t - t0) % (60 * S) == 0:
                    writer.write(
                        "/hydra/backend/dsg",
                        "hydra_msgs/msg/DsgUpdate",
                        {
                            "header": {"stamp": _stamp(t), "frame_id": "map"},
                            "layer_contents": payload,
                            "full_update": True,
                        },
                        t,
                    )
                    n_graph += 1
                    written.append(t)
                extra = [(second_graph[0], second_graph[1], "odom", True)] if second_graph else []
                if partial_places is not None:
                    extra.append(("/hydra/backend/dsg", partial_places, "map", False))
                for topic, places_k, frame_k, full in extra:
                    if (t - t0) % (60 * S) != 30 * S:
                        continue
                    writer.write(
                        topic,
                        "hydra_msgs/msg/DsgUpdate",
                        {
                            "header": {"stamp": _stamp(t), "frame_id": frame_k},
                            "layer_contents": np.frombuffer(graph_payload(places_k), np.uint8),
                            "full_update": full,
                        },
                        t,
                    )
                if tf and (t - t0) % (5 * S) == 0:
                    x, y, z = ROBOT_XYZ
                    writer.write(
                        "/tf",
                        "tf2_msgs/msg/TFMessage",
                        {
                            "transforms": [
                                {
                                    "header": {"stamp": _stamp(t), "frame_id": "map"},
                                    "child_frame_id": "base_link",
                                    "transform": {
                                        "translation": {"x": x, "y": y, "z": z},
                                        "rotation": {"w": 1.0},
                                    },
                                }
                            ]
                        },
                        t,
                    )
                    n_tf += 1
                    written.append(t)
                if (t - t0) % (MSG_PERIOD_S * S) == 5 * S:
                    for topic in ("/tracks", second_topic):
                        if topic is not None:  # a second tracker publishing the same people
                            writer.write(
                                topic,
                                "spencer_tracking_msgs/msg/TrackedPersons",
                                _tracked_persons(t, t0, frame),
                                t,
                            )
                    n_tracks += 1
                    written.append(t)
    per_track = {k: len(detection_times(k, duration_s)) * len(starts) for k in TRACKS}
    return Expected(
        detections=sum(per_track.values()),
        per_track=per_track,
        track_messages=n_tracks,
        graph_messages=n_graph,
        tf_messages=n_tf,
        start_ns=min(written),
        end_ns=max(written),
    )
