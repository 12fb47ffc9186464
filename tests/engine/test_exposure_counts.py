"""What still counts whole windows under exposure, and must.

A robot that watches place B for a tenth of every window sees there Poisson counts of a tenth
of the true rate. Each of those windows is still one window: its Pearson term (n − λ·share)² /
(λ·share) has mean 1 for Poisson counts whatever the share, so the over-dispersion φ that the
predictive spread is made of is χ² over the *number* of windows scored — over their summed
shares it would say φ = 10 for a Poisson stream.
"""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.observation import SUBSTEPS, ObservationSource
from aion_cli.engine.query import historical_table, predict_table
from aion_cli.engine.temporal.choice import dispersion
from aion_cli.engine.types import Trajectory
from tests.engine.engine_builders import T0, T0_DAY_END, S, check_invariants, detections
from tests.engine.test_exposure import CFG, A, B, W, _at, _dwelling_robot


def _poisson_people(m: Mapper, windows: int, rate: float, seed: int = 7) -> None:
    """People pass A and B at ``rate`` detections per full window (Poisson), seen only while
    the robot is there (A the first 540 s of every window, B the last 60 s), in time order."""
    rng = np.random.default_rng(seed)
    times, places = [], []
    for w in range(windows):
        for place, lo, hi in ((A, 0, 540), (B, 540, 600)):
            n = rng.poisson(rate * (hi - lo) / 600)
            times.append(T0 + w * W + (rng.uniform(lo, hi, n) * S).astype(np.int64))
            places.append(np.repeat(place[None, :] + 0.1, n, axis=0))
    t = np.concatenate(times)
    order = np.argsort(t, kind="stable")
    m.add_detections(detections(t[order], np.concatenate(places)[order]))
    m.advance(T0 + windows * W)


def _row(m: Mapper, place: np.ndarray) -> int:
    rows = m.state.entries.live_rows()
    xyz = m.state.entries.xyz[rows, :2]
    return int(rows[np.flatnonzero(np.linalg.norm(xyz - place[:2] - 0.1, axis=1) < 0.5)[0]])


def test_poisson_counts_watched_a_tenth_of_each_window_are_not_over_dispersed() -> None:
    """Three days' windows at 100 people per window: each place scores every window after the
    first (local) day once, and its χ² per scored window (φ) is about 1 (it was 10 at B,
    watched a tenth of each window, when the windows scored were summed by their shares)."""
    windows = 3 * 144
    m = Mapper(CFG.replace(families=("static",)))
    m.add_trajectory(_dwelling_robot(windows, 0.9, hz=0.5))
    _poisson_people(m, windows, 100.0)
    m.state.close_day()
    check_invariants(m.state)
    t = m.state.temporal
    static = m.state.params.flow.index("static")
    scored = windows - (T0_DAY_END - T0) // W
    for place in (B, A):
        r = _row(m, place)
        phi = float(t.flow_chi2[r, static]) / float(t.flow_scored[r])
        assert 0.7 < phi < 1.5, (place, phi)
        assert float(t.flow_scored[r]) == scored  # whole windows, not Σ share
    rows = np.array([_row(m, A), _row(m, B)])
    chosen = np.full(rows.size, static)
    spread = dispersion(t.flow_chi2[rows], t.flow_scored[rows], chosen)
    assert float(spread.max()) < 1.5


def test_windows_observed_weighs_the_pending_day_as_the_flows_do() -> None:
    """Twelve windows, the last two on a day still pending, B watched a tenth of each: B's
    windows observed are 1.2, the denominator of its historical flow, as they are once that
    day is closed (the pending day's windows counted whole: 1.0 + 2 = 3 windows)."""
    m = Mapper(CFG)
    m.add_trajectory(_dwelling_robot(12, 0.9))
    _poisson_people(m, 12, 100.0)
    state = m.state
    assert len(state.pending.windows) == 2  # T0 is ten windows before midnight
    rows = np.array([_row(m, A), _row(m, B)])
    pending = state.windows_observed(rows, open_window=True)
    np.testing.assert_allclose(pending, [10.8, 1.2], atol=2.0 / SUBSTEPS * 12)
    table = historical_table(state)
    detected = state.entries.counts[rows].sum(axis=1) + state.entries.nodir[rows]
    at = [_at(table, A), _at(table, B)]
    np.testing.assert_allclose(table.flow[at], detected / pending, rtol=1e-9)
    state.close_day()
    np.testing.assert_allclose(state.windows_observed(rows), pending, rtol=1e-9)


@pytest.mark.parametrize("floor", [1.0 / SUBSTEPS, ModelConfig().exposure_floor])
def test_a_place_passed_for_seconds_does_not_top_the_map(floor: float) -> None:
    """Three days beside A (5 people a window); once, the robot steps to C for 4 s (less than
    one 10-s step) while one person there is detected 3 times. C was watched 1/60 of one
    window: its rate was 3 / (1/60) = 180 a window, 36 times the busiest place, in history
    and forecast (3 / 0.2 = 15, three times it, with the default ``exposure_floor``). Less
    than a window of watching in all counts as one: 3, the detections seen (what whole windows
    say), and A keeps its 5."""
    windows = 3 * 144
    far = np.array([30.0, 0.0, 0.0])
    t = T0 + np.arange(0, windows * W, 2 * S, dtype=np.int64)
    xyz = np.tile(A, (t.size, 1))
    xyz[(t >= T0 + 100 * W + 300 * S) & (t < T0 + 100 * W + 304 * S)] = far
    m = Mapper(CFG.replace(exposure_floor=floor))
    m.add_trajectory(Trajectory(t, xyz))
    rng = np.random.default_rng(0)
    det = list(T0 + (np.sort(rng.uniform(0, windows * 600, windows * 5)) * S).astype(np.int64))
    where = [A + 0.1] * len(det)
    for s in (300.5, 301.5, 302.5):
        det.append(T0 + 100 * W + int(s * S))
        where.append(far + 0.1)
    order = np.argsort(det, kind="stable")
    m.add_detections(detections(np.array(det)[order], np.array(where)[order]))
    m.advance(T0 + windows * W)
    check_invariants(m.state)
    c = _row(m, far)
    assert float(m.state.windows_observed(np.array([c]), open_window=True)[0]) < 1.0
    history = historical_table(m.state)
    at_c = int(np.flatnonzero(np.abs(history.xyz[:, 0] - 30.25) < 0.5)[0])
    at_a = int(np.flatnonzero(np.abs(history.xyz[:, 0] - 0.25) < 0.5)[0])
    assert float(history.flow[at_c]) == 3.0
    assert float(history.flow[at_a]) == pytest.approx(5.0, rel=0.05)
    forecast = predict_table(m.state, T0 + windows * W + 3600 * S)
    # 01:00, an hour C was never watched at: its static rate times the group's daily shape
    # there (e5fceacc), which A's even day keeps within its sampling noise of 1
    assert float(forecast.flow[at_c]) == pytest.approx(3.0, rel=0.05)
    assert int(np.nanargmax(forecast.flow)) == at_a


def test_exposure_reads_the_window_s_own_poses_however_the_log_was_read() -> None:
    """Poses 100 s apart beside P at 400 s and 601 s. The steps ending window 0 (575-595 s)
    are nearest the pose of 601 s, in window 1: they counted when that pose had been read
    before window 0 closed (12 steps in all), not when the log reached it later (9). And a
    step opening a window took the pose before it where a shard keeps the closed windows'
    poses, but not after a build pruned them. Only the window's own poses count: the same
    exposure either way."""
    far = np.array([50.0, 0.0, 0.0])
    seconds = np.array([0, 100, 200, 300, 400, 500, 601, 700, 800, 900, 1000, 1100, 1199])
    t = T0 + seconds * S
    xyz = np.array([far] * 4 + [A, far, A] + [far] * 6)

    def steps(poses_first: bool) -> float:
        m = Mapper(CFG)
        cut = t.size if poses_first else 6  # else the poses up to 500 s before the detections
        m.add_trajectory(Trajectory(t[:cut], xyz[:cut]))
        m.add_detections(detections(T0 + np.array([400, 610]) * S, np.array([A, A]) + 0.1))
        m.add_trajectory(Trajectory(t[cut:], xyz[cut:]))
        m.advance(T0 + 2 * W)
        m.state.close_day()
        return float(m.state.temporal.obs.n[_row(m, A)]) * SUBSTEPS

    assert steps(True) == pytest.approx(steps(False))
    # window 1 opens 2 s from the pose of 598 s, beside P: pruned or not, the same exposure
    source = ObservationSource()
    source.add_trajectory(Trajectory(T0 + np.array([598, 640, 700]) * S, np.array([A, far, A])))
    window = T0 // W + 1
    kept = source.robot_exposure(np.array([A[:2]]), window, W, 8.0)
    source.prune(T0 + W)
    assert source.robot_exposure(np.array([A[:2]]), window, W, 8.0)[0] == pytest.approx(kept[0])
