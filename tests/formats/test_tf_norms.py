"""Rotations tf2 refuses as not normalised (|q|² − 1 beyond ±0.01), as aion tallies them."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from aion_cli.formats.tf_norms import NormTally, off_unit


def test_off_unit_is_tf2s_tolerance_and_leaves_zero_and_nan_to_the_buffer() -> None:
    q = np.array(
        [
            [0, 0, 0, 1.0],
            [0, 0, 0, 1.004],  # |q|² − 1 = 0.008: tf2 takes it
            [0, 0, 0, 1.006],  # 0.012: tf2 refuses it
            [0, 0, 0, 0.994],  # −0.012: refused too (tf2 takes the absolute value)
            [0, 0, 0, 0.0],  # dropped as unusable by the buffer, not counted here
            [np.nan, 0, 0, 1.0],
        ]
    )
    assert off_unit(q).tolist() == [False, False, True, True, False, False]


def _tf(parent: str, child: str, w: float) -> SimpleNamespace:
    rot = SimpleNamespace(x=0.0, y=0.0, z=0.0, w=w)
    return SimpleNamespace(
        header=SimpleNamespace(frame_id=parent),
        child_frame_id=child,
        transform=SimpleNamespace(rotation=rot),
    )


def test_decoded_messages_count_once_per_message_and_edge() -> None:
    """The generic decoder's path: two messages, one of them with the bad edge twice; the
    self-referencing transform (which the buffer refuses for its frames) is not counted."""
    tally = NormTally()
    tally.add_message("/tf", SimpleNamespace(transforms=[_tf("/map", "odom", 0.5),
                                                          _tf("map", "odom", 3.0),
                                                          _tf("odom", "odom", 9.0)]))
    tally.add_message("/tf", SimpleNamespace(transforms=[_tf("map", "odom", 1.0)]))
    tally.add_message("/tf", SimpleNamespace(transforms=[_tf("map", "odom", 2.0)]))
    assert tally.edges == {("/tf", "map", "odom"): [2, 0.5, 3.0]}
    assert "map->odom on /tf in 2 messages (|q| 0.5 to 3)" in tally.text()
    assert NormTally().text() == ""
