"""engine.align: a T-shaped corridor's occupancy, drawn in one frame and again (other draws)
turned, shifted and perhaps mirrored, is put back by the transform it was moved with."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.align import RigidAlignment, align_occupancy, occupancy_overlap


def corridor(rng: np.random.Generator, n: int) -> np.ndarray:
    """An unequal T: a 17 m corridor along x (the stem 6 m from its left end), a 10 m stem
    up, a short side branch; people spread 0.4 m across each."""
    part = rng.choice(3, size=n, p=[0.6, 0.3, 0.1])
    u = rng.uniform(0.0, 1.0, n)
    across = rng.normal(0.0, 0.4, n)
    x = np.where(part == 0, -6.0 + 17.0 * u, np.where(part == 1, across, 7.0 + across))
    y = np.where(part == 0, across, np.where(part == 1, 10.0 * u, -3.0 * u))
    return np.c_[x, y]


@pytest.mark.parametrize(("angle_deg", "shift", "mirror"), [
    (171.4, (10.5, -1.0), False), (37.0, (-4.0, 6.0), False), (100.0, (2.0, 3.0), True),
])
def test_the_transform_is_recovered(
    angle_deg: float, shift: tuple[float, float], mirror: bool
) -> None:
    rng = np.random.default_rng(7)
    fixed = corridor(rng, 20_000)
    truth_points = corridor(rng, 8_000)  # other people, same corridor
    move = RigidAlignment(np.deg2rad(angle_deg), shift, mirror, 0.0, 0.0)
    moved = move.apply(truth_points)  # the corridor in another frame
    found = align_occupancy(moved, fixed)
    back = found.apply(moved)
    assert found.mirror == mirror
    assert np.max(np.hypot(*(back - truth_points).T)) < 0.3  # every point back within 0.3 m
    assert found.overlap_before < 0.5 * found.overlap_after
    # as alike as two draws of the same frame are
    assert found.overlap_after > 0.9 * occupancy_overlap(truth_points, fixed)


def test_headings_turn_with_the_points() -> None:
    walk = np.array([[0.0, 0.0], [1.0, 0.0]])  # heading 0: along +x
    for mirror in (False, True):
        a = RigidAlignment(np.deg2rad(90.0), (3.0, 4.0), mirror, 0.0, 0.0)
        p = a.apply(walk)
        step = p[1] - p[0]
        heading = a.apply_heading(np.array([0.0, np.nan]))
        assert heading[0] == pytest.approx(np.arctan2(step[1], step[0]))
        assert np.isnan(heading[1])
    up = RigidAlignment(0.0, (0.0, 0.0), True, 0.0, 0.0)  # mirror alone: +y walks become -y
    assert up.apply_heading(np.array([np.pi / 2]))[0] == pytest.approx(-np.pi / 2)


def test_overlap_is_one_for_the_same_points_and_zero_apart() -> None:
    pts = corridor(np.random.default_rng(1), 1_000)
    assert occupancy_overlap(pts, pts) == pytest.approx(1.0)
    assert occupancy_overlap(pts, pts + 100.0) == 0.0
