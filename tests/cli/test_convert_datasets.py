"""``aion convert --layout edinburgh | thor-magni | eth | ucy``: real and synthetic dataset files
become logs whose detections are the file's, at the times the options say; every misuse of the
layout-specific options is one ``error:`` line and exit code 2."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats.detections.frame import FrameDetections
from tests.cli.conftest import assert_one_line_error, run, warning_lines
from tests.formats.dataset_files import EDINBURGH, ETH_UCY, edinburgh_file, magni_file

S = 1_000_000_000


def _read(log: Path) -> tuple[list[int], FrameDetections]:
    """Log times of the detection messages and the decoded detections."""
    from aion_cli.formats.detections import adapter_for
    from aion_cli.formats.logs import open_logs

    with open_logs([log]) as logs:
        msgs = list(logs.messages())
        adapter = adapter_for(msgs[0].msgtype)
        assert adapter is not None
        return [m.log_time_ns for m in msgs], adapter.decode(msgs)


def test_edinburgh_date_yesterday_is_yesterdays_midnight(tmp_path: Path) -> None:
    """``--date yesterday`` put frame 0 at this time of day yesterday ("yesterday" alone is now
    minus a day in every other time option); --date names a day, frame 0 at its midnight, as
    ``--date 2010-07-01`` does."""
    import datetime as dt

    path = edinburgh_file(tmp_path / "t.txt", {4: [(10, 20, 0), (12, 20, 5)]})
    out = tmp_path / "t.mcap"
    before = dt.datetime.now(dt.UTC).date()
    result = run("convert", path, "--layout", "edinburgh", "--date", "yesterday", "--tz", "UTC",
                 "--fps", "10", "-o", out)  # fmt: skip
    after = dt.datetime.now(dt.UTC).date()
    assert result.exit_code == 0, result.stderr
    times, _ = _read(out)
    midnights = {
        int(dt.datetime.combine(day - dt.timedelta(days=1), dt.time(), dt.UTC).timestamp()) * S
        for day in (before, after)  # the test may straddle midnight
    }
    assert times[0] in midnights


def test_layout_choices_are_the_readers_layouts() -> None:
    from aion_cli.cli.convert import LAYOUTS
    from aion_cli.formats.track_types import LAYOUTS as READERS

    assert sorted(LAYOUTS) == sorted(READERS)


@pytest.mark.skipif(not EDINBURGH.is_file(), reason="../shared/data/tracks/edinburgh is absent")
def test_edinburgh_day_converts_at_its_date(tmp_path: Path) -> None:
    out = tmp_path / "forum.mcap"
    result = run(
        "convert",
        EDINBURGH,
        "--layout",
        "edinburgh",
        "--date",
        "2010-07-01",
        "--tz",
        "Europe/London",
        "-o",
        out,
    )
    assert result.exit_code == 0, result.stderr
    # the database's 111,230 points, but for 92 that give a person a second position in a
    # frame it already has: each person is written once per time, and a note says so
    assert "111,138 detections of 1,262 tracks" in result.stderr
    assert "92 rows repeat the time and track id of an earlier row (0 the same row again, " \
        "92 at another position)" in result.stderr
    assert warning_lines(result.stderr) == []
    assert "frame 0 taken as 2010-07-01 00:00:00+01:00, frames at 9 fps" in result.stderr
    times, frames = _read(out)
    midnight = 1_277_938_800 * S  # 2010-07-01 00:00 BST
    assert times[0] == midnight + round(95 / 9 * 1e6) * 1000  # the first frame, 95
    assert len(frames) == 111_138


def test_edinburgh_date_with_a_time_and_fps(tmp_path: Path) -> None:
    path = edinburgh_file(tmp_path / "t.txt", {4: [(10, 20, 0), (12, 20, 5)]})
    out = tmp_path / "t.mcap"
    result = run(
        "convert",
        path,
        "--layout",
        "edinburgh",
        "--date",
        "2010-07-01 08:30",
        "--tz",
        "UTC",
        "--fps",
        "10",
        "-o",
        out,
    )
    assert result.exit_code == 0, result.stderr
    times, frames = _read(out)
    t0 = 1_277_973_000 * S  # 2010-07-01 08:30 UTC
    assert times == [t0, t0 + S // 2]
    np.testing.assert_allclose(frames.xyz[:, 0], [10 * 0.0247, 12 * 0.0247])
    assert frames.track_id.tolist() == [4, 4]


def test_thor_magni_converts_helmets_in_metres(tmp_path: Path) -> None:
    path = magni_file(tmp_path / "THOR-Magni_120522_SC1A_R1.csv")
    out = tmp_path / "magni.mcap"
    result = run(
        "convert",
        path,
        "--layout",
        "thor-magni",
        "--start",
        "2022-05-12 10:00",
        "--tz",
        "Europe/Stockholm",
        "-o",
        out,
    )
    assert result.exit_code == 0, result.stderr
    assert "95 detections of 2 tracks" in result.stderr
    assert "not people, skipped: DARKO_Robot" in result.stderr
    assert "positions read as millimetres" in result.stderr
    times, frames = _read(out)
    t0 = 1_652_342_400 * S  # 2022-05-12 10:00 CEST
    assert times[0] == t0
    assert times[-1] == t0 + 490_000_000
    assert sorted(set(frames.track_id.tolist())) == [3, 11]
    assert frames.xyz[:, 0].max() < 6.0  # metres, not mm
    # without --start the times count from 1970, and the user is told
    result = run("convert", path, "--layout", "thor-magni", "-o", tmp_path / "m2.mcap")
    assert result.exit_code == 0, result.stderr
    assert "give --start for when it was recorded" in result.stderr


@pytest.mark.skipif(not ETH_UCY.is_dir(), reason="../shared/data/tracks/eth_ucy is absent")
def test_ucy_and_eth_files_convert(tmp_path: Path) -> None:
    out = tmp_path / "uni.mcap"
    result = run(
        "convert",
        ETH_UCY / "uni_examples.txt",
        "--layout",
        "ucy",
        "--start",
        "1700000000",
        "-o",
        out,
    )
    assert result.exit_code == 0, result.stderr
    assert "2,747 detections of 118 tracks" in result.stderr
    times, _ = _read(out)
    assert set(np.diff(times).tolist()) <= {400_000_000 * k for k in range(1, 40)}
    out = tmp_path / "eth.mcap"
    result = run(
        "convert",
        ETH_UCY / "biwi_eth.txt",
        "--layout",
        "eth",
        "--fps",
        "15",
        "-o",
        out,
        "--start",
        "1700000000",
    )
    assert result.exit_code == 0, result.stderr
    assert "5,492 detections of 360 tracks" in result.stderr
    times, _ = _read(out)
    assert times[0] == 1_700_000_000 * S + round(780 / 15 * 1e9)


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--layout", "edinburgh"], "needs --date"),
        (["--layout", "edinburgh", "--date", "2010-07-01", "--start", "0"], "give --date"),
        (["--layout", "thor", "--date", "2010-07-01"], "--date applies to the edinburgh"),
        (["--layout", "atc", "--fps", "10"], "--fps does not apply to the atc"),
        (["--start", "2026-01-05 12:00"], "--start does not apply to the canonical layout"),
        (["--layout", "lincoln", "--start", "0"], "--start does not apply to the lincoln"),
        (["--layout", "atc", "--start", "0"], "--start does not apply to the atc"),
        (["--container", "bag"], "--container bag does not match the output name 'x.mcap'"),
        (["--container", "rosbag2-mcap"], "--container rosbag2-mcap does not match"),
        (["--layout", "eth", "--fps", "0"], "--fps must be above 0 and at most 10,000"),
        (["--layout", "eth", "--fps", "nan"], "--fps must be above 0 and at most 10,000"),
        (["--layout", "eth", "--fps", "inf"], "--fps must be above 0 and at most 10,000"),
        (["--layout", "eth", "--fps", "1e300"], "--fps must be above 0 and at most 10,000"),
        (["--layout", "ucy", "--length-unit", "mm"], "--length-unit does not apply"),
        (["--layout", "edinburgh", "--date", "someday"], "--date 'someday': cannot read the time"),
        (["--layout", "ucy", "--start", "someday"], "--start 'someday': cannot read the time"),
        (["--layout", "thor-magni"], "THÖR-MAGNI header"),
        (["--layout", "edinburgh", "--date", "2010-07-01"], "no TRACK.Rn"),
    ],
)
def test_bad_options_and_files(args: list[str], fragment: str, tmp_path: Path) -> None:
    path = tmp_path / "data.txt"
    path.write_text("1 2 3 4\n")
    out = tmp_path / "x.mcap"
    result = run("convert", path, "-o", out, *args)
    assert result.exit_code == 2, result.stderr
    assert_one_line_error(result.stderr, fragment)
    assert not out.exists()


def test_people_walking_too_fast_for_the_frame_rate_are_warned(tmp_path: Path) -> None:
    """Two people stepping 1 m every 10 frames: 2.5 m/s at the default 25 fps (warned, with
    the rate at which they would walk 1.3 m/s: 13 fps); 1 m/s at --fps 10 (no warning)."""
    rows = [f"{10 * k} {pid} {float(k)} {float(pid)}" for k in range(20) for pid in (1, 2)]
    path = tmp_path / "fast.txt"
    path.write_text("\n".join(rows) + "\n")
    fast = run("convert", path, "--layout", "eth", "--start", "2026-01-05 12:00", "--tz", "UTC",
               "-o", tmp_path / "a.mcap")
    assert fast.exit_code == 0, fast.stderr
    shown = " ".join(fast.stderr.split())
    assert "people walk 2.50 m/s (median) at 25 frames per second" in shown
    assert "at 13 fps they would walk 1.3 m/s" in shown
    slow = run("convert", path, "--layout", "eth", "--fps", "10", "--start", "2026-01-05 12:00",
               "--tz", "UTC", "-o", tmp_path / "b.mcap")
    assert slow.exit_code == 0, slow.stderr
    assert "m/s (median)" not in slow.stderr


def test_one_damaged_position_leaves_the_frame_rate_advice_sane(tmp_path: Path) -> None:
    """The first 400 rows of ETH's biwi_eth.txt (annotated at 15 fps: README) with one x set
    to 1e300: convert printed numpy's "RuntimeWarning: overflow encountered in multiply" and
    "people walk 94936708860759498802569892550833317004979463608953060606257926478513134763164
    ... m/s on average" with 1e-300 fps as the advice. The speeds' median keeps it sane."""
    from tests.shared_data import real

    rows = [r.split() for r in real("tracks", "eth_ucy", "biwi_eth.txt").read_text().splitlines()]
    rows = rows[:400]
    rows[5][2] = "1e300"
    path = tmp_path / "damaged.txt"
    path.write_text("\n".join("\t".join(r) for r in rows) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # numpy's overflow warning fails
        result = run("convert", path, "--layout", "eth", "--start", "2026-01-05 12:00",
                     "--tz", "UTC", "-o", tmp_path / "d.mcap")
    assert result.exit_code == 0, result.stderr
    shown = " ".join(result.stderr.split())
    speed = float(shown.split("people walk ")[1].split(" m/s (median)")[0])
    fps = float(shown.split("(at ")[1].split(" fps they would walk")[0])
    assert 1.5 < speed < 3.5  # 15 fps annotations read at 25: about 25 / 15 times 1.3 m/s
    assert 10 < fps < 20
