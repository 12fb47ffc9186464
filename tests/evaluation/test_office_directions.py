"""Directions against the truth (``evaluation.office_directions``): hand-computed cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.evaluation.office_directions import (
    DIRECTION_METRICS,
    direction_truth_scores,
    direction_truth_sentence,
    direction_truth_table,
    mean_normalised,
    normalised_entropy,
)


def _one_hot(b: int, bins: int = 8, n: float = 10.0) -> list[float]:
    row = [0.0] * bins
    row[b] = n
    return row


def test_a_map_equal_to_the_truth_scores_zero() -> None:
    truth = np.array([_one_hot(0), [1, 2, 3, 4, 0, 0, 0, 0]], dtype=float)
    scores = direction_truth_scores(truth, {"same": truth * 3.0})
    assert scores["places"] == 2.0
    assert scores["same"] == pytest.approx(dict.fromkeys(DIRECTION_METRICS, 0.0), abs=1e-12)


def test_opposite_and_uniform_maps() -> None:
    truth = np.array([_one_hot(0)], dtype=float)  # everyone walks east
    scores = direction_truth_scores(
        truth, {"west": np.array([_one_hot(4)], float), "uniform": np.ones((1, 8))}
    )
    west, uniform = scores["west"], scores["uniform"]
    assert west["js"] == pytest.approx(1.0)  # disjoint distributions: 1 bit
    assert west["dominant_deg"] == pytest.approx(180.0)
    assert west["entropy_error"] == pytest.approx(0.0)
    # uniform against one bin: entropy 1 against 0; JS = 1 - (7/16) log2 (16/2)... by hand:
    # m = (1/2 + 1/16, 1/16 x 7); KL(p||m) = log2(1/(9/16)); KL(u||m) = 1/8 log2((1/8)/(9/16))
    kl_p = math.log2(16 / 9)
    kl_u = (1 / 8) * math.log2(2 / 9) + (7 / 8) * math.log2(2.0)
    assert uniform["js"] == pytest.approx(0.5 * kl_p + 0.5 * kl_u)
    assert uniform["entropy_error"] == pytest.approx(1.0)
    assert uniform["entropy_bias"] == pytest.approx(1.0)
    assert uniform["dominant_deg"] == pytest.approx(0.0)  # the first of equal bins


def test_places_any_map_lacks_are_left_out_for_every_map() -> None:
    truth = np.array([_one_hot(2), _one_hot(2), [0.0] * 8])
    a = np.array([_one_hot(2), _one_hot(6), _one_hot(1)])
    b = np.array([_one_hot(2), [0.0] * 8, _one_hot(1)])  # no counts at the second place
    scores = direction_truth_scores(truth, {"a": a, "b": b})
    assert scores["places"] == 1.0  # the second lacks b, the third the truth
    assert scores["a"]["dominant_deg"] == pytest.approx(0.0)  # a's 180° miss is left out


def test_no_common_place_gives_nan() -> None:
    scores = direction_truth_scores(np.zeros((2, 8)), {"a": np.ones((2, 8))})
    assert scores["places"] == 0.0
    assert all(math.isnan(v) for v in scores["a"].values())


def test_mismatched_shapes_are_refused() -> None:
    with pytest.raises(ValueError, match="one histogram row per true histogram"):
        direction_truth_scores(np.ones((2, 8)), {"a": np.ones((3, 8))})


def test_mean_normalised_weighs_every_time_the_same() -> None:
    busy = np.array([_one_hot(0, n=100.0)])
    quiet = np.array([_one_hot(4, n=1.0)])
    mean = mean_normalised([busy, quiet, np.zeros((1, 8))])
    expected = np.zeros((1, 8))
    expected[0, 0] = expected[0, 4] = 1 / 3
    np.testing.assert_allclose(mean, expected)
    with pytest.raises(ValueError):
        mean_normalised([])


def test_normalised_entropy_bounds() -> None:
    h = normalised_entropy(np.array([_one_hot(3), [1.0] * 8, [1, 1, 0, 0, 0, 0, 0, 0]]))
    np.testing.assert_allclose(h, [0.0, 1.0, 1 / 3])  # ln 2 / ln 8


def test_table_averages_the_scenes_that_compared_places() -> None:
    def scene(js: float, places: float = 3.0) -> dict:
        row = {"js": js, "dominant_deg": 45.0, "entropy_error": 0.1, "entropy_bias": -0.1}
        return {"directions": {"places": places, "aion historical": row,
                               "aion predicted": row, "grid historical": row,
                               "grid predicted": row}}

    rows = direction_truth_table([scene(0.2), scene(0.4), scene(0.9, places=0.0), {}])
    first = rows[0]
    assert first["scenes"] == 2
    assert first["js"] == pytest.approx((0.3, 0.1))
    assert "aion historical JS 0.300" in direction_truth_sentence(rows)
