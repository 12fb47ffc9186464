"""Two ATC-layout sessions a day apart, converted and built by the tests of ``aion convert
--observed`` and ``--graph``: the rows, the conversion and the map's observed windows."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from tests.cli.conftest import run

SPAN = "2026-11-23 08:00..2026-11-23 12:02"


def write_two_sessions(path: Path) -> Path:
    """ATC rows (time s, id, x m, y m, speed, angle) into ``path``: 08:00-08:20 on 2026-11-23
    and -24, one person a minute walking for 30 s from 5 s past it; the last row at
    08:19:34."""
    rows, person = [], 1
    for day in (23, 24):
        t0 = datetime(2026, 11, day, 8, 0, tzinfo=UTC).timestamp()
        for minute in range(20):
            start = t0 + minute * 60 + 5
            rows += [f"{start + i:.3f},{person},{-10 + i * 0.5:.3f},1.000,0.5,0.0"
                     for i in range(30)]
            person += 1
    path.write_text("\n".join(rows) + "\n")
    return path


def convert_atc(tracks: Path, log: Path, *args: str) -> None:
    """``aion convert TRACKS --layout atc -o LOG ARGS...``, which must succeed."""
    result = run("convert", tracks, "--layout", "atc", "-o", log, "-q", *args)
    assert result.exit_code == 0, result.stderr


def observed_windows(path: Path) -> np.ndarray:
    """The windows observed per live entry of the map at ``path``, the open one included."""
    from aion_cli.mapquery import load_map

    state = load_map(path).state
    out: np.ndarray = state.windows_observed(state.entries.live_rows(), True)
    return out
