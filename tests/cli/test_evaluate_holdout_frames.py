"""``aion evaluate holdout`` on the corridor of :mod:`tests.cli.test_evaluate_holdout`: what
its notes say of the frames the test logs were read in."""

from __future__ import annotations

from tests.cli.conftest import run_json
from tests.cli.test_evaluate_holdout import corridor

__all__ = ["corridor"]  # the fixture, built once for this module


def test_the_fixed_sensor_note_names_the_frames_given(corridor: tuple) -> None:
    """The test day has no TF: with --base-frame robot1 the note said "no robot trajectory
    (TF map->base_link ...)", a chain nobody asked for; it names map->robot1 now."""
    site, _train, test, _truth = corridor
    doc = run_json("evaluate", "holdout", site, test, "--format", "json",
                   "--base-frame", "robot1")  # fmt: skip
    said = [n for n in doc["notes"] if n.startswith("no robot trajectory")]
    assert len(said) == 1, doc["notes"]
    assert said[0].startswith("no robot trajectory (TF map->robot1 or scene-graph agents)")
