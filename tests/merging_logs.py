"""Map files for the merge tests (``tests/test_merging*.py``): states built in memory from the
logs of ``tests/engine/state_logs.py``, saved with a manifest naming made-up logs, so every
rule of the file layer is exercised without decoding a log."""

from __future__ import annotations

import hashlib
from functools import partial
from pathlib import Path

import numpy as np

from aion_cli.engine.family_summary import family_summary
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.state import MapState
from aion_cli.formats.mapfile import write_map
from aion_cli.manifest import InputLog, Manifest
from aion_cli.mapquery import state_counts
from tests.engine.engine_builders import detections, graph
from tests.engine.state_logs import Step, W, fixed_sensor_log, run_steps


def input_logs(*names: str) -> tuple[InputLog, ...]:
    """Manifest entries of made-up logs with these names (size 1000 + position, name's sha256)."""
    return tuple(
        InputLog(f"/logs/{n}", n, 1000 + k, hashlib.sha256(n.encode()).hexdigest())
        for k, n in enumerate(names)
    )


def save_map(
    state: MapState,
    path: Path,
    logs: tuple[str, ...],
    span: tuple[int, int],
    timezone: str | None = "UTC",
    map_frame: str | None = None,
) -> Path:
    """``state`` as a map file whose manifest says it was built from ``logs`` over ``span``
    (in ``map_frame``: None, as maps written before the record)."""
    arrays, meta = state.to_arrays()
    manifest = Manifest(
        state=meta,
        config=state.config.to_dict(),
        inputs=input_logs(*logs),
        start_ns=span[0],
        end_ns=span[1],
        counts={"read": state.accepted, "used": state.accepted, "dropped": {"nan": 0}}
        | state_counts(state),
        graph_source="test",
        observation="fixed sensor",
        timezone=timezone,
        families=family_summary(state),
        map_frame=map_frame,
    )
    write_map(path, arrays, manifest.to_dict())
    return path


def fixed_sensor_map(
    path: Path,
    logs: tuple[str, ...],
    start: int,
    seed: int,
    mapper: Mapper | None = None,
    timezone: str | None = "UTC",
    map_frame: str | None = None,
) -> Path:
    """The map of one fixed-sensor log from ``start`` (``fixed_sensor_log(start, seed)``,
    learnt by ``mapper`` or a default one) saved at ``path`` as built from ``logs``."""
    state = run_steps(fixed_sensor_log(start, seed=seed), mapper).state
    return save_map(state, path, logs, log_span(start), timezone, map_frame)


def log_span(start: int, windows: int = 6) -> tuple[int, int]:
    """The time span of a log of ``windows`` windows from ``start``."""
    return start, start + windows * W


def random_log(start: int, seed: int, windows: int, nodes: np.ndarray) -> list[Step]:
    """A fixed sensor over the log, a graph of ``nodes`` (ids p0..), detections anywhere."""
    rng = np.random.default_rng(seed)
    end = start + windows * W
    ids = list(range(len(nodes)))
    steps: list[Step] = [
        lambda m: m.set_fixed_sensor(start, end),
        lambda m: m.add_graph(graph(start, ids, nodes)),
    ]
    for w in range(windows):
        n = int(rng.integers(1, 40))
        t = start + w * W + np.sort(rng.integers(0, W, n))
        xyz = np.c_[rng.uniform(-2, 9, (n, 2)), np.zeros(n)]
        heading = np.where(rng.random(n) < 0.2, np.nan, rng.uniform(-np.pi, np.pi, n))
        speed = np.where(rng.random(n) < 0.2, np.nan, rng.uniform(0.1, 2, n))
        steps.append(partial(Mapper.add_detections, batch=detections(t, xyz, heading, speed)))
    return steps
