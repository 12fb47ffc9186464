"""A kind of day the map never saw (a Saturday of a map of weekdays) keeps each place's own
rhythm: every entry's ``profile`` reads its own counts at the same hour of the kinds seen,
as the map's and the groups' shapes do, so the forecast follows the weekdays' rhythm and
level per place, not only in the map's total."""

from __future__ import annotations

import numpy as np
import pytest

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.query import EntryTable, predict_table
from aion_cli.engine.types import DetectionBatch
from tests.engine.temporal_data import DAY, HOUR, MONDAY

WEEKDAYS = 5
LUNCH = 12


def _steady(h: int) -> float:
    return 60.0  # the hall: the same all day


def _kitchen(h: int) -> float:
    return 240.0 if h == LUNCH else 0.0  # the kitchen: busy at lunch only


def _weekdays(profile: str) -> tuple[Mapper, np.ndarray]:
    """A fixed sensor over Monday to Friday (no weekend window observed): a kitchen (x, y in
    0..1 m, four 0.5 m cells) busy at lunch only and a hall (x 4..10 m) busy all day.
    Returns the map and the kitchen's detections per hour of the day, summed over the days."""
    rng = np.random.default_rng(3)
    mapper = Mapper(ModelConfig(profile=profile))
    end = MONDAY + WEEKDAYS * DAY
    mapper.set_fixed_sensor(MONDAY, end)
    kitchen = np.zeros(24)
    for d in range(WEEKDAYS):
        for h in range(24):
            start = MONDAY + d * DAY + h * HOUR
            n_k, n_h = int(rng.poisson(_kitchen(h))), int(rng.poisson(_steady(h)))
            kitchen[h] += n_k
            xy = np.concatenate(
                [rng.uniform(0.0, 1.0, (n_k, 2)), rng.uniform((4.0, 0.0), (10.0, 2.0), (n_h, 2))]
            )
            n = n_k + n_h
            order = np.argsort(t := start + rng.integers(0, HOUR, n))
            batch = DetectionBatch.from_arrays(
                t[order], np.column_stack([xy[order], np.zeros(n)]), np.zeros(n), np.ones(n)
            )
            mapper.add_detections(batch)
    mapper.advance(end)
    return mapper, kitchen


def _in_kitchen(table: EntryTable) -> np.ndarray:
    xyz = table.xyz
    out: np.ndarray = (table.kind == 0) & (xyz[:, 0] < 1.0) & (xyz[:, 1] < 1.0)
    return out


@pytest.mark.parametrize("profile", ["day_weekend", "week"])
def test_a_saturday_keeps_the_kitchens_lunch(profile: str) -> None:
    """Before: the kitchen's cells forecast Saturday noon from the map's shape (their
    lunch spread over the hall's steady day: about a fifth of it) and Saturday 03:00 at
    several times their weekday night. Now Saturday noon is the kitchen's weekday noon
    — the detections counted at 12:00 over the weekdays per 10-minute window of that hour
    — and its night stays near empty, as on a weekday."""
    mapper, counted = _weekdays(profile)
    saturday, friday = MONDAY + 5 * DAY, MONDAY + 4 * DAY
    sat_noon = predict_table(mapper.state, saturday + LUNCH * HOUR + HOUR // 2)
    kitchen = _in_kitchen(sat_noon)
    assert kitchen.sum() == 4
    assert set(sat_noon.flow_family[kitchen].tolist()) == {"profile"}
    # independently: the kitchen's lunch detections per observed window (6 an hour each day)
    expected = counted[LUNCH] / (6 * WEEKDAYS)
    assert float(sat_noon.flow[kitchen].sum()) == pytest.approx(expected, rel=0.05)
    sat_night = predict_table(mapper.state, saturday + 3 * HOUR + HOUR // 2)
    assert float(sat_night.flow[kitchen].sum()) < 0.02 * expected
    if profile == "day_weekend":  # one kind seen: Saturday's hours are the weekdays' own
        fri_noon = predict_table(mapper.state, friday + LUNCH * HOUR + HOUR // 2)
        np.testing.assert_allclose(sat_noon.flow, fri_noon.flow, rtol=1e-12)
        np.testing.assert_allclose(
            sat_noon.descriptors.probabilities, fri_noon.descriptors.probabilities, atol=1e-12
        )
