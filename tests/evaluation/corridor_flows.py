"""A corridor whose flow is known, for the grid baseline and heading-score tests: people walk
+x in the morning hours and -x in the afternoon hours."""

from __future__ import annotations

import math

import numpy as np

from aion_cli.engine.types import DetectionBatch
from aion_cli.engine.windows import EPOCH_NS

HOUR = 3_600_000_000_000  # ns


def corridor_flow(hours: int, seed: int = 0) -> DetectionBatch:
    """People walk +x along y = 0.5 in the morning hours and -x in the afternoon hours."""
    rng = np.random.default_rng(seed)
    t, x, h = [], [], []
    for hour in range(hours):
        n = 40
        t.append(EPOCH_NS + hour * HOUR + rng.integers(0, HOUR, n))
        x.append(rng.uniform(0.0, 10.0, n))
        h.append(np.full(n, 0.0 if (hour % 24) < 12 else math.pi - 1e-9))
    tt = np.concatenate(t)
    xyz = np.column_stack([np.concatenate(x), np.full(len(tt), 0.5), np.zeros(len(tt))])
    return DetectionBatch.from_arrays(tt, xyz, np.concatenate(h))
