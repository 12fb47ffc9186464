"""``--derive-graph`` drops what a build drops: three detections far outside the spatial
hash's range used to become a place at 1e12 m that refused the whole build ("coordinate
x=999999999999.75 cannot be hashed", exit 2) although a normal build drops and counts them
as ``out_of_range``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.derive_graph import OccupancyGrid
from aion_cli.engine.spatial_hash import hashable_indices
from tests.robustness.conftest import T0, S, build_json, map_arrays, person, walk, write_log


@pytest.mark.parametrize(
    ("xyz", "reason"),
    [((1e12, 0.0, 0.0), "out_of_range"), ((0.0, 0.0, 1e300), "out_of_range"),
     ((1e7, 0.0, 0.0), "out_of_range"), ((np.nan, 1.0, 0.0), "nan")],
)
def test_derive_graph_drops_and_counts_like_a_normal_build(
    tmp_path: Path, xyz: tuple[float, float, float], reason: str
) -> None:
    bad = [person(T0 + (50 + k) * S, xyz) for k in range(3)]  # 3 = derive_min_detections
    log = write_log(tmp_path / "bad.mcap", [*walk(50), *bad, *walk(50, start_s=53)])
    clean = write_log(tmp_path / "clean.mcap", [*walk(50), *walk(50, start_s=53)])
    derived = build_json(log, "--derive-graph", "-o", tmp_path / "d.aion")
    plain = build_json(log, "-o", tmp_path / "p.aion")
    reference = build_json(clean, "--derive-graph", "-o", tmp_path / "c.aion")
    assert derived["detections"] == plain["detections"]
    assert derived["detections"] == {"read": 103, "used": 100, "dropped": {reason: 3}}
    assert derived["nodes"] == reference["nodes"] == 1
    for name, arr in map_arrays(tmp_path / "d.aion").items():
        if arr.dtype.kind == "f" and "xyz" in name:
            assert np.isfinite(arr).all(), name
            assert arr.size == 0 or np.abs(arr).max() < 1e3, name


def test_the_grid_keeps_only_rows_a_map_of_its_cell_size_can_hold() -> None:
    """The packable range is +-2^20 cells: +-524,288 m at 0.5 m cells, +-52,429 m at 0.05 m.
    A row is kept when its position and its place (the grid cell's centre) both hash."""
    pts = np.array([
        [1.0, 2.0, 0.0],
        [100_000.0, 0.0, 0.0],  # inside at 0.5 m, outside at 0.05 m
        [524_287.9, 0.0, 0.0],  # inside, but its 1.5 m cell's centre is not
        [np.inf, 0.0, 0.0],
        [0.0, 0.0, -1e9],
    ])
    coarse = OccupancyGrid(1.5)
    coarse.add(pts)
    fine = OccupancyGrid(1.5, cell_size=0.05)
    fine.add(pts)
    assert (coarse.total, coarse.skipped) == (2, 3)
    assert (fine.total, fine.skipped) == (1, 4)
    for grid in (coarse, fine):
        places = grid.graph(1, 0).places
        assert hashable_indices(places.xyz, grid.cell_size)[2].all()
