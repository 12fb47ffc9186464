"""The scene-graph stream log of the graph-stream build tests (``tests/test_pipeline_graphs.py``
tells what its builds must give): the office of ``tests/cli/logdata.py`` (people at p1, p4, p3;
TF at the robot) with a ``DsgUpdate`` every second for 60 s, starting 30 s before a window
boundary. Place p1 moves by 0.5 m in the graphs from index 3 on and again from index 12 on;
every other graph repeats the payload before it. With the build and the map comparison those
tests use."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from aion_cli.formats.mapfile import read_map
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.logdata import EDGES, PLACES, ROBOT_XYZ, ROOMS, T0, S, _tracked_persons
from tests.cli.logdata import build_graph as office_graph

START = T0 + 570 * S  # 30 s before the window boundary at T0 + 600 s
N_GRAPHS = 60


def _p1_moves(k: int) -> int:
    """How often p1 has moved by graph ``k``."""
    return int(k >= 3) + int(k >= 12)


def office_graph_payload(moves: int, _cache: dict[int, bytes] = {}) -> bytes:  # noqa: B006
    """The office graph's payload with p1 moved ``moves`` times 0.5 m along y (cached)."""
    if moves not in _cache:
        places = dict(PLACES)
        x, y, z = places[1]
        places[1] = (x, y + 0.5 * moves, z)
        _cache[moves] = bytes(office_graph(places, EDGES, ROOMS).to_binary(False))
    return _cache[moves]


def write_stream_log(
    path: Path,
    graphs: list[int] | None = None,
    *,
    stray_graph: bool = False,
) -> Path:
    """The stream log with the graphs of index ``graphs`` (all 60 when None); people every
    second, TF every 5 s, 63 s in all. ``stray_graph``: one more graph two days earlier (a
    stray log time the build drops)."""
    from aion_cli.formats.writers import LogWriter

    keep = set(range(N_GRAPHS) if graphs is None else graphs)
    with LogWriter(path, "mcap") as writer:

        def graph(t: int, payload: bytes) -> None:
            writer.write(
                "/hydra/backend/dsg",
                "hydra_msgs/msg/DsgUpdate",
                {
                    "header": {"stamp": {"sec": t // S, "nanosec": t % S}, "frame_id": "map"},
                    "layer_contents": np.frombuffer(payload, np.uint8),
                    "full_update": True,
                },
                t,
            )

        if stray_graph:
            graph(START - 2 * 86_400 * S, office_graph_payload(2))
        for s in range(63):
            t = START + s * S
            if s < N_GRAPHS and s in keep:
                graph(t, office_graph_payload(_p1_moves(s)))
            if s % 5 == 0:
                x, y, z = ROBOT_XYZ
                writer.write(
                    "/tf",
                    "tf2_msgs/msg/TFMessage",
                    {
                        "transforms": [
                            {
                                "header": {"stamp": {"sec": t // S}, "frame_id": "map"},
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
            writer.write(
                "/tracks",
                "spencer_tracking_msgs/msg/TrackedPersons",
                _tracked_persons(t + S // 2, START, "map"),
                t + S // 2,
            )
    return path


def build_log(log: Path, out: Path, **options: Any) -> Any:
    """``aion build`` of the one ``log`` into ``out`` with these BuildOptions."""
    return build_map(BuildOptions(logs=(log,), output=out, **options))


def _map_content(path: Path) -> tuple[dict[str, np.ndarray], Any]:
    arrays, manifest = read_map(path)
    return arrays, manifest["state"]


def assert_same_map(a: Path, b: Path) -> None:
    """The two map files hold the same members (names, dtypes, values) and state metadata."""
    arrays_a, state_a = _map_content(a)
    arrays_b, state_b = _map_content(b)
    assert sorted(arrays_a) == sorted(arrays_b)
    for name in arrays_a:
        assert arrays_a[name].dtype == arrays_b[name].dtype, name
        np.testing.assert_array_equal(arrays_a[name], arrays_b[name], err_msg=name)
    assert state_a == state_b
