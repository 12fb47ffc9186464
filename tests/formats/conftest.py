"""Shared by the tests of the .aion map container (``test_mapfile.py``: writing,
``test_mapfile_damaged.py``: damaged and hostile maps): the sample arrays (every dtype and
shape a map holds), the ``written`` map of them, and an array-by-array comparison; and by the
tests of logs compressed whole, ``temp_root``: where their decompressed copies go."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats.mapfile import write_map


def sample_arrays() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    return {
        "f64": rng.normal(size=(5, 3)),
        "c128": rng.normal(size=(4, 2)) + 1j * rng.normal(size=(4, 2)),
        "u64": np.array([0, 1, 2**64 - 1, 2**63], dtype=np.uint64),
        "i8": np.array([-128, 0, 127], dtype=np.int8),
        "flags": np.array([True, False, True]),
        "empty": np.zeros(0, dtype=np.float64),
        "empty2d": np.zeros((0, 8), dtype=np.int64),
        "cube": np.arange(24, dtype=np.int32).reshape(2, 3, 4),
        "fortran": np.asfortranarray(np.arange(12.0).reshape(3, 4)),
        "fremen/sum_se": np.ones((2, 3), dtype=np.complex128),
        "scalar": np.array(3.5),
        "labels": np.array(["kitchen", "hall"]),
    }


def assert_same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert set(a) == set(b)
    for name in a:
        assert b[name].dtype == a[name].dtype, name
        assert b[name].shape == a[name].shape, name
        np.testing.assert_array_equal(b[name], a[name])


@pytest.fixture
def written(tmp_path: Path) -> Path:
    path = tmp_path / "office.aion"
    write_map(path, sample_arrays(), {"config": {"bins": 8}, "counts": {"entries": 5}})
    return path


@pytest.fixture
def temp_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Where the decompressed copies go (tempfile's folder), to see them come and go."""
    root = tmp_path / "tmp"
    root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(root))
    return root
