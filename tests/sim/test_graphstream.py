"""The scene-graph stream decoded with spark_dsg: growth, loop-closure moves, merges, removals."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np
import pytest

from aion_cli.formats.dsg import decode_dsg_update
from aion_cli.formats.logs import open_logs
from aion_cli.sim.graphstream import EVENT_KINDS
from aion_cli.sim.scenario import SceneResult, build_scene, load_environment
from tests.shared_data import needs
from tests.sim.conftest import DSG_DIR, PATROL, load_truth

PLACES = 3


@dataclass
class Frame:
    t_ns: int
    pos: dict[int, np.ndarray]
    nbrs: dict[int, set[int]]
    payload: bytes


def _frames(result: SceneResult) -> list[Frame]:
    import spark_dsg as dsg

    frames = []
    with open_logs([result.log]) as logs:
        for raw in logs.messages({"/hydra/backend/dsg"}):
            msg = logs.decode(raw)
            assert msg.full_update
            payload = bytes(msg.layer_contents)
            g = dsg.DynamicSceneGraph.from_binary(payload)
            layer = g.get_layer(PLACES)
            pos = {  # copies: the attribute arrays are views into spark_dsg memory
                n.id.value: np.array(n.attributes.position, dtype=float).ravel()
                for n in layer.nodes
            }
            nbrs: dict[int, set[int]] = {k: set() for k in pos}
            for e in layer.edges:
                nbrs[e.source].add(e.target)
                nbrs[e.target].add(e.source)
            frames.append(Frame(raw.log_time_ns, pos, nbrs, payload))
    return frames


@pytest.fixture(scope="module")
def stream(patrol_scene: SceneResult) -> tuple[list[Frame], dict[str, np.ndarray]]:
    return _frames(patrol_scene), load_truth(patrol_scene)


def _around(frames: list[Frame], t_ns: int) -> tuple[Frame, Frame]:
    """The last frame before t and the frame at t."""
    times = np.array([f.t_ns for f in frames])
    at = int(np.searchsorted(times, t_ns))
    assert times[at] == t_ns
    return frames[at - 1], frames[at]


def test_graph_grows_while_the_robot_explores(stream: tuple[list[Frame], dict]) -> None:
    frames, truth = stream
    first_closure = truth["loop_closure_t_ns"][0]
    sizes = [len(f.pos) for f in frames if f.t_ns < first_closure]
    assert sizes[0] < sizes[-1]
    assert all(b >= a for a, b in itertools.pairwise(sizes))
    assert sizes[-1] <= len(truth["place_ids"])


def test_loop_closures_move_places_back_to_the_truth(stream: tuple[list[Frame], dict]) -> None:
    frames, truth = stream
    true_xyz = dict(zip(truth["place_ids"].tolist(), truth["place_xyz"], strict=True))
    moved_any = 0
    for t in truth["loop_closure_t_ns"]:
        before, after = _around(frames, int(t))
        common = [k for k in before.pos if k in after.pos and k in true_xyz]
        shift = np.array([np.linalg.norm(after.pos[k] - before.pos[k]) for k in common])
        err_after = np.array([np.linalg.norm(after.pos[k] - true_xyz[k]) for k in common])
        moved_any += int((shift > 0.05).sum())
        assert err_after.max() < 0.2  # the fixed per-place error only (σ = 3 cm)
    assert moved_any > 10
    # every recorded move is what the stream shows at the closure
    kind = truth["event_kind"]
    moves = np.flatnonzero(kind == EVENT_KINDS.index("move"))
    assert len(moves) > 0
    shift = np.linalg.norm(truth["event_dst_xyz"][moves] - truth["event_src_xyz"][moves], axis=1)
    assert shift.min() > 0.01  # the stream's move threshold
    # a move starts where the place was in the frame before the closure (for places the robot
    # did not re-measure in the closing interval, which is most of them)
    starts_there = 0
    for i in moves:
        before, _ = _around(frames, int(truth["event_t_ns"][i]))
        node = int(truth["event_node"][i])
        if node in before.pos:
            starts_there += np.allclose(before.pos[node], truth["event_src_xyz"][i], atol=1e-9)
    assert starts_there > len(moves) // 2
    times = np.array([f.t_ns for f in frames])
    for i in moves[:: max(len(moves) // 50, 1)]:
        frame = frames[int(np.searchsorted(times, truth["event_t_ns"][i]))]
        node = int(truth["event_node"][i])
        if node not in frame.pos:  # merged or removed by the same loop closure
            same = (truth["event_t_ns"] == truth["event_t_ns"][i]) & (truth["event_node"] == node)
            assert set(kind[same].tolist()) - {EVENT_KINDS.index("move")}
            continue
        np.testing.assert_allclose(frame.pos[node], truth["event_dst_xyz"][i], atol=1e-9)


def test_merges_remove_a_node_and_rewire_its_edges(stream: tuple[list[Frame], dict]) -> None:
    frames, truth = stream
    merges = np.flatnonzero(truth["event_kind"] == EVENT_KINDS.index("merge"))
    assert len(merges) >= 3
    for i in merges:
        before, after = _around(frames, int(truth["event_t_ns"][i]))
        node, target = int(truth["event_node"][i]), int(truth["event_target"][i])
        assert node in before.pos
        assert node not in after.pos
        assert target in before.pos
        assert target in after.pos
        assert node in before.nbrs[target]  # merged into a neighbour
        survivors = {n for n in before.nbrs[node] if n in after.pos and n != target}
        assert survivors <= after.nbrs[target]  # the target took over the edges


def test_removed_places_vanish_and_return_under_new_ids(stream: tuple[list[Frame], dict]) -> None:
    frames, truth = stream
    kind, node = truth["event_kind"], truth["event_node"]
    removes = np.flatnonzero(kind == EVENT_KINDS.index("remove"))
    assert len(removes) >= 3
    for i in removes:
        before, after = _around(frames, int(truth["event_t_ns"][i]))
        assert int(node[i]) in before.pos
        assert int(node[i]) not in after.pos
        later = [f for f in frames if f.t_ns > truth["event_t_ns"][i]]
        assert all(int(node[i]) not in f.pos for f in later)  # ids are never reused
    readded = np.flatnonzero(
        (kind == EVENT_KINDS.index("add")) & ~np.isin(node, truth["place_ids"])
    )
    assert len(readded) >= 1
    for i in readded:
        assert int(node[i]) in frames[-1].pos or int(node[i]) in set(node[removes].tolist())


@needs(DSG_DIR / "mp3d_x8F5xyUWy9e_dsg.json", "the mp3d scene graph")
def test_new_ids_never_collide_with_a_real_graphs_ids() -> None:
    """Real files number places sparsely; ids issued for re-added places must be fresh."""
    config = replace(
        PATROL, environment=str(DSG_DIR / "mp3d_x8F5xyUWy9e_dsg.json"), days=3 / 24, agents=0
    )
    env = load_environment(config)
    index = env.place_ids & np.uint64((1 << 56) - 1)
    assert int(index.max()) >= env.n_places  # the file's ids are not 0..m-1
    frames = build_scene(config, env, 0).frames
    kind, node = frames.events.kind, frames.events.node
    added = node[kind == EVENT_KINDS.index("add")]
    fresh = added[~np.isin(added, env.place_ids)]
    assert len(fresh) >= 1
    assert len(np.unique(added)) == len(added)
    for f in range(len(frames)):
        alive = frames.ids[f][frames.state[f] == 1]
        assert len(np.unique(alive)) == len(alive)


def test_payloads_decode_with_hierarchy_and_mesh(stream: tuple[list[Frame], dict]) -> None:
    frames, _truth = stream
    last = frames[-1]
    snap = decode_dsg_update(last.payload, last.t_ns)
    assert len(snap.places) == len(last.pos)
    assert set(snap.places.parent.tolist()) <= set(snap.rooms.ids.tolist())
    room_chars = {chr(int(i) >> 56) for i in snap.rooms.ids}
    assert room_chars == {"R"}
    assert {chr(int(b) >> 56) for b in snap.rooms.parent} == {"B"}
    assert "kitchen" in snap.rooms.labels
    assert snap.mesh is not None
    assert len(snap.mesh.faces) > 100
    ids = snap.places.ids
    for a, b in snap.edges[:50]:
        assert int(ids[b]) in last.nbrs[int(ids[a])]
