"""Synthetic people streams with known temporal structure, for the temporal-model tests."""

from __future__ import annotations

from collections.abc import Callable
from datetime import UTC, datetime

import numpy as np

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.types import DetectionBatch

S = 1_000_000_000
HOUR = 3600 * S
DAY = 24 * HOUR
MONDAY = int(datetime(2026, 11, 2, tzinfo=UTC).timestamp()) * S  # a Monday, 00:00 UTC


def rush(d: int, h: int) -> float:
    """People only 08-10 h and 17-19 h, 300 an hour."""
    return 300.0 if h in (8, 9, 17, 18) else 0.0


RHYTHM_PERIOD_H = 56.0


def rhythm_56h(d: int, h: int) -> float:
    """A 56 h rhythm (7 d / 3: a FreMEn period no hour-of-day profile can hold)."""
    return 60.0 * (1.0 + np.cos(2 * np.pi * (d * 24 + h + 0.5) / RHYTHM_PERIOD_H))


def heading_56h(d: int, h: int) -> float:
    """East while the rhythm rises, west while it falls: per-bin rhythms that cancel in the
    total (what per-bin FreMEn directions are for)."""
    return 0.0 if np.sin(2 * np.pi * (d * 24 + h + 0.5) / RHYTHM_PERIOD_H) > 0 else np.pi


def corridor(
    days: int,
    rate_per_hour: Callable[[int, int], float],
    seed: int = 0,
    config: ModelConfig | None = None,
    cells: tuple[float, float] = (10.0, 2.0),
    start_ns: int = MONDAY,
    heading: Callable[[int, int], float] | None = None,
    end_ns: int | None = None,
) -> Mapper:
    """A fixed sensor over ``days`` days watching a corridor of ``cells`` metres; in hour h of
    day d a Poisson number of people (mean ``rate_per_hour(d, h)``) is detected at uniform
    random places and times, walking ``heading(d, h)`` (default east). ``end_ns``: the
    recording stops there instead (at an hour's start), the last day left pending."""
    rng = np.random.default_rng(seed)
    mapper = Mapper(config or ModelConfig())
    stop = start_ns + days * DAY if end_ns is None else end_ns
    mapper.set_fixed_sensor(start_ns, stop)
    for d in range(days):
        for h in range(24):
            n = int(rng.poisson(rate_per_hour(d, h)))
            if n == 0 or start_ns + d * DAY + h * HOUR >= stop:
                continue
            t = start_ns + d * DAY + h * HOUR + np.sort(rng.integers(0, HOUR, n))
            xy = rng.uniform((0.0, 0.0), cells, size=(n, 2))
            theta = 0.0 if heading is None else heading(d, h)
            head = np.full(n, theta) + rng.normal(0.0, 0.1, n)
            head = np.mod(head + np.pi, 2 * np.pi) - np.pi
            batch = DetectionBatch.from_arrays(
                t, np.column_stack([xy, np.zeros(n)]), head, np.ones(n)
            )
            mapper.add_detections(batch)
    mapper.advance(stop)
    return mapper


def total_flow(mapper: Mapper, t_ns: int) -> float:
    """Predicted detections per window summed over the map at ``t_ns``."""
    from aion_cli.engine.query import predict_table

    return float(np.nansum(predict_table(mapper.state, int(t_ns)).flow))


def bursty_corridor(
    days: int,
    passes_per_hour: Callable[[int, int], float],
    burst: int,
    seed: int = 0,
    cells: tuple[float, float] = (10.0, 2.0),
    first_hour: int = 0,
) -> Mapper:
    """A fixed sensor watching a corridor from ``first_hour`` on the first day to the end of
    day ``days``: in hour h of day d a Poisson number of people (mean
    ``passes_per_hour(d, h)``) walk 2 m east within 10 s, each detected ``burst`` times — the
    detections of a window come in bursts, as a tracker's do (one person, many detections,
    several cells)."""
    rng = np.random.default_rng(seed)
    mapper = Mapper(ModelConfig())
    mapper.set_fixed_sensor(start_ns := MONDAY + first_hour * HOUR, MONDAY + days * DAY)
    for d in range(days):
        for h in range(24):
            n = int(rng.poisson(passes_per_hour(d, h)))
            start = MONDAY + d * DAY + h * HOUR
            if n == 0 or start < start_ns:
                continue
            t0 = start + np.sort(rng.integers(0, HOUR - 60 * S, n))
            t = (t0[:, None] + np.arange(burst)[None, :] * (10 * S // burst)).reshape(-1)
            x0 = rng.uniform(0.0, cells[0] - 2.0, n)
            x = (x0[:, None] + np.linspace(0.0, 2.0, burst)[None, :]).reshape(-1)
            y = np.repeat(rng.uniform(0.0, cells[1], n), burst)
            k = t.size
            xyz = np.column_stack([x, y, np.zeros(k)])
            mapper.add_detections(DetectionBatch.from_arrays(t, xyz, np.zeros(k), np.ones(k)))
    mapper.advance(MONDAY + days * DAY)
    return mapper
