"""Two of the real leg_tracker bags recorded the same 0.3 s (positive_2's clusters lie within
positive_1's time): the build warns that their people count twice, and said the time they
share was "(0.0 h)". It now gives it as ``aion info`` gives spans ("0.3 s"), from the bags'
own first and last message times (read here with rosbags). ``aion info`` of the two said
nothing of it; it now gives the build's warning."""

from __future__ import annotations

from pathlib import Path

from rosbags.rosbag1 import Reader

from tests.cli.conftest import run_json
from tests.shared_data import real


def _times(path: Path) -> tuple[int, int]:
    with Reader(path) as bag:
        return bag.start_time, bag.end_time - 1  # rosbags' end is one past the last message


def test_bags_sharing_under_a_second_say_how_long(tmp_path: Path) -> None:
    one = real("logs", "leg_tracker", "positive_1_extracted.bag")
    two = real("logs", "leg_tracker", "positive_2_extracted.bag")
    (start1, end1), (start2, end2) = _times(one), _times(two)
    shared_s = (min(end1, end2) - max(start1, start2)) / 1e9
    assert 0.05 < shared_s < 59  # under a minute: said in seconds
    report = run_json("build", one, two, "-o", tmp_path / "m.aion", "--map-frame",
                      "right_laser", "--workers", "1", "--format", "json")  # fmt: skip
    (warning,) = [w for w in report["warnings"] if "count twice" in w]
    assert warning.startswith(f"{one.name} and {two.name} both hold /leg_cluster_positions ")
    assert f"({shared_s:.1f} s), with the same people at the same times and places: the " \
        "people both logs saw count twice" in warning
    assert "h)" not in warning


def test_info_warns_as_build_does_of_logs_sharing_their_time(tmp_path: Path) -> None:
    one = real("logs", "leg_tracker", "positive_1_extracted.bag")
    two = real("logs", "leg_tracker", "positive_2_extracted.bag")
    build = run_json("build", one, two, "-o", tmp_path / "m.aion", "--map-frame",
                     "right_laser", "--workers", "1", "--format", "json")  # fmt: skip
    said = [w for w in build["warnings"] if "count twice" in w]
    assert len(said) == 1
    both = run_json("info", one, two, "--format", "json")
    assert [w for w in both["warnings"] if "count twice" in w] == said
    alone = run_json("info", one, "--format", "json")
    assert not [w for w in alone["warnings"] if "count twice" in w]
