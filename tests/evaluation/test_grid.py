"""The STeF-style grid baseline on scenes whose flow is known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.descriptors import bin_of
from aion_cli.engine.observation import ObservationSource
from aion_cli.engine.types import DetectionBatch, Trajectory
from aion_cli.engine.windows import EPOCH_NS
from aion_cli.evaluation.baselines import StaticHistogram, TimeOfDayHistogram
from aion_cli.evaluation.grid import GridMoD, GridSpec, expected_counts_per_window
from tests.evaluation.corridor_flows import HOUR, corridor_flow


def test_grid_spec_covers_points_and_indexes_cells() -> None:
    spec = GridSpec.covering(np.array([[0.2, 0.3], [4.7, 2.1]]), cell_size=1.0, margin=0.0)
    assert spec.origin == (0.0, 0.0)
    assert (spec.nx, spec.ny) == (6, 4)
    cells = spec.cell_of(np.array([[0.5, 0.5], [4.7, 2.1], [-3.0, 0.0]]))
    assert cells.tolist() == [0, 2 * 6 + 4, -1]
    assert spec.centres()[cells[1]].tolist() == [4.5, 2.5]


def test_grid_learns_the_dominant_direction_per_cell() -> None:
    batch = corridor_flow(6)
    grid = GridMoD(GridSpec.covering(batch.xyz[:, :2], 1.0), ModelConfig(window_s=600.0))
    grid.fit(batch)
    hist = grid.historical()
    occupied = hist.sum(axis=1) > 0
    assert hist.sum() == len(batch)
    assert np.all(hist[occupied].argmax(axis=1) == bin_of(np.array([0.0]), 8)[0])
    # Max-normalised windows: a window with any detection in the cell gives its dominant bin 1,
    # an observed empty window gives 0, so the static prediction is the fraction of windows
    # in which the cell saw someone.
    dominant = bin_of(np.array([0.0]), 8)[0]
    cells = grid.spec.cell_of(batch.xyz[:, :2])
    windows = batch.t_ns // 600_000_000_000
    n_windows = windows.max() - windows.min() + 1
    static = grid.predict(int(batch.t_ns.mean()), static=True)
    for cell in np.flatnonzero(occupied):
        busy = len(np.unique(windows[cells == cell]))
        assert static[cell, dominant] == pytest.approx(busy / n_windows, rel=1e-12)
    # every window of the span was observed (a fixed sensor): the global observation block
    assert grid.state.glob.n[0] == n_windows
    np.testing.assert_array_equal(grid.windows_observed_per_cell, n_windows)
    pred = grid.predict(int(batch.t_ns.mean()))
    others = np.delete(pred[occupied], dominant, axis=1)
    assert np.all(others == 0.0)  # raw per-bin rates: no direction prior
    assert pred[occupied, dominant].mean() > 0.2
    assert np.all(pred[~occupied] == 0.0)
    # one day, never scored: every cell forecasts with the static family
    np.testing.assert_array_equal(pred, static)
    counts_per_window = expected_counts_per_window(grid)
    np.testing.assert_allclose(counts_per_window, hist.sum(axis=1) / n_windows, rtol=1e-12)


def test_raw_grid_predicts_expected_detections_per_window() -> None:
    batch = corridor_flow(6, seed=3)
    grid = GridMoD(GridSpec.covering(batch.xyz[:, :2], 1.0), ModelConfig(window_s=600.0),
                   normalise=False)
    grid.fit(batch)
    windows = batch.t_ns // 600_000_000_000
    n_windows = windows.max() - windows.min() + 1
    np.testing.assert_allclose(grid.predict(int(batch.t_ns.min()), static=True),
                               grid.historical() / n_windows, rtol=1e-12)


def test_grid_fremen_learns_a_direction_that_flips_at_noon() -> None:
    """STeF's point: FreMEn per cell and bin. A week of a corridor walked +x every morning and
    -x every afternoon (the total flow never changes): at 09:00 the grid must expect +x walkers
    (bin 4) more than -x walkers (bin 7), at 15:00 the other way round — the static histogram
    cannot."""
    batch = corridor_flow(7 * 24, seed=2)
    grid = GridMoD(GridSpec.covering(batch.xyz[:, :2], 1.0), ModelConfig(window_s=600.0))
    grid.fit(batch)
    occupied = grid.historical().sum(axis=1) > 0
    east, west = bin_of(np.array([0.0, math.pi - 1e-9]), 8)
    after = EPOCH_NS + 7 * 24 * HOUR
    morning = grid.predict(after + 9 * HOUR)[occupied]
    afternoon = grid.predict(after + 15 * HOUR)[occupied]
    assert np.mean(morning[:, east] > morning[:, west]) > 0.9
    assert np.mean(afternoon[:, west] > afternoon[:, east]) > 0.9


def test_grid_memory_is_dense() -> None:
    small = GridMoD(GridSpec((0.0, 0.0), 1.0, 10, 10))
    large = GridMoD(GridSpec((0.0, 0.0), 1.0, 100, 10))
    assert large.stored_bytes() == pytest.approx(10 * small.stored_bytes(), rel=0.01)


def test_time_of_day_histogram_separates_morning_and_afternoon() -> None:
    batch = corridor_flow(48, seed=1)
    spec = GridSpec.covering(batch.xyz[:, :2], 1.0)
    model = TimeOfDayHistogram(spec)
    model.fit(batch)
    query = np.array([[5.0, 0.5, 0.0], [5.0, 0.5, 0.0], [-50.0, 0.0, 0.0]])
    times = np.array([EPOCH_NS + 9 * HOUR, EPOCH_NS + 15 * HOUR, EPOCH_NS], dtype=np.int64)
    hist, matched = model.probabilities(query, times)
    assert matched.tolist() == [True, True, False]
    assert hist[0].argmax() == bin_of(np.array([0.0]), 8)[0]
    assert hist[1].argmax() == bin_of(np.array([math.pi - 1e-9]), 8)[0]
    static = StaticHistogram(spec)
    static.fit(batch)
    s_hist, _ = static.probabilities(query[:2], times[:2])
    assert np.allclose(s_hist[0], s_hist[1])


@pytest.mark.parametrize("exposure", [True, False])
def test_grid_under_a_robot_counts_windows_as_aion_does(exposure: bool) -> None:
    """A robot watches place A for the first 70 % of each window and place B for the last
    30 %; people pass both at 10 a window, so the robot sees 7 at A and 3 at B. With
    ``exposure`` (aion's default) the grid counts each watched window by its share, as aion's
    entries do, and reads 10 a window at both; without it, whole windows: 7 and 3."""
    window, steps, n_windows = 600 * 10**9, 60, 6
    t0 = (EPOCH_NS // window + 1000) * window
    step = window // steps
    k = np.arange(n_windows * steps)
    at_a = k % steps < 42  # 42 of the 60 steps of every window
    poses = np.where(at_a[:, None], [0.0, 0.0, 0.0], [20.0, 0.0, 0.0])
    source = ObservationSource()
    source.add_trajectory(Trajectory(t0 + k * step + step // 2, poses))
    seen = k[(k % 6 == 0)]  # a detection every sixth step: 7 of them at A, 3 at B
    xyz = np.where(at_a[seen, None], [0.5, 0.5, 0.0], [20.5, 0.5, 0.0])
    batch = DetectionBatch.from_arrays(
        t0 + seen * step + step // 2, xyz, np.zeros(seen.size), np.ones(seen.size),
        np.arange(seen.size),
    )
    config = ModelConfig(window_s=600.0, exposure=exposure)
    grid = GridMoD(GridSpec.covering(batch.xyz[:, :2], 1.0), config, normalise=False)
    grid.fit(batch, t0, t0 + n_windows * window, source)
    a, b = grid.spec.cell_of(np.array([[0.5, 0.5], [20.5, 0.5]]))
    assert grid.historical()[[a, b]].sum(axis=1).tolist() == [42.0, 18.0]
    want = [10.0, 10.0] if exposure else [7.0, 3.0]
    np.testing.assert_allclose(expected_counts_per_window(grid)[[a, b]], want, rtol=1e-12)
    static = grid.predict(t0, static=True)
    np.testing.assert_allclose(static[[a, b]].sum(axis=1), want, rtol=1e-12)


@pytest.mark.parametrize("exposure", [True, False])
def test_grid_counts_a_fixed_sensor_log_that_starts_mid_window_by_its_share(
    exposure: bool,
) -> None:
    """A fixed sensor's log starts a quarter into its first window; a person passes every
    50 s (12 a window), so the sensor records 9 in the first window and 12 in each other.
    With ``exposure`` aion counts the first window by the share recorded (0.75, its own
    ``fixed_share``), and so must the grid: 12 a window everywhere; without it, whole
    windows: fewer than 12 (the first window's 9 over a whole window)."""
    window, steps, n_windows = 600 * 10**9, 60, 4
    t0 = (EPOCH_NS // window + 1000) * window
    step = window // steps
    start = t0 + 15 * step  # a quarter into the first window
    source = ObservationSource()
    source.set_fixed_sensor(start, t0 + n_windows * window)
    k = np.arange(15, n_windows * steps, 5)  # every fifth step from the log's start
    batch = DetectionBatch.from_arrays(
        t0 + k * step, np.tile([0.5, 0.5, 0.0], (k.size, 1)), np.zeros(k.size),
        np.ones(k.size), np.arange(k.size),
    )
    config = ModelConfig(window_s=600.0, exposure=exposure)
    grid = GridMoD(GridSpec.covering(batch.xyz[:, :2], 1.0), config, normalise=False)
    grid.fit(batch, start, t0 + n_windows * window, source)
    cell = grid.spec.cell_of(np.array([[0.5, 0.5]]))[0]
    assert grid.historical()[cell].sum() == 9 + 12 * (n_windows - 1)
    recorded = n_windows - 0.25 if exposure else float(n_windows)
    np.testing.assert_allclose(grid.windows_observed_per_cell, recorded, rtol=1e-12)
    assert source.fixed_share(
        np.arange(t0 // window, t0 // window + n_windows), window, config
    ).sum() == pytest.approx(recorded)  # aion's own count of the same windows
    want = 12.0 if exposure else (9 + 12 * (n_windows - 1)) / n_windows
    np.testing.assert_allclose(expected_counts_per_window(grid)[cell], want, rtol=1e-12)
