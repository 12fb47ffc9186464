"""Ground truth beside each simulated log: true flows per place and window, and graph events.

``<log>.truth.npz`` holds plain arrays (``np.load(..., allow_pickle=False)`` works), and
``<log>.truth.json`` the metadata and a description of every array:

- ``flow_counts[W, m, B]``: ALL true agent positions (every walking agent at every sensor tick,
  whether the robot saw it or not) assigned to their nearest environment place, per window of
  ``window_s`` seconds aligned to the UNIX epoch, per direction bin of the true walking direction
  with the paper's convention ``bin(θ) = floor((θ+π)/(2π/B)) mod B``.
- ``seen_counts[W, m, B]``: the same for the positions the sensor saw (true positions, no noise).
- ``observed[W, m]``: the sensor covered the place at some tick of the window (judged from the
  place nearest the robot: places within range and sight of it), all true for a fixed sensor.
- ``event_*``: scene-graph node events (add / move at a loop closure / merge / remove) with ids
  as published, and ``loop_closure_t_ns``.
- ``agent_*``: the true samples themselves.

Place ids are the environment's ids, i.e. the ids the places have when first published; the
events say which ids later vanished (merge, remove) or were issued anew.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.types import F64, I64, BoolA
from aion_cli.sim.agents import AgentSamples
from aion_cli.sim.environment import Environment
from aion_cli.sim.graphstream import EVENT_KINDS, GraphFrames, robot_places
from aion_cli.sim.robot import RobotTrack

ARRAY_DOC: dict[str, str] = {
    "place_ids": "uint64[m] environment place ids (spark_dsg NodeSymbol values)",
    "place_xyz": "float64[m,3] true place positions (map frame)",
    "place_room": "uint64[m] room id of each place",
    "edges": "int64[k,2] place edges as row indices",
    "window_start_ns": "int64[W] window starts (UNIX ns, multiples of window_s)",
    "flow_counts": "uint32[W,m,B] all true agent positions per window, nearest place, bin",
    "seen_counts": "uint32[W,m,B] the positions the sensor saw, same layout",
    "speed_sums": "float64[W,m,B] sum of true speeds matching flow_counts",
    "observed": "bool[W,m] the sensor covered the place during the window",
    "event_t_ns": "int64[e] time of each scene-graph event",
    "event_kind": "int64[e] index into event_kinds (add, move, merge, remove)",
    "event_node": "uint64[e] node id affected",
    "event_target": "uint64[e] merge target id (0 otherwise)",
    "event_src_xyz": "float64[e,3] position before the event",
    "event_dst_xyz": "float64[e,3] position after (merge: the target's position)",
    "loop_closure_t_ns": "int64[c] loop-closure times",
    "agent_t_ns": "int64[n] true agent samples: time",
    "agent_id": "int64[n] agent index",
    "agent_xyz": "float64[n,3] true position",
    "agent_heading": "float64[n] true walking direction (rad)",
    "agent_speed": "float64[n] true speed (m/s)",
    "agent_place": "int64[n] nearest place row",
    "agent_seen": "bool[n] the sensor saw this sample",
}


def direction_bin(theta: F64, bins: int) -> I64:
    """The paper's bin: floor((θ+π)/(2π/B)) mod B."""
    return np.asarray(np.floor((theta + np.pi) / (2 * np.pi / bins)), dtype=np.int64) % bins


def nearest_place(env: Environment, xyz: F64) -> I64:
    """Row of the environment place nearest to each point (3D distance)."""
    from scipy.spatial import cKDTree

    if len(xyz) == 0:
        return np.zeros(0, dtype=np.int64)
    return np.asarray(cKDTree(env.xyz).query(xyz)[1], dtype=np.int64)


@dataclass(frozen=True)
class WindowGrid:
    """Windows of ``window_s`` aligned to the UNIX epoch covering [t0, t_end]."""

    first: int
    count: int
    window_ns: int

    @classmethod
    def covering(cls, t0_ns: int, t_end_ns: int, window_s: float) -> WindowGrid:
        w = round(window_s * 1e9)
        first = t0_ns // w
        return cls(first, int(t_end_ns // w - first + 1), w)

    def index(self, t_ns: I64) -> I64:
        return np.asarray(t_ns // self.window_ns - self.first, dtype=np.int64)

    def starts(self) -> I64:
        return (np.arange(self.count, dtype=np.int64) + self.first) * self.window_ns


def flow_counts(
    grid: WindowGrid,
    n_places: int,
    bins: int,
    t_ns: I64,
    place: I64,
    heading: F64,
    weights: F64 | None = None,
) -> npt.NDArray[Any]:
    """Counts (or weight sums) per window, place and direction bin."""
    out = np.zeros(
        (grid.count, n_places, bins), dtype=np.float64 if weights is not None else np.uint32
    )
    w = np.ones(len(t_ns)) if weights is None else weights
    np.add.at(
        out,
        (grid.index(t_ns), place, direction_bin(heading, bins)),
        w if weights is not None else 1,
    )
    return out


def observed_mask(
    env: Environment, robot: RobotTrack | None, grid: WindowGrid, t0_ns: int, dt_ns: int
) -> BoolA:
    """observed[w, i]: the sensor covered place i at some tick of window w."""
    if robot is None:
        return np.ones((grid.count, env.n_places), dtype=bool)
    vis = env.visibility_matrix(robot.config.sensor_range, robot.config.line_of_sight)
    near = robot_places(env, robot)
    win = grid.index(t0_ns + np.arange(len(near), dtype=np.int64) * dt_ns)
    pairs = np.unique(np.column_stack([win, near]), axis=0)
    hits = np.zeros((grid.count, env.n_places), dtype=np.int64)
    np.add.at(hits, pairs[:, 0], vis[pairs[:, 1]])
    return hits > 0


def truth_arrays(
    env: Environment,
    samples: AgentSamples,
    seen: BoolA,
    robot: RobotTrack | None,
    frames: GraphFrames,
    grid: WindowGrid,
    bins: int,
    t0_ns: int,
    dt_ns: int,
) -> dict[str, npt.NDArray[Any]]:
    """Every ground-truth array of one scene (see the module docstring)."""
    t_ns = t0_ns + samples.tick * dt_ns
    place = nearest_place(env, samples.xyz)
    m = env.n_places
    ev = frames.events
    return {
        "place_ids": env.place_ids,
        "place_xyz": env.xyz,
        "place_room": env.place_room,
        "edges": env.edges,
        "window_start_ns": grid.starts(),
        "flow_counts": flow_counts(grid, m, bins, t_ns, place, samples.heading),
        "seen_counts": flow_counts(grid, m, bins, t_ns[seen], place[seen], samples.heading[seen]),
        "speed_sums": flow_counts(grid, m, bins, t_ns, place, samples.heading, samples.speed),
        "observed": observed_mask(env, robot, grid, t0_ns, dt_ns),
        "event_t_ns": ev.t_ns,
        "event_kind": ev.kind,
        "event_node": ev.node,
        "event_target": ev.target,
        "event_src_xyz": ev.src_xyz,
        "event_dst_xyz": ev.dst_xyz,
        "loop_closure_t_ns": t0_ns + frames.closures * dt_ns,
        "agent_t_ns": t_ns,
        "agent_id": samples.agent,
        "agent_xyz": samples.xyz,
        "agent_heading": samples.heading,
        "agent_speed": samples.speed,
        "agent_place": place,
        "agent_seen": seen,
    }


def truth_paths(log_path: Path) -> tuple[Path, Path]:
    """``<log>.truth.npz`` and ``<log>.truth.json`` beside a log file or rosbag2 folder."""
    base = log_path.parent / log_path.name
    return Path(f"{base}.truth.npz"), Path(f"{base}.truth.json")


def save_npz(path: Path, arrays: dict[str, npt.NDArray[Any]]) -> None:
    """Like ``np.savez_compressed`` but byte-reproducible: fixed member timestamps."""
    import zipfile

    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name in sorted(arrays):
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with zf.open(info, "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(arrays[name]), allow_pickle=False)


def _is_truth_npz(path: Path) -> bool:
    from aion_cli.formats.outputs import file_starts_with

    return file_starts_with(path, b"PK\x03\x04")  # a zip (npz), as save_npz writes it


def _is_truth_json(path: Path) -> bool:
    from aion_cli.formats.outputs import file_starts_with

    return file_starts_with(path, b"{")  # a JSON object, as write_truth writes it


def check_truth_targets(log_path: Path, overwrite: bool) -> None:
    """Refuse the truth files' paths of ``log_path`` before anything is simulated (the rules
    of :func:`formats.outputs.check_output`: no special file, an existing one only with
    ``overwrite`` and only when it is an npz / JSON file as aion writes them)."""
    from aion_cli.formats.outputs import check_output

    npz, js = truth_paths(log_path)
    check_output(npz, overwrite=overwrite, recognise=_is_truth_npz, what="a ground-truth npz")
    check_output(js, overwrite=overwrite, recognise=_is_truth_json, what="a ground-truth JSON")


def write_truth(
    log_path: Path,
    arrays: dict[str, npt.NDArray[Any]],
    meta: dict[str, Any],
    overwrite: bool = False,
) -> tuple[Path, Path]:
    """Write the arrays (compressed npz) and the JSON sidecar; returns both paths. Each is
    written beside its target and renamed into place (``overwrite`` replaces a previous
    run's truth files, never another file)."""
    from aion_cli.formats.outputs import Staged

    npz, js = truth_paths(log_path)
    check_truth_targets(log_path, overwrite)
    with Staged(npz) as staged:
        save_npz(staged.path, arrays)
    kinds = arrays["event_kind"]
    meta = {
        **meta,
        "event_kinds": list(EVENT_KINDS),
        "event_counts": {k: int((kinds == i).sum()) for i, k in enumerate(EVENT_KINDS)},
        "loop_closures": len(arrays["loop_closure_t_ns"]),
        "true_samples": len(arrays["agent_t_ns"]),
        "seen_samples": int(arrays["agent_seen"].sum()),
        "arrays": {k: ARRAY_DOC[k] for k in arrays},
    }
    with Staged(js) as staged:
        staged.path.write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n")
    return npz, js
