"""Logs of the same hour on the same topic warn that their people "count twice" only when
they hold the same detections (``aion_cli.log_twins``).

Before: the warning came from the time spans alone, so the ATC train and test splits of one
hour (converted apart; 90/10 split by person, no person in both) were said to hold the same
people. A log repeated in another container, or inside a merged file, still warns."""

from __future__ import annotations

import json
import math
from pathlib import Path

from tests.robustness.conftest import T0, Message, S, build_json, person, run, walk, write_log

MINUTES = 15


def _people(
    tracks: range, seconds: int = MINUTES * 60, late_ns: int = 0, digits: int = 9, ids: int = 0
) -> list[Message]:
    """One message per person and second: person k walks a circle of its own (radius k m);
    ``late_ns`` later, rounded to ``digits`` and its track ids ``ids`` on (another processing
    of the same recording)."""
    out = []
    for s in range(seconds):
        for k in tracks:
            a = 0.01 * s + k
            xy = round(k * math.cos(a), digits), round(k * math.sin(a), digits)
            out.append(person(T0 + s * S + late_ns, (*xy, 0.0), track=k + ids))
    return out


def _twice(report: dict[str, object]) -> list[str]:
    warnings = report["warnings"]
    assert isinstance(warnings, list)
    return [w for w in warnings if "both hold /tracks" in w and "count twice" in w]


def test_a_split_by_person_of_one_hour_does_not_warn(tmp_path: Path) -> None:
    train = write_log(tmp_path / "train.mcap", _people(range(1, 10)))
    test = write_log(tmp_path / "test.mcap", _people(range(10, 12)))
    report = build_json(train, test, "-o", tmp_path / "split.aion", "--workers", "1")
    assert _twice(report) == []
    assert report["detections"]["used"] == 11 * MINUTES * 60  # each person once


def test_a_log_repeated_in_another_container_or_a_merged_file_warns(tmp_path: Path) -> None:
    one = _people(range(1, 4))
    log = write_log(tmp_path / "run.mcap", one)
    bag = write_log(tmp_path / "run.bag", one, "bag")
    report = build_json(log, bag, "-o", tmp_path / "copy.aion", "--workers", "1")
    (warning,) = _twice(report)
    assert warning.startswith("run.mcap and run.bag both hold /tracks from ")
    assert report["detections"]["used"] == 2 * 3 * MINUTES * 60  # what it warns of
    others = _people(range(5, 8))
    merged = write_log(tmp_path / "merged.mcap", sorted(one + others, key=lambda m: m[3]))
    # Lincoln's 2017-05-24_25 and 2017-05-25 files: other stamps, other rounding, other ids
    again = _people(range(1, 4), late_ns=60_000_000, digits=4, ids=100)
    again_log = write_log(tmp_path / "again.mcap", again)
    for pair in ((log, merged), (merged, log), (log, again_log)):
        report = build_json(*pair, "-o", tmp_path / "merged.aion", "--workers", "1")
        assert len(_twice(report)) == 1


def test_logs_sharing_less_than_a_second_give_ends_that_read_apart(tmp_path: Path) -> None:
    """Two logs sharing 0.3 s were said to hold the same people "from 08:00:00 UTC to
    08:00:00 UTC (0.3 s)": both ends cut to the second. Now with the decimals that tell them
    apart; logs sharing minutes keep the times to the second. (A person 1 m further at each
    detection: a copy of one standing in place for 0.3 s is no evidence of a copy.)"""
    short = [person(T0 + k * S // 10, (1.0 * k, 0.0, 0.0)) for k in range(2, 6)]  # 0.2..0.5 s
    pair = write_log(tmp_path / "run.mcap", short), write_log(tmp_path / "run.bag", short, "bag")
    info = run("info", *pair, "--format", "json")
    assert info.exit_code == 0, info.stderr
    (warning,) = _twice(json.loads(info.stdout))
    assert "from 2026-11-23 08:00:00.2 UTC to 2026-11-23 08:00:00.5 UTC (0.3 s)" in warning
    report = build_json(*pair, "-o", tmp_path / "short.aion", "--workers", "1")
    assert _twice(report) == [warning]  # build says as info does
    long = walk(3 * 60 + 1)  # 08:00:00 .. 08:03:00
    pair = write_log(tmp_path / "a.mcap", long), write_log(tmp_path / "a.bag", long, "bag")
    (warning,) = _twice(json.loads(run("info", *pair, "--format", "json").stdout))
    assert "from 2026-11-23 08:00:00 UTC to 2026-11-23 08:03:00 UTC (3m00s)" in warning


def _crossing(start_ns: int, seconds: float, x0: float, speed: float) -> list[Message]:
    """A person walking along x from ``x0`` at ``speed`` m/s, a detection every 10 ms from
    ``start_ns`` for ``seconds``."""
    n = round(seconds * 100)
    return [person(start_ns + k * S // 100, (x0 + speed * k / 100, 0.2, 0.0)) for k in range(n)]


def test_logs_sharing_a_fraction_of_a_second_warn_only_with_evidence(tmp_path: Path) -> None:
    """Two excerpts of one leg-tracker recording, extracted one after the other, share 0.3 s
    of log time (the extraction's) with different people a metre or less apart: within the
    0.5 s tolerance any nearby detection matched, and the build said they "hold the same
    people". Now a stretch shorter than four tolerances is compared at a quarter of its
    length and against chance (one log's times turned round): different people near each
    other do not warn; a copy of the 0.3 s whose person moves 1 m a detection (the test
    above) and a copy of 3 s still do."""
    one = _crossing(T0, 5.0, 0.0, 1.5)  # 08:00:00 .. 08:00:05, at 7.05 m .. 7.5 m from 04.7
    # from 08:00:04.7 (0.3 s shared) another comes the other way, from 7.3 m: they pass;
    # 0.5 s long, so that the 0.3 s shared is over half of it (less is no overlap at all)
    other = _crossing(T0 + 47 * S // 10, 0.5, 7.3, -1.5)
    pair = write_log(tmp_path / "one.mcap", one), write_log(tmp_path / "other.mcap", other)
    report = build_json(*pair, "-o", tmp_path / "apart.aion", "--workers", "1")
    assert _twice(report) == []
    info = json.loads(run("info", *pair, "--format", "json").stdout)
    assert _twice(info) == []
    copy = [m for m in one if m[3] >= T0 + 2 * S]  # one's own last 3 s, copied
    pair = pair[0], write_log(tmp_path / "copy.mcap", copy)
    report = build_json(*pair, "-o", tmp_path / "copy.aion", "--workers", "1")
    (warning,) = _twice(report)
    assert warning.startswith("one.mcap and copy.mcap both hold /tracks ")
