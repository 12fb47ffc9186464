"""A canonical tracks file whose ``t_ns`` column holds UNIX seconds or milliseconds (ATC's
1351038020 s, 2012-10-24 00:20:20 UTC) put every detection in 1970, converted without a word
("wrote ...: 3 detections ... over 0 s"): now a warning names the unit the numbers fit and
the date they would then be, and nanoseconds stay silent."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import run

HEADER = "t_ns,track_id,x,y,z,heading_rad,speed_mps"


def _convert(tmp_path: Path, times: list[int]) -> str:
    src = tmp_path / "tracks.csv"
    src.write_text("\n".join([HEADER, *(f"{t},1,{k},0,0,0,1" for k, t in enumerate(times))]))
    result = run("convert", src, "-o", tmp_path / "t.mcap", "-q")
    assert result.exit_code == 0, result.stderr
    return result.stderr


@pytest.mark.parametrize(
    ("scale", "unit", "factor"),
    [(1, "seconds", "1e9"), (1000, "milliseconds", "1e6"), (10**6, "microseconds", "1e3")],
)
def test_seconds_or_milliseconds_in_t_ns_are_named(
    tmp_path: Path, scale: int, unit: str, factor: str
) -> None:
    first = 1351038020 * scale
    stderr = _convert(tmp_path, [first, first + scale, first + 2 * scale])
    assert f"warning: tracks.csv: t_ns starts at {first}" in stderr
    assert f"as UNIX {unit} 2012-10-24 00:20:20+00:00" in stderr
    assert f"(multiply it by {factor})" in stderr


def test_nanoseconds_are_silent(tmp_path: Path) -> None:
    first = 1351038020 * 10**9
    assert _convert(tmp_path, [first, first + 10**9]) == ""
