"""Issue 15, a build's usual window close: one window, no robot pose pending
(``closing._close_one``) gives exactly what the general path of ``close_windows`` gave
(kept verbatim below), and takes the shortcut.

Builds of three days under a fixed sensor whose interval starts and ends inside windows
and has a gap (shares below 1, uncovered windows), with and without ``exposure``, and
without any observation source (windows recorded by their detections alone), with
graphs whose nodes come, go and move (binds inside closes), compared array by array.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from aion_cli.engine import closing
from aion_cli.engine import mapper as mapper_module
from aion_cli.engine.closing import _record, _recorded_windows
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.ownership import (
    apply_binds,
    plan_binds,
    stable_nodes,
    unentered_stable_nodes,
)
from aion_cli.engine.windows import window_centre_ns, window_ns, window_start_ns
from tests.engine.engine_builders import T0_DAY_END, S, feed_bursts


def _close_windows_before(state: Any, stop: int) -> None:
    """``closing.close_windows`` before the single-window shortcut (verbatim)."""
    w0 = state.open_window
    if w0 is None or stop <= w0:
        return
    delta = window_ns(state.config.window_s)
    count_rows = state.entries.window_rows()
    recorded = _recorded_windows(state, w0, stop, count_rows)
    if recorded.size <= 4:  # a build's usual step: one window, its day remembered
        days = [state.window_day(w) for w in recorded.tolist()]
    else:
        days = state.params.calendar.day(window_centre_ns(recorded, delta)).tolist()
    segment: list[int] = []
    segment_day: int | None = None
    stable_seen = -1
    waiting = np.zeros(0, np.int64)  # stable nodes the robot has not observed yet: no entry

    def record() -> None:
        nonlocal waiting
        waiting = _record(state, np.array(segment, np.int64), w0, delta, count_rows, waiting)
        segment.clear()

    for w, day in zip(recorded.tolist(), days, strict=True):
        if segment and day != segment_day:  # a day is over: record it and close it
            record()
            state.close_day()
        segment_day = day
        end = int(window_start_ns(w + 1, delta))
        n_stable = int(np.count_nonzero(stable_nodes(state, end)))
        if n_stable != stable_seen:
            stable_seen = n_stable
            plan = plan_binds(state, end)
            newly = unentered_stable_nodes(state, end)
            if plan is not None or not np.array_equal(newly, waiting):
                record()  # the windows before, with the nodes waiting before
                waiting = newly
                if plan is not None:
                    apply_binds(state, plan)
                count_rows = state.entries.window_rows()  # the counts moved with the cells
        segment.append(w)
    record()
    state.entries.clear_window()
    state.open_window = int(stop)
    if state.deferred is None:  # a shard keeps its poses for the join (engine.shards)
        state.observation.prune(int(window_start_ns(stop, delta)))
    if (
        state.pending
        and state.pending.day is not None
        and state.window_day(stop) > state.pending.day
    ):
        state.close_day()  # log time is in a later day: the pending day is over


def _build(seed: int, source: str, exposure: bool) -> dict[str, np.ndarray]:
    """Three days: detections in bursts (many windows without any), a graph now and then
    whose nodes come, go and move; ``source`` "fixed": a fixed sensor from 7 minutes into a
    window to 4 minutes into another, with a gap of a few hours; "none": no source."""
    rng = np.random.default_rng(seed)
    cfg = ModelConfig(
        stability_s=120.0, window_s=600.0, cell_size=0.5, bind_radius=1.0, exposure=exposure
    )
    m = Mapper(cfg)
    start = T0_DAY_END - 3 * 3600 * S + 420 * S
    end = start + 3 * 86_400 * S - 180 * S
    if source == "fixed":
        m.set_fixed_sensor(start, start + 30 * 3600 * S + 77 * S)
        m.set_fixed_sensor(start + 34 * 3600 * S + 250 * S, end)
    return feed_bursts(m, rng, start, end, (200, 800))


@pytest.mark.parametrize(
    ("source", "exposure"), [("fixed", True), ("fixed", False), ("none", True)]
)
@pytest.mark.parametrize("seed", [1, 2])
def test_single_window_closes_equal_the_general_path_bit_for_bit(
    seed: int, source: str, exposure: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    taken: list[int] = []
    one = closing._close_one

    def counted(state: Any, w0: int, delta: int) -> None:
        taken.append(w0)
        one(state, w0, delta)

    with monkeypatch.context() as patch:
        patch.setattr(closing, "_close_one", counted)
        fast = _build(seed, source, exposure)
    with monkeypatch.context() as patch:
        patch.setattr(closing, "close_windows", _close_windows_before)
        patch.setattr(mapper_module, "close_windows", _close_windows_before)
        plain = _build(seed, source, exposure)
    assert mapper_module.close_windows is closing.close_windows  # patches undone
    assert sorted(fast) == sorted(plain)
    for name in fast:
        assert fast[name].dtype == plain[name].dtype, name
        assert fast[name].shape == plain[name].shape, name
        assert fast[name].tobytes() == plain[name].tobytes(), name
    # the builds did what they are meant to exercise: most closes took the shortcut, cells
    # were bound, days closed and scored
    assert len(taken) > 100
    assert fast["redirect_keys"].size > 0
    assert fast["temporal_flow_scored"].sum() > 0
    if source == "fixed":
        shares = np.asarray(fast["temporal_glob_n"]).sum()
        assert 0 < shares < 3 * 144  # partial windows and a gap


def test_one_window_share_equals_the_share_of_many_windows() -> None:
    """``fixed_share_of`` (one window, a float) against ``fixed_share`` of a run of windows
    (the vectorised path, integer nanoseconds), around interval ends and gaps."""
    m = Mapper(ModelConfig(window_s=600.0))
    obs = m.state.observation
    delta = 600 * S
    start = T0_DAY_END + 420 * S
    obs.set_fixed_sensor(start, start + 5 * delta + 17 * S)
    obs.set_fixed_sensor(start + 9 * delta, start + 9 * delta + 1)
    obs.set_fixed_sensor(start + 12 * delta + 3 * S, start + 14 * delta)
    w0 = start // delta - 2
    windows = np.arange(w0, w0 + 20, dtype=np.int64)
    for exposure in (True, False):
        cfg = ModelConfig(window_s=600.0, exposure=exposure)
        many = obs.fixed_share(windows, delta, cfg)
        ones = [obs.fixed_share_of(int(w), delta, cfg) for w in windows.tolist()]
        assert np.array(ones).tobytes() == many.tobytes()
        assert (many == 0).any()  # uncovered windows asked
        assert (many == 1).any()  # whole ones
        assert ((many > 0) & (many < 1)).any() == exposure  # and windows covered in part
