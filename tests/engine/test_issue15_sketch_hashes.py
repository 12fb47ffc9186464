"""Issue 15: the detection sketch's hashes computed in place and its finite rows found by
columns (:func:`aion_cli.engine.row_masks.all_columns`) are the hashes and rows of before,
checked against splitmix64's published first output and a per-row Python reference; a
map's manifest stores these hashes, so they must not change by a bit."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.detection_sketch import (
    _GOLDEN,
    DetectionSketch,
    _mix_in_place,
    detection_hashes,
)
from aion_cli.engine.row_masks import all_columns

MASK = (1 << 64) - 1
M1, M2, GOLDEN = 0xBF58476D1CE4E5B9, 0x94D049BB133111EB, 0x9E3779B97F4A7C15


def _mix_py(z: int) -> int:
    """splitmix64's finaliser on one Python int (the reference, not numpy)."""
    z = ((z ^ (z >> 30)) * M1) & MASK
    z = ((z ^ (z >> 27)) * M2) & MASK
    return z ^ (z >> 31)


def _hash_py(t_ns: int, xyz: tuple[float, ...]) -> int:
    """One detection's hash as the sketch defines it: stamp in µs, position in mm rounded
    half to even (Python's ``round``, as ``np.rint``), mixed column by column."""
    h = 0
    for c in (t_ns // 1000, *(round(v * 1000.0) for v in xyz)):
        h = _mix_py(h ^ ((c + GOLDEN) & MASK))
    return h


def test_the_finaliser_gives_splitmix64s_published_first_output() -> None:
    # splitmix64 seeded with 0: its first output is the finaliser of the golden gamma
    h = np.array([_GOLDEN, 0, 1, MASK], dtype=np.uint64)
    _mix_in_place(h, np.empty_like(h))
    assert int(h[0]) == 0xE220A8397B1DCDAF
    assert h[1:].tolist() == [_mix_py(0), _mix_py(1), _mix_py(MASK)]


def test_hashes_equal_the_per_row_reference_and_skip_the_rows_no_map_holds() -> None:
    rng = np.random.default_rng(15)
    n = 3000
    t = rng.integers(-(10**18), 10**18, n).astype(np.int64)
    xyz = rng.uniform(-500, 500, (n, 3))
    xyz[::7, 1] = np.round(xyz[::7, 1], 4) + 0.0005  # half-millimetre ties
    xyz[::11, 2] = -0.0
    bad = rng.choice(n, 60, replace=False)
    xyz[bad[:20], 0] = np.nan
    xyz[bad[20:40], 1] = np.inf * np.sign(rng.normal(size=20))
    xyz[bad[40:], 2] = 1e12  # beyond the sketch's reach, though finite
    kept_t, h = detection_hashes(t, xyz)
    keep = np.ones(n, bool)
    keep[bad] = False
    assert kept_t.tolist() == t[keep].tolist()
    rows = zip(t[keep], xyz[keep], strict=True)
    expected = [_hash_py(int(a), (*map(float, p),)) for a, p in rows]
    assert h.tolist() == expected
    # every row fine: the same hashes (the rows are not selected then)
    t2, h2 = detection_hashes(t[keep], xyz[keep])
    assert t2.tolist() == kept_t.tolist()
    assert h2.tolist() == expected


def test_a_sketch_of_the_same_detections_is_the_same_in_any_batches() -> None:
    rng = np.random.default_rng(3)
    t = np.sort(rng.integers(0, 10**15, 20_000)).astype(np.int64)
    xyz = rng.uniform(-30, 30, (20_000, 3))
    whole, parts = DetectionSketch(), DetectionSketch()
    whole.add(t, xyz)
    for a in range(0, len(t), 333):
        parts.add(t[a : a + 333], xyz[a : a + 333])
    assert whole.level == parts.level > 0
    assert whole.h.tolist() == parts.h.tolist()
    assert whole.t_ns.tolist() == parts.t_ns.tolist()
    # the kept hashes are those of the reference below the level
    rows = zip(t, xyz, strict=True)
    ref = np.array([_hash_py(int(a), (*map(float, p),)) for a, p in rows], np.uint64)
    below = ref[(ref >> np.uint64(64 - whole.level)) == 0]
    assert sorted(below.tolist()) == whole.h.tolist()


@pytest.mark.parametrize("columns", [0, 1, 2, 3, 5])
def test_all_columns_is_all_along_rows(columns: int) -> None:
    rng = np.random.default_rng(columns)
    mask = rng.random((1000, columns)) < 0.8
    assert all_columns(mask).tolist() == mask.all(axis=1).tolist()
    assert all_columns(mask).dtype == bool


def test_all_columns_leaves_its_mask_alone_and_refuses_other_shapes() -> None:
    mask = np.array([[True, False], [True, True]])
    before = mask.copy()
    assert all_columns(mask).tolist() == [False, True]
    assert (mask == before).all()
    with pytest.raises(ValueError):
        all_columns(np.ones(3, bool))
