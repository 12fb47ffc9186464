"""The temporal accumulators' zeros take memory only in the small pages written
(:mod:`aion_cli.engine.zeros`): the first query of a big sparse map, which scatters the
pending day's counts over every row, no longer waits seconds for the kernel to find a 2 MB
huge page behind each write — and its forecasts are the same to the bit."""

from __future__ import annotations

import pickle
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import aion_cli as aion
from aion_cli.engine import zeros as zeros_module
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.engine.temporal import accumulator_files, accumulators, observation_block
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.types import DetectionBatch
from aion_cli.engine.zeros import lazy_zeros

_T0 = 1_767_607_200 * 10**9  # 2026-01-05 10:00 UTC
_THP = Path("/sys/kernel/mm/transparent_hugepage/enabled")


@pytest.mark.parametrize(
    ("shape", "dtype"),
    [(0, np.float64), ((3, 4), np.uint8), ((4000, 9, 31), np.complex128), ((70_000, 9), float)],
)
def test_lazy_zeros_are_zeros(shape: Any, dtype: Any) -> None:
    """What ``np.zeros`` gives (shape, type, values, writable, contiguous), also pickled."""
    got, want = lazy_zeros(shape, dtype), np.zeros(shape, dtype)
    assert got.shape == want.shape
    assert got.dtype == want.dtype
    assert np.array_equal(got, want)
    assert got.flags.writeable
    assert got.flags.c_contiguous
    if got.size:
        got.reshape(-1)[-1] = 1
        assert got.reshape(-1)[-1] == 1
        assert not got.reshape(-1)[:-1].any()
    assert np.array_equal(pickle.loads(pickle.dumps(got)), got)


def _mappings_of(array: np.ndarray) -> dict[str, int]:
    """The /proc/self/smaps kB fields summed over the maps ``array`` lies in (a kernel may
    split one allocation into several, e.g. around the part advised to take huge pages),
    ``THPeligible`` the largest."""
    start = array.ctypes.data
    end = start + array.nbytes
    fields: dict[str, int] = {}
    inside = False
    for line in Path("/proc/self/smaps").read_text().splitlines():
        head = re.match(r"^([0-9a-f]+)-([0-9a-f]+) ", line)
        if head:
            inside = int(head[1], 16) < end and start < int(head[2], 16)
        elif inside:
            name, _, value = line.partition(":")
            parts = value.split()
            if parts and parts[0].isdigit():
                old = fields.get(name, 0)
                number = int(parts[0])
                fields[name] = max(old, number) if name == "THPeligible" else old + number
    return fields


def test_accumulators_back_only_the_pages_written() -> None:
    """A write to one row of a state of 20k entries backs that row's small page, not the
    2 MB huge page around it (numpy's ``np.zeros`` asks for huge pages: eligible before)."""
    if not Path("/proc/self/smaps").exists() or not _THP.exists():
        pytest.skip("needs Linux /proc/self/smaps and transparent huge pages")
    if "[never]" in _THP.read_text():
        pytest.skip("transparent huge pages are off: every page is small anyway")
    state = TemporalState.empty(20_000, 9, 31, 48, 3, 3)  # cnt_fourier: 89 MB of zeros
    state.cnt_fourier[10_000, 4] = 1.0 + 2.0j
    state.cnt_profile[10_000, 4, 7] = 3.0
    for array in (state.cnt_fourier, state.cnt_profile):
        mapping = _mappings_of(array)
        assert mapping, "the array's mapping is in smaps"
        assert mapping.get("THPeligible", 0) == 0
        assert mapping["AnonHugePages"] == 0
        # kB: the pages written (a row may straddle two; the kernel may join the arrays'
        # neighbouring maps into one, so both writes can count here)
        assert mapping["Rss"] <= 16
    assert state.cnt_fourier[10_000, 4, 0] == 1.0 + 2.0j
    assert state.cnt_fourier.sum() == 31 + 62j


def _big_map_repro(n: int, side: float, path: Path) -> Path:
    """``big.py`` of the report at a smaller size: one hour of a fixed sensor's detections
    spread thinly over ``side`` x ``side`` m, the day left open (every count pending)."""
    m = Mapper(ModelConfig())
    rng = np.random.default_rng(0)
    t = _T0 + np.sort(rng.integers(0, 3600 * 10**9, n))
    m.set_fixed_sensor(int(t[0]), int(t[-1]))
    xyz = np.c_[rng.uniform(0, side, n), rng.uniform(0, side, n), np.zeros(n)]
    m.add_detections(DetectionBatch.from_arrays(t, xyz, rng.uniform(-3, 3, n), np.ones(n)))
    return aion.Map.from_state(m.state, timezone="UTC").save(path)


def _plain_zeros(shape: Any, dtype: Any = np.float64) -> Any:
    return np.zeros(shape, dtype)


def _first_query(path: Path) -> tuple[list[str], TemporalState]:
    """Every entry's forecast (each row's repr: floats to the bit, NaN equal to NaN) and the
    accumulators the query read."""
    loaded = aion.Map.load(path)
    table = loaded.predict("2026-01-05 10:30", tz="UTC")
    return [repr(row) for row in table], loaded._loaded.state.query_temporal()


def test_first_query_of_sparse_map_is_unchanged(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The repro's map at 5k entries: its first query (the pending day absorbed in place)
    gives the same accumulators and forecasts, to the bit, as with ``np.zeros`` arrays."""
    path = _big_map_repro(5_000, 400.0, tmp_path / "big.aion")
    rows, view = _first_query(path)
    for module in (accumulators, observation_block, accumulator_files, zeros_module):
        monkeypatch.setattr(module, "lazy_zeros", _plain_zeros)
    want_rows, want_view = _first_query(path)
    assert len(rows) == len(want_rows) > 4_000
    assert rows == want_rows
    for name in ("cnt_fourier", "cnt_profile", "flow_score", "dir_score"):
        assert np.array_equal(getattr(view, name), getattr(want_view, name))
    assert np.array_equal(view.obs.fourier, want_view.obs.fourier)
    assert np.array_equal(view.glob.profile, want_view.glob.profile)
