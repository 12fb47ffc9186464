"""``observed`` spans in the Python API given in the forms a script holds them in: a list of
pairs, a generator of pairs (read once), one pair, and numpy arrays of shape ``(n, 2)`` or
``(2,)`` (``datetime64``, text, nanoseconds). Each builds the map the list of pairs builds;
before, a generator or an array was refused as "must be (start, end) pairs, got array(...)".
Arrays of another shape stay refused, naming the argument."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.errors import InputError
from tests.cli.conftest import run
from tests.cli.logdata import T0

#: the log's two minutes of one walker, 2026-11-23 08:00-08:01 and 09:00-09:01 UTC (T0 is
#: 08:00 that day); the spans watched: 07:50-08:20 and 08:50-09:10 (3 + 2 ten-minute windows)
SPANS = [("2026-11-23 07:50", "2026-11-23 08:20"), ("2026-11-23 08:50", "2026-11-23 09:10")]


def _log(tmp_path: Path) -> Path:
    log = tmp_path / "t.mcap"
    if log.exists():
        return log
    rows = ["t_ns,track_id,x,y,z,heading_rad,speed_mps"]
    rows += [f"{T0 + hour * 3600 * 10**9 + k * 10**9},{hour + 1},{0.1 * k:.1f},0,0,0,1"
             for hour in (0, 1) for k in range(60)]  # fmt: skip
    (tmp_path / "t.csv").write_text("\n".join(rows) + "\n")
    assert run("convert", tmp_path / "t.csv", "-o", log).exit_code == 0
    return log


def _observation(tmp_path: Path, name: str, observed: object) -> str:
    made = aion.build(_log(tmp_path), tmp_path / f"{name}.aion", observed=observed, tz="UTC")
    return made.manifest.observation


def test_spans_as_a_generator_or_an_array_build_what_the_list_builds(tmp_path: Path) -> None:
    assert T0 == 1_795_420_800 * 10**9  # 2026-11-23 08:00 UTC: the SPANS above are of this log
    listed = _observation(tmp_path, "list", SPANS)
    assert listed.startswith("fixed sensor over the 5 windows")  # 07:50-08:20: 3, 08:50-09:10: 2
    forms = {
        "generator": (pair for pair in SPANS),
        "text": np.array(SPANS),
        "datetime64": np.array(SPANS, dtype="datetime64[ns]"),
        "nanoseconds": np.array(SPANS, dtype="datetime64[ns]").astype(np.int64),
    }
    for name, observed in forms.items():
        assert _observation(tmp_path, name, observed) == listed, name
    one = _observation(tmp_path, "one", SPANS[0])
    assert _observation(tmp_path, "one-array", np.array(SPANS[0], dtype="datetime64[s]")) == one
    assert one != listed


@pytest.mark.parametrize("shape", [(2, 3), (3,), (2, 2, 2)])
def test_arrays_of_another_shape_are_refused(tmp_path: Path, shape: tuple[int, ...]) -> None:
    bad = np.full(shape, np.datetime64("2026-11-23T08:00", "ns"))
    shapes = r"observed as an array must be of shape \(2,\) or \(n, 2\)"
    with pytest.raises(InputError, match=shapes):
        aion.build(_log(tmp_path), tmp_path / "bad.aion", observed=bad, tz="UTC")
