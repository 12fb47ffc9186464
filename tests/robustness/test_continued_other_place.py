"""``aion build LOG --map OLD`` with logs of another place: most of the new detections lie
farther than the sensor range from every entry OLD held, and the build warns so (naming the
share and what ``--map`` is for), in one process and with ``--workers 2``; logs of OLD's own
place, or a minority of detections elsewhere (a robot exploring new ground), are not warned
of (``build_plausibility.NEW_GROUND_SHARE``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.build_options import BuildOptions
from aion_cli.build_plausibility import NEW_GROUND_SHARE
from aion_cli.pipeline import build_map
from tests.robustness.conftest import T0, Message, S, person, write_log

HOUR_S = 3600


def _people(seed: int, start_s: int, n: int, origin: float) -> list[Message]:
    """``n`` people at random places of a 6 m square from (``origin``, ``origin``), one
    every 10 s from ``T0 + start_s``."""
    rng = np.random.default_rng(seed)
    return [
        person(T0 + (start_s + 10 * k) * S,
               (origin + float(rng.uniform(0, 6)), origin + float(rng.uniform(0, 6)), 0.0),
               track=k % 4 + 1)
        for k in range(n)
    ]


def _old_map(tmp_path: Path) -> Path:
    log = write_log(tmp_path / "old.mcap", _people(1, 0, 120, 0.0))
    out = tmp_path / "old.aion"
    build_map(BuildOptions(logs=(log,), output=out))
    return out


def _continue(old: Path, out: Path, logs: tuple[Path, ...], workers: int = 1) -> list[str]:
    report = build_map(BuildOptions(logs=logs, output=out, continue_from=old, workers=workers))
    return [w for w in report.warnings if "from every entry it held" in w]


@pytest.mark.parametrize("workers", [1, 2])
def test_logs_of_a_place_far_from_the_continued_map_are_warned_of(
    tmp_path: Path, workers: int
) -> None:
    old = _old_map(tmp_path)
    # two logs after the map, 500 m away (another building in its own frame)
    far = (
        write_log(tmp_path / "far1.mcap", _people(2, 2 * HOUR_S, 60, 500.0)),
        write_log(tmp_path / "far2.mcap", _people(3, 3 * HOUR_S, 60, 500.0)),
    )
    warned = _continue(old, tmp_path / "far.aion", far, workers)
    assert len(warned) == 1, warned
    assert warned[0].startswith("100% of the 120 detections"), warned[0]
    assert "to old.aion" in warned[0]
    assert "--map is for more logs of the same place" in warned[0]
    # the same logs at the map's own place: nothing to warn of
    near = (
        write_log(tmp_path / "near1.mcap", _people(2, 2 * HOUR_S, 60, 0.0)),
        write_log(tmp_path / "near2.mcap", _people(3, 3 * HOUR_S, 60, 0.0)),
    )
    assert _continue(old, tmp_path / "near.aion", near, workers) == []


def test_a_minority_on_new_ground_is_not_warned_of(tmp_path: Path) -> None:
    """A robot exploring: 40 of 100 new detections far away (under the bar), then 60."""
    old = _old_map(tmp_path)
    assert NEW_GROUND_SHARE == 0.5  # the shares below straddle it
    some = write_log(tmp_path / "some.mcap", sorted(
        _people(4, 2 * HOUR_S, 60, 0.0) + _people(5, 2 * HOUR_S + 5, 40, 500.0),
        key=lambda m: m[3]))
    assert _continue(old, tmp_path / "some.aion", (some,)) == []
    most = write_log(tmp_path / "most.mcap", sorted(
        _people(4, 2 * HOUR_S, 40, 0.0) + _people(5, 2 * HOUR_S + 5, 60, 500.0),
        key=lambda m: m[3]))
    warned = _continue(old, tmp_path / "most.aion", (most,))
    assert len(warned) == 1, warned
    assert warned[0].startswith("60% of the 100 detections the logs added to old.aion (60)")
