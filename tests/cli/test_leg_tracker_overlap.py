"""Two of the real leg_tracker bags, ``positive_1`` and ``positive_2``, share 0.3 s of log
time: their log times (and stamps) are those of their extraction, one after the other, not of
the recordings. Within the 0.5 s matching tolerance any person near another matched, and the
build warned that they hold "the same people at the same times and places" (it first also
said the time they share was "(0.0 h)"). A stretch that short is now compared at a quarter of
its length and against chance proximity (``aion_cli.log_twins``): the pair does not warn, in
build or info. The shared time, from the bags' own first and last message times (read here
with rosbags), is under a second, so the twin warning's own "(0.3 s)" wording is covered with
generated logs (tests/robustness/test_overlap_people.py)."""

from __future__ import annotations

from pathlib import Path

from rosbags.rosbag1 import Reader

from tests.cli.conftest import run_json
from tests.shared_data import real


def _times(path: Path) -> tuple[int, int]:
    with Reader(path) as bag:
        return bag.start_time, bag.end_time - 1  # rosbags' end is one past the last message


def test_two_bags_sharing_a_fraction_of_a_second_are_not_said_to_be_twins(
    tmp_path: Path,
) -> None:
    one = real("logs", "leg_tracker", "positive_1_extracted.bag")
    two = real("logs", "leg_tracker", "positive_2_extracted.bag")
    (start1, end1), (start2, end2) = _times(one), _times(two)
    shared_s = (min(end1, end2) - max(start1, start2)) / 1e9
    assert 0.05 < shared_s < 2.0  # shorter than four 0.5 s tolerances: evidence is asked
    build = run_json("build", one, two, "-o", tmp_path / "m.aion", "--map-frame",
                     "right_laser", "--workers", "1", "--format", "json")  # fmt: skip
    assert not [w for w in build["warnings"] if "count twice" in w]
    assert not [w for w in build["warnings"] if "same people" in w]
    both = run_json("info", one, two, "--format", "json")
    assert not [w for w in both["warnings"] if "count twice" in w]
