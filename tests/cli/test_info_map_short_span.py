"""``aion info MAP`` of a map of a real half-second leg_tracker bag showed its time span as
"0.5 s: Mon 2015-03-16 03:16 to Mon 2015-03-16 03:16 UTC": two equal ends, to the minute. A
span inside one minute now shows its ends to the second, or to the millisecond where they
first differ there (positive_2_extracted.bag: 0.27 s inside one second), read here from the
bag's own first and last message times (``aion info LOG --format json``); a longer span
stays to the minute."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import pytest

from tests.cli.conftest import run, run_json
from tests.shared_data import real


def _span_row(stderr: str) -> str:
    row = next(line for line in stderr.splitlines() if "time span" in line)
    return " ".join(row.replace("│", " ").split())


@pytest.mark.parametrize(
    ("name", "fmt"),
    [
        ("positive_2_extracted.bag", "%a %Y-%m-%d %H:%M:%S.%f"),  # inside one second
        ("positive_1_extracted.bag", "%a %Y-%m-%d %H:%M:%S"),  # 51.6 s .. 52.1 s
    ],
)
def test_a_span_inside_a_minute_shows_ends_that_differ(
    name: str, fmt: str, tmp_path: Path
) -> None:
    log = real("logs", "leg_tracker", name)
    seen = run_json("info", log, "--format", "json")
    out = tmp_path / "legs.aion"
    run_json("build", log, "--map-frame", "right_laser", "-o", out, "--workers", "1",
             "--format", "json")  # fmt: skip

    def clock(t_ns: int) -> str:
        text = datetime.fromtimestamp(t_ns / 1e9, UTC).strftime(fmt)
        return text[:-3] if fmt.endswith("%f") else text  # to the millisecond

    first, last = clock(seen["start_ns"]), clock(seen["end_ns"])
    assert first != last
    result = run("info", out)
    assert result.exit_code == 0, result.stderr
    assert f"{first} to {last} UTC" in _span_row(result.stdout + result.stderr)


def test_a_longer_span_stays_to_the_minute(tmp_path: Path) -> None:
    log = real("logs", "rosbagjs_fixtures", "example-bz2.bag")  # 21.7 s across a minute
    suggested = run("info", log, "--suggest-mapping", "/turtle1/pose")
    mapping = tmp_path / "turtle.toml"
    mapping.write_text(suggested.stdout)
    out = tmp_path / "t.aion"
    run_json("build", log, "--detections-mapping", mapping, "--map-frame", "world", "-o", out,
             "--workers", "1", "--format", "json")  # fmt: skip
    row = _span_row(run("info", out).stdout)
    assert row.endswith("Mon 2014-03-31 19:24 to Mon 2014-03-31 19:25 UTC"), row
