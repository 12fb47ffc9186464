"""The table's direction column: whole degrees with a sign, one label per direction."""

from __future__ import annotations

import math

import pytest

from aion_cli.cli.output import degrees


@pytest.mark.parametrize(
    ("radians", "shown"),
    [
        (0.0, "+0°"),
        (-1e-6, "+0°"),  # not "-0°"
        (math.radians(-0.4), "+0°"),
        (math.radians(22.5), "+22°"),  # rounded half to even, as round() does
        (math.radians(-90.0), "-90°"),
        (math.pi, "+180°"),
        (-math.pi, "+180°"),  # the same direction as +180
        (math.radians(-179.7), "+180°"),
        (math.radians(179.4), "+179°"),
    ],
)
def test_directions_read_one_way(radians: float, shown: str) -> None:
    assert degrees(radians) == shown


def test_unknown_directions_are_a_dash() -> None:
    assert degrees(None) == "-"
    assert degrees(float("nan")) == "-"
