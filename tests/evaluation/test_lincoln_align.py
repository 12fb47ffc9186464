"""evaluate lincoln --align-05-31: a day drawn in another frame is put into the other days'
(positions and headings), and the JSON record names the transform found."""

from __future__ import annotations

import numpy as np

from aion_cli.engine.align import RigidAlignment
from aion_cli.engine.types import DetectionBatch
from aion_cli.evaluation.lincoln import DayData, align_day
from tests.engine.test_align import corridor


def day(name: str, xy: np.ndarray, heading: np.ndarray) -> DayData:
    n = len(xy)
    batch = DetectionBatch(np.arange(n, dtype=np.int64), np.c_[xy, np.zeros(n)], heading,
                           np.ones(n), np.full(n, -1, dtype=np.int64))
    return DayData(name, batch, [(0, n)], "generated")


def test_the_day_is_put_into_the_other_days_frame() -> None:
    rng = np.random.default_rng(3)
    truth = corridor(rng, 6_000)
    heading = rng.uniform(-np.pi, np.pi, len(truth))
    away = RigidAlignment(np.deg2rad(-171.4), (4.0, -9.0), False, 0.0, 0.0)
    days = {k: day(k, corridor(rng, 9_000), rng.uniform(-np.pi, np.pi, 9_000)) for k in "ab"}
    days["odd"] = day("odd", away.apply(truth), away.apply_heading(heading))
    record = align_day(days, "odd", ["a", "b"])
    assert record is not None
    assert record["onto"] == ["a", "b"]
    assert not record["mirror"]
    assert record["overlap_after"] > record["overlap_before"]
    back = days["odd"].batch
    assert np.max(np.hypot(*(back.xyz[:, :2] - truth).T)) < 0.3
    assert np.max(np.abs(np.angle(np.exp(1j * (back.heading - heading))))) < np.deg2rad(2.0)
    assert days["a"].batch.xyz.shape == (9_000, 3)  # the others untouched


def test_nothing_to_align_onto() -> None:
    days = {"odd": day("odd", corridor(np.random.default_rng(0), 100), np.zeros(100))}
    assert align_day(days, "odd", []) is None
    assert days["odd"].spans == [(0, 100)]
    assert len(days["odd"].batch) == 100
