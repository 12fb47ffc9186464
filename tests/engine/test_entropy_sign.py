"""Everyone walking one way is entropy 0, not -0.0: ``-Σ p ln p`` of a one-bin histogram is
``-(0.0)``, which ``predict --format json`` / ``csv`` printed as ``"entropy": -0.0`` (a
negative entropy to any script that checks the sign or prints it)."""

from __future__ import annotations

import numpy as np

from aion_cli.engine.descriptors import _entropy_nats


def test_entropy_of_one_direction_is_positive_zero() -> None:
    probs = np.array([[0.0, 1.0, 0.0, 0.0], [0.25, 0.25, 0.25, 0.25]])
    h = _entropy_nats(probs)
    assert h[0] == 0.0
    assert not np.signbit(h[0])  # before: -0.0
    assert np.isclose(h[1], np.log(4))
