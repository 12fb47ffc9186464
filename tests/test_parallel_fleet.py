"""A fleet's logs in a parallel build: robots recording the same hours (their logs share
message times to the nanosecond, as `aion simulate` writes them from one start) are one
shard, and that shard must read them in the order one pass does. One pass breaks ties
between messages of one log time by the order the logs were given; when two robots'
publishing the same TF frames at the same instants shared one TF buffer, the other order
gave another map, so a shard that ordered its logs by their end time (the shorter log
first) built another map than ``--workers 1``. Each robot's log now resolves with its own
TF tree (:mod:`aion_cli.tf_trees`), and the order no longer changes the map."""

from __future__ import annotations

from pathlib import Path

import pytest

from aion_cli.engine.compare import differences
from aion_cli.mapquery import load_map
from aion_cli.pipeline import BuildOptions, build_map
from tests.cli.conftest import run
from tests.cli.logdata import save_graph_file


def _simulate(path: Path, seed: int, start: str, days: float) -> Path:
    result = run(
        "simulate", "-o", path, "--seed", str(seed), "--start", start, "--days", str(days), "-q"
    )
    assert result.exit_code == 0, result.output
    return path


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[Path], Path]:
    folder = tmp_path_factory.mktemp("fleet")
    longer = _simulate(folder / "robot1.mcap", 1, "2026-01-05T09:00", 0.1)
    shorter = _simulate(folder / "robot2.mcap", 2, "2026-01-05T09:00", 0.05)
    later = _simulate(folder / "robot1-wed.mcap", 3, "2026-01-07T09:00", 0.05)
    # one saved graph for every robot (so the days are separate shards): places 3 m apart
    grid = [(x, y) for x in range(0, 36, 3) for y in range(0, 21, 3)]
    places = {k: (float(x), float(y), 0.0) for k, (x, y) in enumerate(grid)}
    graph = save_graph_file(folder / "site_dsg.json", places, [])
    return [longer, shorter, later], graph


def _build(logs: list[Path], out: Path, workers: int, graph: Path) -> object:
    return build_map(
        BuildOptions(logs=tuple(logs), output=out, workers=workers, graph_file=graph)
    )


def _state(path: Path) -> object:
    return load_map(path, writable=True).state


def test_a_shard_of_robots_recording_at_once_keeps_the_logs_order(
    fleet: tuple[list[Path], Path], tmp_path: Path
) -> None:
    logs, graph = fleet
    seq, par = tmp_path / "seq.aion", tmp_path / "par.aion"
    _build(logs, seq, 1, graph)
    report = _build(logs, par, 2, graph)
    workers = report.to_dict()["workers"]  # type: ignore[attr-defined]
    assert [w["logs"] for w in workers] == [
        ["robot1.mcap", "robot2.mcap"],  # as given, not the shorter log first
        ["robot1-wed.mcap"],
    ]
    assert differences(_state(seq), _state(par)) == []  # type: ignore[arg-type]


def test_robots_recording_at_once_make_one_map_in_either_order(
    fleet: tuple[list[Path], Path], tmp_path: Path
) -> None:
    # each robot's log holds its own /tf (map -> base_link at the same stamps as the other's)
    # and resolves its detections and poses with its own tree (aion_cli.tf_trees): before,
    # one buffer of both let the later log's poses overwrite the other's, and the same logs
    # in the other order were another map
    logs, graph = fleet
    given, swapped = tmp_path / "given.aion", tmp_path / "swapped.aion"
    _build(logs, given, 1, graph)
    _build([logs[1], logs[0], logs[2]], swapped, 1, graph)
    assert differences(_state(given), _state(swapped)) == []  # type: ignore[arg-type]
