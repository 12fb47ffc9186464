"""formats/MAPFILE.md against real maps: every member a map holds is in the document's table
of members, with the dtype and the number of dimensions the table gives, every member the
table names is written by some map, and the manifest's keys are the documented ones."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.engine.graph_arrays import graph_to_arrays
from aion_cli.engine.types import GraphSnapshot, Layer, Mesh, Trajectory
from aion_cli.formats.mapfile import read_manifest

REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "formats" / "MAPFILE.md"
SAMPLE = REPO / "samples" / "office.mcap"

DTYPES = {
    "bool": {"|b1"},
    "int8": {"|i1"},
    "int32": {"<i4"},
    "int64": {"<i8"},
    "uint8": {"|u1"},
    "uint64": {"<u8"},
    "float64": {"<f8"},
    "complex128": {"<c16"},
    "uint": {"|u1", "<u2", "<u4", "<f8"},  # the narrowest exact unsigned type, else float64
    "uint32": {"<u4", "<i8"},  # an index: int64 when a position does not fit
    "index": {"|u1", "<u2", "<u4", "<i8"},  # the narrowest unsigned type, else int64
}


def _section(title: str) -> str:
    text = DOC.read_text()
    assert title in text, f"formats/MAPFILE.md has no section {title!r}"
    return text.split(title, 1)[1]


def documented_members() -> dict[str, tuple[set[str], int]]:
    """Member name pattern -> (numpy dtype strings allowed, number of dimensions), from the
    table under "The members of a map"."""
    table = _section("## The members of a map").split("\n## ", 1)[0]
    out: dict[str, tuple[set[str], int]] = {}
    for names, dtype, shape in re.findall(r"^\| (`[^|]+`) \| (\w+) \| ([^|]+) \|", table, re.M):
        rank = shape.split("],")[0].count(",") + 1
        assert dtype in DTYPES, f"unknown dtype {dtype!r} in MAPFILE.md's members table"
        for name in re.findall(r"`([^`]+)`", names):
            out[name] = (DTYPES[dtype], rank)
    assert len(out) > 50, "MAPFILE.md's members table was not found"
    return out


def _pattern(member: str, table: dict[str, tuple[set[str], int]]) -> str | None:
    if member in table:
        return member
    held = re.sub(r"^held\d+_", "held{k}_", member)
    return held if held in table else None


@pytest.fixture(scope="module")
def maps(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """An ordinary map (a robot's trajectory, a scene graph with a mesh, a pending day), a part
    map of the same log (its closed days held), the query-only copy of the first, and a part
    map of a fixed sensor whose two logs a day apart start and end inside windows (the
    windows' recorded shares, held and pending)."""
    from tests.cli.logdata import write_office_log

    folder = tmp_path_factory.mktemp("mapfile-doc")
    full = folder / "office.aion"
    aion.build([SAMPLE], output=full)
    aion.build([SAMPLE], output=folder / "part.aion", part=True)
    aion.compact(full, folder / "compact.aion")
    first, second = folder / "fixed-1.mcap", folder / "fixed-2.mcap"
    write_office_log(first, tf=False, shift_s=360)
    write_office_log(second, tf=False, shift_s=360 + 86_400)
    aion.build([first, second], output=folder / "fixed-part.aion", part=True)
    return {p.stem: p for p in sorted(folder.glob("*.aion"))}


def _graph_with_mesh_and_agents() -> dict[str, np.ndarray]:
    places = Layer(np.array([1, 2], np.uint64), np.zeros((2, 3)), np.zeros(2, np.uint64))
    mesh = Mesh(np.zeros((3, 3)), np.array([[0, 1, 2]], np.int32), np.zeros((3, 3)))
    agents = Trajectory(np.array([5, 6], np.int64), np.zeros((2, 3)))
    graph = GraphSnapshot(
        t_ns=0,
        places=places,
        edges=np.array([[0, 1]], np.int64),
        rooms=Layer.empty(),
        buildings=Layer.empty(),
        mesh=mesh,
        agents=agents,
    )
    return graph_to_arrays(graph)[0]


def _part_with_unstable_keys() -> dict[str, np.ndarray]:
    """The arrays of a part map whose only graph came after its detections: its checks
    reached cells near places not yet stable (``held_unstable_keys``), which no CLI log of
    the fixture gives (their places are stable within seconds)."""
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.shards import start_shard
    from aion_cli.engine.state import MapState
    from tests.engine.engine_builders import graph
    from tests.engine.state_logs import CFG, MORNING, NODES, W, fixed_sensor_log, run_steps

    steps = fixed_sensor_log(MORNING, 39, windows=2)
    last = graph(MORNING + 2 * W - 1, list(range(5)), np.array(NODES))
    log = [steps[0], *steps[2:], lambda m: m.add_graph(last)]
    shard = run_steps(log, Mapper(CFG, start_shard(MapState.empty(CFG)))).state
    arrays: dict[str, np.ndarray] = shard.to_arrays()[0]
    return arrays


def _members(path: Path) -> dict[str, dict[str, Any]]:
    members: dict[str, dict[str, Any]] = read_manifest(path)["members"]
    return members


def test_every_member_of_a_real_map_is_documented_with_its_dtype_and_rank(
    maps: dict[str, Path],
) -> None:
    table = documented_members()
    records = {f"{name}:{m}": rec for name, p in maps.items() for m, rec in _members(p).items()}
    for m, a in _graph_with_mesh_and_agents().items():
        records[f"graph:{m}"] = {"dtype": a.dtype.str, "shape": list(a.shape)}
    unstable = _part_with_unstable_keys()["held_unstable_keys"]
    records["unstable-part:held_unstable_keys"] = {
        "dtype": unstable.dtype.str, "shape": list(unstable.shape)
    }
    assert any(key.startswith("part:held0_") for key in records)  # the part holds days
    for key, rec in records.items():
        member = key.split(":", 1)[1]
        pattern = _pattern(member, table)
        assert pattern is not None, f"{key} is not in formats/MAPFILE.md's members table"
        dtypes, rank = table[pattern]
        assert rec["dtype"] in dtypes, f"{key} is {rec['dtype']}, MAPFILE.md says {dtypes}"
        assert len(rec["shape"]) == rank, f"{key} has shape {rec['shape']}, MAPFILE.md rank {rank}"


def test_every_documented_member_is_written_by_some_map(maps: dict[str, Path]) -> None:
    table = documented_members()
    written = {_pattern(m, table) for p in maps.values() for m in _members(p)}
    written |= {_pattern(m, table) for m in _graph_with_mesh_and_agents()}
    written |= {_pattern(m, table) for m in _part_with_unstable_keys()}
    stale = sorted(set(table) - written)
    assert not stale, f"formats/MAPFILE.md lists members no map holds: {stale}"


def test_the_manifest_holds_the_documented_keys(maps: dict[str, Path]) -> None:
    manifest_doc = _section("## Manifest").split("\n## ", 1)[0]
    keys = set(re.findall(r"^\| `(\w+)`(?:, `(\w+)`)? \|", manifest_doc, re.M))
    documented = {k for pair in keys for k in pair if k}
    record = re.search(r"\| `members` \| object \| `\{name: \{(.*?)\}\}`", manifest_doc)
    assert record is not None, "MAPFILE.md's manifest table does not give the member record"
    record_keys = set(re.findall(r'"(\w+)"', record.group(1)))
    for name, path in maps.items():
        manifest = read_manifest(path)
        assert set(manifest) <= documented, (name, sorted(set(manifest) - documented))
        for member, rec in manifest["members"].items():
            assert set(rec) == record_keys, (name, member, sorted(rec))
    assert "query_only" in read_manifest(maps["compact"])
    assert "deferred" in read_manifest(maps["part"])["state"]
