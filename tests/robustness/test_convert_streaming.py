"""``aion convert`` streams rows: canonical / ATC / THÖR files are read and written in chunks of
``formats.track_csv.CHUNK_ROWS`` rows, so memory does not grow with the file (it held ~1 KB per
row: a full ATC day needed ~10 GB). The log is byte for byte the one the whole file gives;
a file out of time order falls back to reading it whole. The output path is checked before the
CSV is read, and times before 1970 are refused before a log exists.

Memory is measured with ``tracemalloc``; no test asserts a time.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import aion_cli.formats.tracks as ft
from aion_cli.engine.types import DetectionBatch
from aion_cli.formats import track_csv, track_types, tracks_log
from tests.robustness.conftest import assert_one_error, run

T0 = 1_351_036_800 * 10**9  # 2012-10-24 00:00 UTC
MiB = 1024**2


def tracks_file(path: Path, n: int, seed: int = 1, tick_ns: int = 10**8) -> Path:
    """A canonical CSV of ``n`` time-sorted rows over an hour, many rows per timestamp
    (times on a ``tick_ns`` grid), 5,000 track ids."""
    rng = np.random.default_rng(seed)
    t = T0 + np.sort(rng.integers(0, 3600 * 10**9, n)) // tick_ns * tick_ns
    xyz = np.c_[rng.uniform(-20, 20, (n, 2)), np.zeros(n)]
    batch = DetectionBatch(t, xyz, rng.uniform(-3, 3, n), rng.uniform(0, 2, n),
                           rng.integers(0, 5000, n))
    track_csv.write_canonical_csv(batch, path)
    return path


def traced_peak_mib(args: list[Any]) -> float:
    """Peak traced memory of ``aion ARGS`` in-process (asserting exit 0), in MiB."""
    tracemalloc.start()
    try:
        result = run(*args)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert result.exit_code == 0, result.stderr
    return peak / MiB


def test_convert_memory_is_one_chunk_not_the_whole_file(tmp_path: Path) -> None:
    """200,000 rows take about as much memory as 50,000: one chunk (20,000 rows). Measured:
    24 MiB for both, where the whole-file version peaked at 171 MiB for 200,000 rows (and
    grew by ~0.85 KB per row)."""
    small = tracks_file(tmp_path / "small.csv", 50_000)
    big = tracks_file(tmp_path / "big.csv", 200_000, seed=2)
    peak_small = traced_peak_mib(["convert", small, "-o", tmp_path / "small.mcap"])
    peak_big = traced_peak_mib(["convert", big, "-o", tmp_path / "big.mcap"])
    assert peak_big < 1.3 * peak_small + 2, (peak_small, peak_big)
    assert peak_big < 200_000 * 200 / MiB, peak_big  # < 200 bytes per row of the file
    assert (tmp_path / "big.mcap").stat().st_size > 10 * MiB  # it really wrote them all


@pytest.mark.parametrize("container", ["mcap", "bag"])
@pytest.mark.parametrize("msgtype", [tracks_log.SPENCER_TRACKED, tracks_log.POSE_ARRAY])
def test_a_streamed_log_equals_the_whole_file_log(
    tmp_path: Path, container: str, msgtype: str
) -> None:
    """Chunks of 7 rows (every timestamp's rows split across chunks) give the same bytes as
    one chunk, with observed spans and a scene graph merged in; and the summary counts the
    file's rows, messages and tracks."""
    from tests.cli.logdata import build_graph

    graph = tmp_path / "g.json"
    build_graph().save(str(graph), False)
    csv = tracks_file(tmp_path / "t.csv", 400, tick_ns=20 * 10**9)
    batch = ft.read_tracks(csv)
    spans = [(T0 - 100 * 10**9, T0 + 200 * 10**9), (T0 + 1800 * 10**9, T0 + 1900 * 10**9)]
    opts: dict[str, Any] = {
        "container": container, "msgtype": msgtype, "observed": spans, "graph_file": graph,
    }
    whole = tracks_log.tracks_to_log(batch, tmp_path / f"whole.{container}", **opts)
    streamed = tracks_log.stream_tracks_to_log(csv, tmp_path / f"s.{container}", rows=7, **opts)
    assert (tmp_path / f"s.{container}").read_bytes() == (
        tmp_path / f"whole.{container}"
    ).read_bytes()
    assert streamed.detections == whole.detections == 400
    assert streamed.detection_messages == whole.detection_messages == len(np.unique(batch.t_ns))
    assert streamed.tracks == whole.tracks == len(np.unique(batch.track_id))
    assert streamed.graph_messages == whole.graph_messages > 1
    assert (streamed.start_ns, streamed.end_ns) == (whole.start_ns, whole.end_ns)
    assert streamed.start_ns == spans[0][0]


def test_a_file_out_of_time_order_is_read_whole(tmp_path: Path) -> None:
    """A chunk that starts before the previous one ended: the partial log is thrown away and
    the file is read whole and sorted -- the log of the sorted file."""
    sorted_csv = tracks_file(tmp_path / "sorted.csv", 300)
    lines = sorted_csv.read_text().splitlines()
    shuffled = tmp_path / "shuffled.csv"
    shuffled.write_text("\n".join([lines[0], *lines[151:], *lines[1:151]]) + "\n")
    tracks_log.stream_tracks_to_log(shuffled, tmp_path / "a.mcap", rows=50)
    tracks_log.stream_tracks_to_log(sorted_csv, tmp_path / "b.mcap", rows=50)
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "a.mcap", "b.mcap", "shuffled.csv", "sorted.csv",
    ]


def test_a_bad_line_in_a_later_chunk_names_its_line_and_writes_nothing(tmp_path: Path) -> None:
    csv = tracks_file(tmp_path / "t.csv", 100)
    lines = csv.read_text().splitlines()
    lines[80] = lines[80].replace(",", ",x", 1)
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(track_types.TracksFormatError, match="line 81"):
        tracks_log.stream_tracks_to_log(csv, tmp_path / "out.mcap", rows=10)
    assert not (tmp_path / "out.mcap").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]


@pytest.mark.parametrize("suffix", [".bag", ".mcap", ""])
def test_times_before_1970_are_exit_2_without_a_partial_log(tmp_path: Path, suffix: str) -> None:
    """The .bag case was an internal error (exit 1: struct packing of a negative second)."""
    csv = tmp_path / "neg.csv"
    csv.write_text(f"{track_csv.CANONICAL_HEADER}\n-1000000000,1,0,0,0,0,1\n2000000000,1,1,0,0,0,1\n")
    out = tmp_path / f"neg{suffix}"
    result = run("convert", csv, "-o", out)
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "log time -1000000000 ns", "before 1970")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["neg.csv"]


def test_observed_spans_before_1970_are_exit_2(tmp_path: Path) -> None:
    csv = tracks_file(tmp_path / "t.csv", 10)
    result = run(
        "convert", csv, "-o", tmp_path / "o.bag", "--observed", "1969-12-31..1970-01-02",
        "--tz", "UTC",
    )
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "the observed spans have times before 1970")
    assert not (tmp_path / "o.bag").exists()


def test_atc_times_beyond_int64_nanoseconds_are_a_format_error(tmp_path: Path) -> None:
    """A time in seconds that does not fit int64 nanoseconds used to wrap around silently."""
    csv = tmp_path / "atc.csv"
    csv.write_text("1351038020.0,1,0.5,0.5,1.0,0.0\n1e12,1,0.5,0.5,1.0,0.0\n")
    result = run("convert", csv, "--layout", "atc", "-o", tmp_path / "a.mcap")
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "atc.csv: a time of 1e+12 s", "beyond the range")


def test_the_output_is_checked_before_the_csv_is_read(tmp_path: Path) -> None:
    """An output that may not be replaced is refused first: a broken CSV is not even read
    (its error would name a line), and nothing is written."""
    broken = tmp_path / "broken.csv"
    broken.write_text(f"{track_csv.CANONICAL_HEADER}\n1,2,three,4,5,6,7\n")
    notes = tmp_path / "notes.mcap"
    notes.write_text("my notes")
    result = run("convert", broken, "-o", notes, "--force")
    assert result.exit_code == 2, result.stderr
    assert_one_error(result.stderr, "notes.mcap exists and is another file")
    assert notes.read_text() == "my notes"
    result = run("convert", broken, "-o", notes)
    assert_one_error(result.stderr, "notes.mcap exists already")
    result = run("convert", broken, "-o", tmp_path / "new.mcap")
    assert_one_error(result.stderr, "line 2")  # with a free target the CSV is read
