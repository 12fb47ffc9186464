"""The UTC times ``aion info LOG --format json`` prints (``start``, ``end``) and the log times
messages name are the nanoseconds cut to the microsecond, never rounded up. They went through
float seconds (``datetime.fromtimestamp(t_ns / 1e9)``), whose steps near 2023 are about
0.24 µs and which rounds: a log ending at 23:59:59.999999999 on the last day of 2023 was said
to end at ``2024-01-01T00:00:00.000000Z``, in the next second, day and year.

The expected texts are worked out by hand: 1_704_067_200 s is 2024-01-01T00:00:00Z
(1_700_000_000 s is 2023-11-14T22:13:20Z; 4_067_200 s = 47 d 1 h 46 min 40 s later)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.time_text import iso_utc, utc_of
from aion_cli.formats.writers import LogWriter, stamp
from tests.cli.conftest import run_json

NEW_YEAR_NS = 1_704_067_200 * 10**9  # 2024-01-01T00:00:00Z


@pytest.mark.parametrize(
    ("t_ns", "text"),
    [
        (NEW_YEAR_NS - 1, "2023-12-31T23:59:59.999999Z"),  # was 2024-01-01T00:00:00.000000Z
        (NEW_YEAR_NS - 500, "2023-12-31T23:59:59.999999Z"),  # was rounded up too
        (NEW_YEAR_NS, "2024-01-01T00:00:00.000000Z"),
        (NEW_YEAR_NS + 999, "2024-01-01T00:00:00.000000Z"),
        (NEW_YEAR_NS + 1_000, "2024-01-01T00:00:00.000001Z"),
        (1_700_000_000_123_456_789, "2023-11-14T22:13:20.123456Z"),  # was .123457
        (0, "1970-01-01T00:00:00.000000Z"),
        (-1, "1969-12-31T23:59:59.999999Z"),  # before 1970: cut to the earlier microsecond
    ],
)
def test_iso_cuts_to_the_microsecond(t_ns: int, text: str) -> None:
    assert iso_utc(t_ns) == text
    assert iso_utc(np.int64(t_ns)) == text  # type: ignore[arg-type]  # as numpy arrays give them


def test_iso_of_a_time_no_datetime_holds_is_the_raw_value() -> None:
    assert iso_utc(10**30) == f"{10**30} ns"
    with pytest.raises(OverflowError):
        utc_of(-(10**30))


def _log(path: Path, container: str, times: list[int]) -> Path:
    with LogWriter(path, container) as w:
        for t in times:
            w.write("/people", "people_msgs/People", {"header": {"stamp": stamp(t)}}, t)
    return path


@pytest.mark.parametrize(("container", "name"), [("mcap", "a.mcap"), ("bag", "a.bag")])
def test_info_json_end_one_ns_before_a_new_year_stays_in_the_old_one(
    container: str, name: str, tmp_path: Path
) -> None:
    first, last = NEW_YEAR_NS - 2 * 10**9, NEW_YEAR_NS - 1
    doc = run_json("info", _log(tmp_path / name, container, [first, last]), "--format", "json")
    assert (doc["start_ns"], doc["end_ns"]) == (first, last)
    assert doc["start"] == "2023-12-31T23:59:58.000000Z"  # an exact second, as it was
    assert doc["end"] == "2023-12-31T23:59:59.999999Z"


def test_info_json_start_and_end_at_exact_seconds_are_unchanged(tmp_path: Path) -> None:
    doc = run_json("info", _log(tmp_path / "a.mcap", "mcap", [NEW_YEAR_NS, NEW_YEAR_NS + 10**9]),
                   "--format", "json")  # fmt: skip
    assert doc["start"] == "2024-01-01T00:00:00.000000Z"
    assert doc["end"] == "2024-01-01T00:00:01.000000Z"


def test_rosbag2_metadata_start_is_named_cut() -> None:
    from aion_cli.formats.rosbag2_storage import MetadataFigures, metadata_disagreements

    said = metadata_disagreements(MetadataFigures(NEW_YEAR_NS - 1, None, None), NEW_YEAR_NS,
                                  NEW_YEAR_NS, 1, {})  # fmt: skip
    assert said == [
        f"starting_time {NEW_YEAR_NS - 1} ns (2023-12-31T23:59:59.999999Z; the files start "
        "at 2024-01-01T00:00:00.000000Z)"
    ]


def test_a_track_time_before_1970_is_named_before_1970() -> None:
    """A row 100 ns before 1970 was named ``1970-01-01 00:00:00`` (float seconds rounded to
    the microsecond, up to 0) in the very error that says it is before 1970."""
    from aion_cli.formats.tracks_log import _check_log_times
    from aion_cli.formats.writers import LogTimeError

    with pytest.raises(LogTimeError, match=r"\(1969-12-31 23:59:59 UTC\)"):
        _check_log_times(np.asarray([-100, 5], dtype=np.int64), "rows")


def test_an_export_series_frame_is_named_by_its_second_cut() -> None:
    """``aion export --from --to --step`` names each time's folder by its UTC second; through
    float seconds a time 1 ns before the new year was named after 2024-01-01 00:00:00."""
    from aion_cli.exports import frame_name

    assert frame_name(NEW_YEAR_NS - 1) == "20231231T235959Z"
    assert frame_name(NEW_YEAR_NS) == "20240101T000000Z"
    assert frame_name(NEW_YEAR_NS + 10**9 - 1) == "20240101T000000Z"
    assert frame_name(None) == "historical"
