"""A window's robot coverage without a KD-tree: the same answers as scipy's cKDTree.

``engine.sensor_reach`` replaced the cKDTree queries of ``ObservationSource.robot_observed``
(nearest pose within the range, the edge included) and ``robot_exposure`` (poses within the
range, counted), so a query of a patrolled map no longer imports ``scipy.spatial``. The
known answers: the tree's, asked here as the code asked it before, on random layouts and at
the range's edge (an entry exactly ``sensor_range`` from a pose is observed, one a hair
beyond is not).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from aion_cli.engine import square_grid
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.sensor_reach import any_within, count_within
from aion_cli.engine.types import Trajectory

W = 600 * 10**9


def _tree_any(points: np.ndarray, centres: np.ndarray, r: float) -> np.ndarray:
    """The query robot_observed made before: the nearest pose within nextafter(r), <= r."""
    bound = float(np.nextafter(r, np.inf))
    dist, _ = cKDTree(centres).query(points[:, :2], k=1, distance_upper_bound=bound)
    return np.asarray(dist <= r)


def _tree_count(points: np.ndarray, centres: np.ndarray, r: float) -> np.ndarray:
    """The query robot_exposure made before: poses within nextafter(r), counted."""
    bound = float(np.nextafter(r, np.inf))
    got = cKDTree(centres).query_ball_point(points[:, :2], bound, return_length=True)
    return np.asarray(got, dtype=np.int64)


def _assert_as_tree(points: np.ndarray, centres: np.ndarray, r: float) -> None:
    np.testing.assert_array_equal(any_within(points, centres, r), _tree_any(points, centres, r))
    np.testing.assert_array_equal(
        count_within(points, centres, r), _tree_count(points, centres, r)
    )


@pytest.mark.parametrize("r", [8.0, 5.0, 0.1, 1.0 / 3.0, 2.5])
def test_an_entry_exactly_at_the_range_is_in_it_and_one_ulp_beyond_is_not(r: float) -> None:
    origin = np.zeros((1, 2))
    beyond = math.nextafter(r, math.inf)
    edge = np.array([[r, 0.0], [0.0, -r], [-r, 0.0], [0.0, r]])
    hair = np.array([[beyond, 0.0], [0.0, -beyond]])
    assert any_within(np.vstack([edge, hair]), origin, r).tolist() == [True] * 4 + [False] * 2
    assert count_within(edge, origin, r).tolist() == [1, 1, 1, 1]
    # a few ulps either side of the edge, at the origin and away from it: as the tree
    steps = np.arange(-4, 5) * np.spacing(r)
    around = np.column_stack([r + steps, np.zeros(steps.size)])
    _assert_as_tree(around, origin, r)
    assert any_within(around, origin, r).tolist() == [True] * 5 + [False] * 4
    away = np.array([12.25, -3.5])
    _assert_as_tree(around + away, origin + away, r)


def test_a_diagonal_edge() -> None:
    """3-4-5: exactly 5 m away along a diagonal (in range), and one ulp of y farther (not)."""
    origin = np.zeros((1, 2))
    points = np.array([[3.0, 4.0], [3.0, math.nextafter(4.0, 5.0)], [-4.0, -3.0]])
    assert any_within(points, origin, 5.0).tolist() == [True, False, True]
    _assert_as_tree(points, origin, 5.0)


def test_robot_observed_counts_an_entry_exactly_at_the_sensor_range() -> None:
    source = ObservationSource()
    t = np.array([10, 20, 30], dtype=np.int64) * 10**9
    source.add_trajectory(Trajectory(t, np.zeros((3, 3))))
    entries = np.array([[8.0, 0.0], [0.0, -8.0], [math.nextafter(8.0, 9.0), 0.0]])
    assert source.robot_observed(entries, 0, W, 8.0).tolist() == [True, True, False]
    exposure = source.robot_exposure(entries, 0, W, 8.0)
    assert exposure[0] == exposure[1] > 0
    assert exposure[2] == 0.0


@pytest.mark.parametrize(
    ("seed", "r", "m", "n", "scale"),
    [
        (0, 3.7, 60, 40, 20.0),  # every pair compared
        (1, 8.0, 600, 150, 30.0),  # a window of a build: the grid, dense
        (2, 8.0, 3000, 5000, 20.0),  # hundreds of poses per square
        (3, 1.0 / 3.0, 700, 3000, 20.0),
        (4, 0.1, 700, 12000, 2e6),  # far from the origin, sparse
        (5, 2.5, 3000, 40, 2e6),
    ],
)
def test_random_layouts_answer_as_the_tree(
    seed: int, r: float, m: int, n: int, scale: float
) -> None:
    """Both candidate routes (every pair; the grid beyond 2^16 pairs) with entries placed at,
    just inside and just outside the range of some pose, on coordinates near and far from
    the origin, poses repeated."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-scale, scale, (m, 2)) + rng.uniform(-1e3, 1e3, 2)
    centres[: m // 5] = centres[m // 5 : 2 * (m // 5)]  # repeated poses (a robot standing)
    if seed % 2:
        centres = np.round(centres, 1)
    k = rng.integers(0, m, n)
    angle = rng.uniform(0.0, 2 * np.pi, n)
    ulps = rng.integers(-3, 4, n) * np.spacing(r)
    dist = np.where(rng.random(n) < 0.5, r + ulps, rng.uniform(0.0, 3.0 * r, n))
    points = centres[k] + np.column_stack([np.cos(angle), np.sin(angle)]) * dist[:, None]
    axis = rng.random(n) < 0.2  # exactly r away along an axis
    points[axis] = centres[k[axis]] + np.array([r, 0.0])
    _assert_as_tree(points, centres, r)
    _assert_as_tree(np.column_stack([points, np.ones(n)]), centres, r)  # a third column
    # an unknown position is in range of nothing (the tree refused it: "must be finite")
    points[:3] = np.nan
    assert not any_within(points, centres, r)[:3].any()
    assert not count_within(points, centres, r)[:3].any()


def test_an_entry_at_the_range_across_a_squares_edge_is_found() -> None:
    """The grid's squares are a hair wider than the range: a pose just below a square's
    edge and an entry exactly the range beyond it lie in adjacent squares, so the entry is
    still compared with it (with squares a hair narrower, it would be two squares on)."""
    r = 8.0
    side = math.nextafter(r, math.inf) * square_grid.WIDER
    edge = math.floor(side * 2.0**40) / 2.0**40 - 2.0**-40  # c + r is exact below 2^13
    far = np.column_stack([1000.0 + np.arange(300.0), np.full(300, 1000.0)])
    centres = np.vstack([[0.0, 0.0], [edge, 0.0], far])  # the grid's origin at (0, 0)
    points = np.vstack([[edge + r, 0.0], far[:299] + 4000.0])  # 300 x 302 pairs: the grid
    assert square_grid.SquareGrid.of(centres, math.nextafter(r, math.inf)) is not None
    assert any_within(points, centres, r)[0]
    assert count_within(points, centres, r)[0] == 1
    _assert_as_tree(points, centres, r)


def test_poses_spread_over_more_squares_than_the_grid_takes_compare_every_pair() -> None:
    rng = np.random.default_rng(3)
    r = 1e-6
    centres = rng.uniform(-1e3, 1e3, (400, 2))
    points = np.vstack([centres[:100] + np.array([r, 0.0]),
                        centres[100:200] + np.array([0.0, 2 * r]),
                        rng.uniform(-1e3, 1e3, (300, 2))])
    assert square_grid.SquareGrid.of(centres, r) is None
    _assert_as_tree(points, centres, r)


def test_nothing_to_compare() -> None:
    none = np.zeros((0, 2))
    some = np.array([[0.0, 0.0], [1.0, 1.0]])
    assert any_within(none, some, 8.0).shape == (0,)
    assert any_within(some, none, 8.0).tolist() == [False, False]
    assert count_within(some, none, 8.0).tolist() == [0, 0]
