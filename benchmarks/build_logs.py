"""The synthetic logs of issue 15's build benchmarks (``bench_build``, ``bench_parallel``).

What the build is timed on, written here once and cached in ``benchmarks/_work/`` (the names
carry every generation parameter):

* **The ratio logs** (:func:`ratio_log`), like the issue's 20-day log: spencer
  ``TrackedPersons`` at 10 Hz from a fixed tracker over a floor of corridors (:data:`FLOOR`:
  60 m x 60 m, corridors 3 m wide every 20 m), 62,501 messages over 20 days in bursts
  (:func:`burst_times`: the tracker publishes while people pass: each 10-minute window gets a
  burst of consecutive 10 Hz messages, more by day than at night and on weekdays than at
  weekends), with k people per message (``1 + Poisson(k - 1)``: the mean is k and no message
  is empty), and a ``hydra_msgs/DsgUpdate`` every 10 minutes carrying the floor's places graph
  (spark_dsg binary, ~150 places along the corridors, no mesh). The graph payload is the same
  in every update (:class:`StaticPayload`), as a fixed sensor's static map is (the simulator's
  stream reuses the bytes when nothing changed).
* **The live-Hydra logs** (:func:`graph_logs`): a ``DsgUpdate`` of up to 5,000 places
  (:data:`SITE`: corridor network, edges between neighbours) every second, every payload
  different (:class:`MovingPayload`: each update moves 50 places by a centimetre and stamps
  them, as the backend's optimisation does), plus people at 10 Hz, 5 per message; and the
  same detections without the graph topic.

Every log is written by :func:`write_log` (the project's own CDR helpers and ``LogWriter``),
which ``bench_parallel`` also uses for its fleet of logs.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import WORK, corridor_nodes, corridor_points

TOPIC = "/spencer/perception/tracked_persons"
GRAPH_TOPIC = "/hydra/backend/dsg"
TRACKED = "spencer_tracking_msgs/msg/TrackedPersons"
DSG_UPDATE = "hydra_msgs/msg/DsgUpdate"
T0_NS = 1_700_006_400 * 10**9  # 2023-11-15 00:00 UTC, a Wednesday (window- and day-aligned)
WINDOW_NS = 600 * 10**9
RATE_HZ = 10.0
PLACE_ID0 = ord("p") << 56  # spark_dsg NodeSymbol('p', 0)

#: the ratio logs' floor: corridors 3 m wide every 20 m over 60 m x 60 m, a place every 3 m
FLOOR = (60.0, 20.0, 3.0)
#: the graph stream's site: corridors every 10 m over 160 m x 160 m, a place every metre
#: (5,185 places; the first 5,000 in (x, y) order are the graph)
SITE = (160.0, 10.0, 1.0)


# -- scene graphs ---------------------------------------------------------------------------------
def places_graph(extent: float, spacing: float, step: float, limit: int | None = None
                 ) -> tuple[Any, Any]:
    """Places along the corridor centre lines (``corridor_nodes``), the first ``limit`` of them
    in (x, y) order, and the edges among those kept: (xyz float64[n,3], edges int64[k,2])."""
    xyz, edges = corridor_nodes(extent, spacing, node_step=step)
    if limit is not None and limit < len(xyz):
        xyz = xyz[:limit]
        edges = edges[(edges < limit).all(axis=1)]
    return xyz, edges


def spark_graph(xyz: Any, edges: Any, t_ns: int) -> Any:
    """A spark_dsg graph of PLACES nodes ``p0..`` at ``xyz`` with ``edges`` (weighted by a fixed
    1 m clearance), every node last updated at ``t_ns``."""
    import spark_dsg as dsg

    g = dsg.DynamicSceneGraph()
    for i, p in enumerate(np.asarray(xyz, float)):
        a = dsg.PlaceNodeAttributes()
        a.position = p
        a.distance = 1.0
        a.real_place = True
        a.last_update_time_ns = int(t_ns)
        g.add_node(dsg.DsgLayers.PLACES, PLACE_ID0 + i, a)
    for i, j in np.asarray(edges, np.int64).tolist():
        info = dsg.EdgeAttributes()
        info.weight = 1.0
        info.weighted = True
        g.insert_edge(PLACE_ID0 + i, PLACE_ID0 + j, info)
    return g


class StaticPayload:
    """The same spark_dsg binary in every update (a fixed sensor's static map)."""

    def __init__(self, xyz: Any, edges: Any) -> None:
        self.data = bytes(spark_graph(xyz, edges, T0_NS).to_binary(False))

    def __call__(self, t_ns: int) -> bytes:
        return self.data


class MovingPayload:
    """A new binary per update: ``moved`` random places shift by up to 1 cm and are stamped
    with the update's time (what Hydra's backend optimisation does to a live graph)."""

    def __init__(self, xyz: Any, edges: Any, moved: int = 50, seed: int = 5) -> None:
        self.xyz = np.asarray(xyz, float).copy()
        self.graph = spark_graph(self.xyz, edges, T0_NS)
        self.moved = min(moved, len(self.xyz))
        self.rng = np.random.default_rng(seed)

    def __call__(self, t_ns: int) -> bytes:
        which = self.rng.choice(len(self.xyz), self.moved, replace=False)
        self.xyz[which, :2] += self.rng.uniform(-0.01, 0.01, (self.moved, 2))
        for i in which.tolist():
            attrs = self.graph.get_node(PLACE_ID0 + i).attributes
            attrs.position = self.xyz[i]
            attrs.last_update_time_ns = int(t_ns)
        return bytes(self.graph.to_binary(False))


# -- logs -----------------------------------------------------------------------------------------
def burst_times(messages: int, days: int, seed: int = 0) -> Any:
    """Stamps (int64 ns, sorted) of ``messages`` tracker messages over ``days`` days from
    :data:`T0_NS`: spread over the 10-minute windows by a daily profile (morning and evening
    peaks, a lunch bump, quiet nights, weekends at 30 %), each window's share published as one
    burst of consecutive 10 Hz messages starting at a random instant of the window."""
    rng = np.random.default_rng(seed)
    windows = days * 144
    start = T0_NS + np.arange(windows, dtype=np.int64) * WINDOW_NS
    hour = (start // 10**9 % 86_400) / 3600.0
    weekday = (start // 10**9 // 86_400 + 3) % 7  # Monday = 0 (1970-01-01 was a Thursday)
    w = (0.15 + np.exp(-(((hour - 9) / 1.5) ** 2)) + np.exp(-(((hour - 17) / 1.5) ** 2))
         + 0.5 * np.exp(-(((hour - 12.5) / 1.0) ** 2)))
    w = w * np.where(weekday >= 5, 0.3, 1.0)
    counts = rng.multinomial(messages, w / w.sum())
    step = int(1e9 / RATE_HZ)
    room = np.maximum(WINDOW_NS - counts * step - 10**9, 1)
    first = start + (rng.random(windows) * room).astype(np.int64)
    window_of = np.repeat(np.arange(windows), counts)
    within = np.arange(messages) - np.repeat(np.cumsum(counts) - counts, counts)
    return first[window_of] + within * step


def steady_times(seconds: float) -> Any:
    """Stamps of a tracker publishing at 10 Hz for ``seconds`` from :data:`T0_NS`."""
    step = int(1e9 / RATE_HZ)
    return T0_NS + np.arange(int(seconds * RATE_HZ), dtype=np.int64) * step + step // 2


def write_log(path: Path, times: Any, per_message: int, area: tuple[float, float],
              graph: Callable[[int], bytes] | None = None, graph_period_s: float = 600.0,
              seed: int = 1, empty: Any = None, chunk_size: int | None = None
              ) -> dict[str, int]:
    """Write (once; cached by ``path``) a TrackedPersons log, messages at ``times``, each with
    ``1 + Poisson(per_message - 1)`` people on the corridors of ``area`` (extent, spacing) in
    the map frame, velocity from heading and speed, and (with ``graph``) a DsgUpdate of
    ``graph(t)`` every ``graph_period_s`` from the first message on, merged in time order.

    Messages are serialized with numpy through the project's own CDR helpers
    (``formats.track_messages.tracked_person_records`` / ``tracked_persons_bytes``) 20,000 at
    a time and written with ``formats.writers.LogWriter`` (MCAP, zstd chunks), which writes to a
    staging name and renames on success, so an interrupted run leaves no truncated cache.
    ``empty``: a mask over ``times`` of messages that hold nobody (a tracker publishing at a
    fixed rate). ``chunk_size``: bytes per MCAP chunk (the writer's 1 MiB when None)."""
    from aion_cli.engine.types import DetectionBatch
    from aion_cli.formats.track_messages import tracked_person_records, tracked_persons_bytes
    from aion_cli.formats.writers import LogWriter, stamp

    if path.exists():
        return {}
    path.parent.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    times = np.asarray(times, np.int64)
    counts = 1 + rng.poisson(max(per_message - 1, 0), len(times))
    if empty is not None:
        counts[np.asarray(empty, bool)] = 0
    graph_times: list[int] = []
    if graph is not None:
        period = round(graph_period_s * 1e9)
        graph_times = list(range(int(times[0]), int(times[-1]) + 1, period))
    burst = np.cumsum(np.r_[0, np.diff(times) > int(2e9 / RATE_HZ)])  # one id per burst
    block, g, detections = 20_000, 0, 0
    with LogWriter(path, "mcap", chunk_size=chunk_size) as writer:
        for a in range(0, len(times), block):
            c = counts[a : a + block]
            total = int(c.sum())
            xyz, heading = corridor_points(rng, total, *area)
            msg = np.repeat(np.arange(a, a + len(c)), c)
            within = np.arange(total) - np.repeat(np.cumsum(c) - c, c)
            batch = DetectionBatch(times[msg], xyz, heading, rng.normal(1.2, 0.2, total),
                                   burst[msg] * 1000 + within)
            records = tracked_person_records(batch, True)
            ends = np.cumsum(c)
            for i, (t, s, e) in enumerate(zip(times[a : a + block].tolist(),
                                              (ends - c).tolist(), ends.tolist(), strict=True)):
                while g < len(graph_times) and graph_times[g] <= t:
                    assert graph is not None
                    writer.write(GRAPH_TOPIC, DSG_UPDATE, {
                        "header": {"stamp": stamp(graph_times[g]), "frame_id": "map"},
                        "layer_contents": graph(graph_times[g]),
                        "full_update": True,
                        "sequence_number": g,
                    }, graph_times[g])
                    g += 1
                raw = tracked_persons_bytes(records[s:e], t, "map", True, a + i)
                writer.write_raw(TOPIC, TRACKED, raw, t)
            detections += total
    return {"messages": len(times), "detections": detections, "graph_messages": g}


def ratio_log_path(per_message: int, messages: int, days: int) -> Path:
    """Cache path of the 20-day-like log (the name carries the generation parameters)."""
    extent, _, step = FLOOR
    return WORK / (f"build_tp_{messages}m_{days}d_{per_message}pm_{int(extent)}m"
                   f"_g{int(step)}s600.mcap")


def ratio_log(per_message: int, messages: int, days: int) -> Path:
    """The cached 20-day-like log with ``per_message`` people per message (written once)."""
    extent, spacing, step = FLOOR
    path = ratio_log_path(per_message, messages, days)
    if not path.exists():
        xyz, edges = places_graph(extent, spacing, step)
        write_log(path, burst_times(messages, days), per_message, (extent, spacing),
                  StaticPayload(xyz, edges), 600.0)
    return path


def fixed_rate_log(per_message: int, messages: int, days: int, every_s: float = 10.0) -> Path:
    """:func:`ratio_log`'s people, with the tracker also publishing an empty message every
    ``every_s`` seconds in between (as trackers that publish at a fixed rate do): the log's
    messages never pause, so only decoding finds its quiet moments (written once)."""
    extent, spacing, step = FLOOR
    path = WORK / (f"build_tp_{messages}m_{days}d_{per_message}pm_{int(extent)}m"
                   f"_g{int(step)}s600_empty{int(every_s)}s.mcap")
    if not path.exists():
        people = burst_times(messages, days)
        idle = T0_NS + np.arange(0, days * 86_400, every_s).astype(np.int64) * 10**9
        idle = np.setdiff1d(idle, people)
        times = np.concatenate([people, idle])
        order = np.argsort(times, kind="stable")
        empty = (np.arange(times.size) >= people.size)[order]
        xyz, edges = places_graph(extent, spacing, step)
        write_log(path, times[order], per_message, (extent, spacing),
                  StaticPayload(xyz, edges), 600.0, empty=empty)
    return path


def graph_logs(places: int, seconds: float, per_message: int = 5) -> tuple[Path, Path]:
    """The cached live-Hydra log (``places``-place graphs at 1 Hz for ``seconds``) and the same
    detections without the graph topic."""
    extent, spacing, step = SITE
    stem = f"build_graphs_{places}p_{int(seconds)}s_{per_message}pm"
    with_g, without = WORK / f"{stem}.mcap", WORK / f"{stem}_nographs.mcap"
    times = steady_times(seconds)
    area = (extent, spacing)
    if not with_g.exists():
        xyz, edges = places_graph(extent, spacing, step, places)
        write_log(with_g, times, per_message, area, MovingPayload(xyz, edges), 1.0)
    if not without.exists():
        write_log(without, times, per_message, area)
    return with_g, without
