"""A Hydra-like scene-graph stream: which places exist, where, and under which id, over time.

Every environment place is a *slot* with a state: undiscovered, alive, removed (Hydra dropped it;
it comes back under a fresh id when seen again) or merged (gone for good; its neighbour took over
its edges). The graph grows as the robot explores: a slot is discovered when the robot's sensor
covers it. Place positions are the robot's estimates: ``C ∘ E`` applied to the true position
while drift accumulates, reset to the truth (plus a small fixed per-place error) at each loop
closure. Loop closures also merge a place into a neighbour or remove one now and then — exactly
the absences and moves aion's ownership transfer has to handle. Every such event is recorded.

The stream is computed as arrays first (:class:`GraphFrames`, cheap), and each frame's spark_dsg
binary payload is built only when the writer asks for it (:class:`PayloadBuilder`), so a week of
frames never sits in memory as bytes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, I64, U64, BoolA
from aion_cli.sim.environment import PLACE_CHAR, Environment, symbol
from aion_cli.sim.geometry import se2_apply
from aion_cli.sim.robot import RobotTrack

UNDISCOVERED, ALIVE, REMOVED, MERGED = 0, 1, 2, 3
EVENT_KINDS = ("add", "move", "merge", "remove")
I8 = npt.NDArray[np.int8]


@dataclass(frozen=True)
class StreamConfig:
    """Scene-graph publishing and loop-closure behaviour."""

    period_s: float = 10.0  # while the robot drives
    idle_period_s: float = 600.0  # while it is parked (or for a fixed sensor)
    merge_p: float = 0.5  # chance that a loop closure merges one place into a neighbour
    remove_p: float = 0.3  # chance that a loop closure removes one place
    max_merged_fraction: float = 0.1
    place_noise: float = 0.03  # fixed per-place estimation error (m)
    move_threshold: float = 0.01  # corrections smaller than this are not recorded as moves
    include_mesh: bool = True


@dataclass(frozen=True)
class GraphEvents:
    """Node events: kind (index into EVENT_KINDS), node id, merge target, positions."""

    t_ns: I64
    kind: I64
    node: U64
    target: U64
    src_xyz: F64
    dst_xyz: F64

    def __len__(self) -> int:
        return len(self.t_ns)


@dataclass(frozen=True)
class GraphFrames:
    """Per published frame f: the tick, each slot's state, id and estimated position."""

    tick: I64
    state: I8
    ids: U64
    xyz: F64
    rep: I64
    updated: I64  # ns of each slot's last position update
    events: GraphEvents
    closures: I64  # ticks of loop closures that were applied

    def __len__(self) -> int:
        return len(self.tick)


def frame_ticks(robot: RobotTrack | None, cfg: StreamConfig, dt_s: float, n_ticks: int) -> I64:
    """Ticks at which a scene graph is published (sorted, unique)."""
    idle = max(round(cfg.idle_period_s / dt_s), 1)
    ticks = [np.arange(0, n_ticks, idle)]
    if robot is not None:
        step = max(round(cfg.period_s / dt_s), 1)
        moving = np.flatnonzero(robot.moving)
        since = moving - robot.tour_starts[np.searchsorted(robot.tour_starts, moving, "right") - 1]
        ticks += [moving[since % step == 0], robot.loop_closures]
    return np.unique(np.concatenate(ticks)).astype(np.int64)


class _Stream:
    """Mutable slot state while the frames are generated (internal to :func:`build_frames`)."""

    def __init__(self, env: Environment, cfg: StreamConfig, rng: np.random.Generator) -> None:
        m = env.n_places
        self.env, self.cfg, self.rng = env, cfg, rng
        self.state = np.zeros(m, dtype=np.int8)
        self.ids = np.zeros(m, dtype=np.uint64)
        self.rep = np.arange(m, dtype=np.int64)
        self.offset = rng.normal(0.0, cfg.place_noise, size=(m, 3)) * np.array([1, 1, 0.3])
        self.xyz = env.xyz + self.offset
        self.updated = np.zeros(m, dtype=np.int64)
        # fresh ids for re-added places continue after the largest index in use
        index = env.place_ids & np.uint64((1 << 56) - 1)
        self.next_index = int(index.max()) + 1 if m else 0
        # (t_ns, kind, node, target, src_xyz, dst_xyz); positions are copies, never row views
        self.events: list[tuple[int, int, int, int, F64, F64]] = []

    def observe(self, t_ns: int, seen: BoolA, error: F64 | None) -> None:
        """Discover or re-add seen slots and re-estimate their positions."""
        truth = self.env.xyz + self.offset
        est = truth if error is None else se2_apply(np.broadcast_to(error, (len(truth), 3)), truth)
        fresh = seen & (self.state == UNDISCOVERED)
        back = seen & (self.state == REMOVED)
        self.ids[fresh] = self.env.place_ids[fresh]
        for i in np.flatnonzero(back):
            self.ids[i] = symbol(PLACE_CHAR, self.next_index)
            self.next_index += 1
        new = fresh | back
        self.state[new] = ALIVE
        upd = seen & (self.state == ALIVE)
        self.xyz[upd] = est[upd]
        self.updated[upd] = t_ns
        for i in np.flatnonzero(new):
            self.events.append(
                (t_ns, 0, int(self.ids[i]), 0, self.xyz[i].copy(), self.xyz[i].copy())
            )

    def close_loop(self, t_ns: int) -> None:
        """Correct every alive place to its true position; maybe merge or remove one."""
        alive = self.state == ALIVE
        corrected = self.env.xyz + self.offset
        shift = np.linalg.norm(corrected - self.xyz, axis=1)
        for i in np.flatnonzero(alive & (shift > self.cfg.move_threshold)):
            self.events.append((t_ns, 1, int(self.ids[i]), 0, self.xyz[i].copy(), corrected[i]))
        self.xyz[alive] = corrected[alive]
        self.updated[alive] = t_ns
        if self.rng.random() < self.cfg.merge_p:
            self._merge(t_ns)
        if self.rng.random() < self.cfg.remove_p:
            self._remove(t_ns)

    def _merge(self, t_ns: int) -> None:
        m = len(self.state)
        if (self.state == MERGED).sum() + 1 > self.cfg.max_merged_fraction * m:
            return
        targets = np.zeros(m, dtype=bool)
        targets[self.rep[self.state == MERGED]] = True
        e = self.env.edges
        both = (self.state[e[:, 0]] == ALIVE) & (self.state[e[:, 1]] == ALIVE)
        pairs = np.concatenate([e[both], e[both][:, ::-1]])
        pairs = pairs[~targets[pairs[:, 0]]]
        dock = self.env.roles.dock
        pairs = pairs[(pairs[:, 0] != dock)]
        if len(pairs) == 0:
            return
        a, b = pairs[self.rng.integers(len(pairs))]
        self.state[a] = MERGED
        self.rep[a] = b
        src, dst = self.xyz[a].copy(), self.xyz[b].copy()
        self.events.append((t_ns, 2, int(self.ids[a]), int(self.ids[b]), src, dst))

    def _remove(self, t_ns: int) -> None:
        cand = np.flatnonzero(self.state == ALIVE)
        cand = cand[cand != self.env.roles.dock]
        if len(cand) == 0:
            return
        i = int(cand[self.rng.integers(len(cand))])
        self.state[i] = REMOVED
        self.events.append((t_ns, 3, int(self.ids[i]), 0, self.xyz[i].copy(), self.xyz[i].copy()))

    def event_arrays(self) -> GraphEvents:
        ev = self.events
        return GraphEvents(
            t_ns=np.asarray([e[0] for e in ev], dtype=np.int64),
            kind=np.asarray([e[1] for e in ev], dtype=np.int64),
            node=np.asarray([e[2] for e in ev], dtype=np.uint64),
            target=np.asarray([e[3] for e in ev], dtype=np.uint64),
            src_xyz=np.asarray([e[4] for e in ev], dtype=np.float64).reshape(-1, 3),
            dst_xyz=np.asarray([e[5] for e in ev], dtype=np.float64).reshape(-1, 3),
        )


def robot_places(env: Environment, robot: RobotTrack) -> I64:
    """The place nearest the robot at every tick (where its sensor footprint is centred)."""
    from scipy.spatial import cKDTree

    near = np.full(len(robot.pose), -1, dtype=np.int64)
    tree = cKDTree(env.xyz[:, :2])
    moving = np.flatnonzero(robot.moving)
    near[moving] = tree.query(robot.pose[moving, :2])[1]
    parked = np.flatnonzero(~robot.moving)
    if len(parked):
        uniq, inv = np.unique(robot.pose[parked, :2], axis=0, return_inverse=True)
        near[parked] = tree.query(uniq)[1][inv.ravel()]
    return near


def build_frames(
    env: Environment,
    robot: RobotTrack | None,
    cfg: StreamConfig,
    rng: np.random.Generator,
    t0_ns: int,
    dt_ns: int,
    n_ticks: int,
) -> GraphFrames:
    """Run the slot state machine over the publishing ticks and record every frame."""
    ticks = frame_ticks(robot, cfg, dt_ns / 1e9, n_ticks)
    s = _Stream(env, cfg, rng)
    lc = set() if robot is None else {int(k) for k in robot.loop_closures}
    if robot is not None:
        vis = env.visibility_matrix(robot.config.sensor_range, robot.config.line_of_sight)
        near = robot_places(env, robot)
    n, m = len(ticks), env.n_places
    state = np.zeros((n, m), dtype=np.int8)
    ids = np.zeros((n, m), dtype=np.uint64)
    xyz = np.zeros((n, m, 3))
    rep = np.zeros((n, m), dtype=np.int64)
    updated = np.zeros((n, m), dtype=np.int64)
    prev = -1
    closed: list[int] = []
    for f, k in enumerate(ticks):
        t_ns = t0_ns + int(k) * dt_ns
        if robot is None:
            s.observe(t_ns, np.ones(m, dtype=bool), None)
        else:
            seen = np.asarray(vis[np.unique(near[prev + 1 : k + 1])].any(axis=0), dtype=bool)
            closing = int(k) in lc
            # at a loop closure the measurements still carry the drift of the tick before
            s.observe(t_ns, seen, robot.error(np.array([max(int(k) - closing, 0)]))[0])
            if closing:
                s.close_loop(t_ns)
                closed.append(int(k))
        state[f], ids[f], xyz[f], rep[f], updated[f] = s.state, s.ids, s.xyz, s.rep, s.updated
        prev = int(k)
    return GraphFrames(
        tick=ticks,
        state=state,
        ids=ids,
        xyz=xyz,
        rep=rep,
        updated=updated,
        events=s.event_arrays(),
        closures=np.asarray(closed, dtype=np.int64),
    )


def frame_edges(env: Environment, state: I8, rep: I64) -> I64:
    """Place edges of one frame as slot pairs: merged slots' edges rewired to their target."""
    e = rep[env.edges]
    keep = (state[e[:, 0]] == ALIVE) & (state[e[:, 1]] == ALIVE) & (e[:, 0] != e[:, 1])
    e = np.sort(e[keep], axis=1)
    return np.unique(e, axis=0) if len(e) else e.reshape(0, 2)


class PayloadBuilder:
    """Builds each frame's spark_dsg binary (what Hydra puts into DsgUpdate.layer_contents).

    Keeps one spark_dsg graph across frames: when only positions changed since the previous
    frame it updates those nodes in place, when nothing changed it reuses the bytes, and it
    rebuilds the graph only when places appear, vanish or are merged.
    """

    def __init__(self, env: Environment, frames: GraphFrames, include_mesh: bool) -> None:
        self.env, self.frames = env, frames
        self.include_mesh = include_mesh and env.mesh is not None
        self.graph: Any = None
        self.key: tuple[bytes, bytes, bytes] | None = None
        self.xyz = np.zeros((0, 3))
        self.updated = np.zeros(0, dtype=np.int64)
        self.data = b""

    def payload(self, f: int) -> bytes:
        """The binary of frame f."""
        fr = self.frames
        key = (fr.state[f].tobytes(), fr.ids[f].tobytes(), fr.rep[f].tobytes())
        if key != self.key:
            self.graph = self._build(f)
            self.key = key
        else:
            alive = fr.state[f] == ALIVE
            moved = (fr.xyz[f] != self.xyz).any(axis=1) | (fr.updated[f] != self.updated)
            changed = alive & moved
            if not changed.any():
                return self.data
            for i in np.flatnonzero(changed):
                attrs = self.graph.get_node(int(fr.ids[f, i])).attributes
                attrs.position = fr.xyz[f, i]
                attrs.last_update_time_ns = int(fr.updated[f, i])
        self.xyz, self.updated = fr.xyz[f].copy(), fr.updated[f].copy()
        self.data = bytes(self.graph.to_binary(self.include_mesh))
        return self.data

    def _build(self, f: int) -> Any:
        import spark_dsg as dsg

        env, fr = self.env, self.frames
        state, ids, xyz, updated = fr.state[f], fr.ids[f], fr.xyz[f], fr.updated[f]
        g = dsg.DynamicSceneGraph()
        alive = np.flatnonzero(state == ALIVE)
        rooms_used = np.unique(env.place_room[alive]) if len(alive) else np.zeros(0, np.uint64)
        rooms_used = rooms_used[rooms_used != 0]
        if len(rooms_used):
            b = dsg.SemanticNodeAttributes()
            b.position = env.room_xyz.mean(axis=0)
            b.name = "building"
            g.add_node(dsg.DsgLayers.BUILDINGS, env.building_id, b)
        for rid in rooms_used:
            k = int(np.flatnonzero(env.room_ids == rid)[0])
            r = dsg.RoomNodeAttributes()
            r.position = env.room_xyz[k]
            r.name = env.room_labels[k]
            g.add_node(dsg.DsgLayers.ROOMS, int(rid), r)
            g.insert_edge(env.building_id, int(rid))
        for i in alive:
            a = dsg.PlaceNodeAttributes()
            a.position = xyz[i]
            a.distance = float(env.clearance[i])
            a.real_place = True
            a.last_update_time_ns = int(updated[i])
            g.add_node(dsg.DsgLayers.PLACES, int(ids[i]), a)
            if env.place_room[i]:
                g.insert_edge(int(env.place_room[i]), int(ids[i]))
        for a_, b_ in frame_edges(env, state, fr.rep[f]):
            info = dsg.EdgeAttributes()
            info.weight = float(min(env.clearance[a_], env.clearance[b_]))
            info.weighted = True
            g.insert_edge(int(ids[a_]), int(ids[b_]), info)
        if self.include_mesh and env.mesh is not None:
            mesh = dsg.Mesh()
            mesh.set_vertices(np.vstack([env.mesh.vertices.T, env.mesh.colors.T]))
            mesh.set_faces(env.mesh.faces.T.astype(np.int32))
            g.mesh = mesh
        return g
