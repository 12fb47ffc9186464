"""A tracks file holding rows twice (``cat a.csv a.csv``, a part pasted again, a person id at
two positions at one time): ``aion convert`` writes each person once per time, and says how
many rows it left out, instead of counting every repeated person twice in the map's flows
(and, for the frame layouts, leaving zero time steps where headings are differenced)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.engine.types import DetectionBatch
from aion_cli.formats import tracks_log
from aion_cli.formats.track_types import repeated_rows
from tests.cli.conftest import run


def _detections(log: Path) -> list[tuple[int, float, float, float]]:
    """Every detection of the log: time, x, y and the velocity's heading (9: none)."""
    from aion_cli.formats.detections import adapter_for
    from aion_cli.formats.logs import open_logs

    with open_logs([log]) as logs:
        msgs = list(logs.messages())
        adapter = adapter_for(msgs[0].msgtype)
        assert adapter is not None
        f = adapter.decode(msgs)
    v = f.velocity
    heading = np.where(np.isnan(v[:, 0]), 9.0, np.round(np.arctan2(v[:, 1], v[:, 0]), 6))
    return sorted(zip(f.t_ns.tolist(), f.xyz[:, 0].tolist(), f.xyz[:, 1].tolist(),
                      heading.tolist(), strict=True))


def test_repeated_rows_are_told_by_time_and_track_id() -> None:
    batch = DetectionBatch.from_arrays(
        [5, 5, 5, 6, 5, 5, 5],
        [[0, 0, 0], [1, 0, 0], [0, 0, 0], [0, 0, 0], [2, 0, 0], [3, 0, 0], [0, 0, 0]],
        track_id=[1, 2, 1, 1, 1, -1, -1],
    )
    mask, elsewhere = repeated_rows(batch)
    # row 2 repeats row 0 exactly, row 4 is id 1 at time 5 elsewhere; no id (-1) never repeats
    assert mask.tolist() == [False, False, True, False, True, False, False]
    assert elsewhere == 1


def test_a_frame_layout_file_given_twice_converts_as_once(tmp_path: Path) -> None:
    rows = [f"{10 * f} {p} {0.4 * f + p:.2f} {float(p):.1f}" for f in range(12) for p in (1, 2)]
    once, twice = tmp_path / "once.txt", tmp_path / "twice.txt"
    once.write_text("\n".join(rows) + "\n")
    twice.write_text("\n".join(rows + rows) + "\n")
    logs = []
    for src in (once, twice):
        log = tmp_path / f"{src.stem}.mcap"
        result = run("convert", src, "--layout", "ucy", "--start", "2026-01-05 12:00", "-o", log)
        assert result.exit_code == 0, result.stderr
        logs.append(log)
    assert "24 detections of 2 tracks" in result.stderr  # before: 48, and headings lost
    assert "warning: twice.txt: 24 rows repeat the time and track id of an earlier row (24 the " \
        "same row again, 0 at another position)" in result.stderr
    assert _detections(logs[1]) == _detections(logs[0])
    assert all(h != 9.0 for *_, h in _detections(logs[1]))  # every heading differenced


def test_streamed_rows_repeated_across_chunks_are_left_out(tmp_path: Path) -> None:
    """An ATC file (streamed a few rows at a time) with each row written twice in a row and
    one person at a second position: each person once per time, whatever the chunking."""
    lines = [f"{1351038020 + t},{p},{t * 0.5:.1f},{p:.1f},1.0,0.0" for t in range(9)
             for p in (7, 8)]
    doubled = [line for line in lines for _ in (0, 1)] + ["1351038028,8,5.0,5.0,1.0,0.0"]
    src = tmp_path / "atc.csv"
    src.write_text("\n".join(doubled) + "\n")
    summary = tracks_log.stream_tracks_to_log(src, tmp_path / "a.mcap", "atc", rows=5)
    assert (summary.detections, summary.repeated_rows, summary.repeated_elsewhere) == (18, 19, 1)
    plain = tmp_path / "plain.csv"
    plain.write_text("\n".join(lines) + "\n")
    tracks_log.stream_tracks_to_log(plain, tmp_path / "b.mcap", "atc", rows=5)
    assert _detections(tmp_path / "a.mcap") == _detections(tmp_path / "b.mcap")


def test_positions_far_beyond_the_spatial_hash_are_warned_of(tmp_path: Path) -> None:
    """A UCY file with one position damaged to 1e300 (and one 600 km out): convert wrote
    them without a word and the build then left them out; convert now warns, naming how
    many and an example, and still writes every row as the file has it."""
    rows = [f"{10 * f} {p} {0.4 * f + p:.2f} {float(p):.1f}" for f in range(12) for p in (1, 2)]
    rows[5] = "20 2 1e300 2.0"
    rows[7] = "30 2 600000.0 2.0"
    src, log = tmp_path / "far.txt", tmp_path / "far.mcap"
    src.write_text("\n".join(rows) + "\n")
    result = run("convert", src, "--layout", "ucy", "--start", "2026-01-05 12:00", "-o", log)
    assert result.exit_code == 0, result.stderr
    assert ("warning: far.txt: 2 rows lie more than 524 km from the origin (e.g. 1e+300 m): "
            "damaged values") in " ".join(result.stderr.split())
    assert len(_detections(log)) == 24
    near = tmp_path / "near.txt"
    near.write_text("\n".join(r for k, r in enumerate(rows) if k not in (5, 7)) + "\n")
    quiet = run("convert", near, "--layout", "ucy", "--start", "2026-01-05 12:00", "-o",
                tmp_path / "near.mcap")
    assert "from the origin" not in quiet.stderr


def test_one_row_is_counted_in_the_singular(tmp_path: Path) -> None:
    """One row repeated and one row far out: "1 row repeats ...", "1 row lies ..." (before:
    "1 row repeat the time and track id", "1 row lie more than 524 km")."""
    rows = ["1351038020.0,1,0.0,0.0,1.0,0.0", "1351038021.0,1,1.0,0.0,1.0,0.0",
            "1351038021.0,1,1.0,0.0,1.0,0.0", "1351038022.0,1,1e7,0.0,1.0,0.0"]
    src = tmp_path / "one.csv"
    src.write_text("\n".join(rows) + "\n")
    result = run("convert", src, "--layout", "atc", "-o", tmp_path / "one.mcap")
    assert result.exit_code == 0, result.stderr
    text = " ".join(result.stderr.split())
    assert "one.csv: 1 row repeats the time and track id of an earlier row" in text
    assert "one.csv: 1 row lies more than 524 km from the origin (e.g. 1e+07 m)" in text
