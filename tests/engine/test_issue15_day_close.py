"""Issue 15, a day close's sums at fewer numpy passes: each gives exactly what the code it
replaced gave (verbatim copies below), bit for bit.

* ``direction_prior.log_gamma`` with the shift's product and logarithm over the arguments
  below 8 alone and the series in place, against the whole-array version.
* ``pooling.count_sums`` of float counts by einsum, against numpy's sum on every axis.
* ``fremen_parts.value_sums`` (einsum over the value bins) against ``sum(axis=1)``, on
  Fourier sums built as the absorption builds them.
* ``slot_sums.sum_slots_in_order`` against slot-by-slot running sums.
* ``absorption._sum_phasors_in_numpy`` against the sparse product it stands in for (a day of
  few pairs), and a build of the sample log, whose days are all such days, in a fresh
  interpreter: it does not import ``scipy.sparse``.

``FixedSlots`` in its (order × slot × entry) layout and ``scoring._observed_sum`` over one
(bin × entry) array are compared with the code before them in ``test_issue15_day_paths``;
the maps built before and after are byte-identical (docs/BENCHMARKS.md).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine.temporal import absorption
from aion_cli.engine.temporal.direction_prior import _STIRLING, log_gamma
from aion_cli.engine.temporal.fremen_parts import value_sums
from aion_cli.engine.temporal.pooling import count_sums
from aion_cli.engine.temporal.slot_sums import sum_slots_in_order
from aion_cli.engine.types import F64


def _log_gamma_whole_array(x: F64) -> F64:
    """``direction_prior.log_gamma`` before this change (verbatim but for the name)."""
    x = np.asarray(x, dtype=np.float64)
    small = x < 8.0
    y = np.where(small, x + 8.0, x)
    product = x.copy()
    for k in range(1, 8):
        product *= x + k
    inverse = 1.0 / y
    square = inverse * inverse
    series = np.zeros_like(y)
    for coefficient in reversed(_STIRLING):
        series = series * square + coefficient
    stirling = (y - 0.5) * np.log(y) - y + 0.5 * np.log(2.0 * np.pi) + series * inverse
    out: F64 = np.where(small, stirling - np.log(np.where(small, product, 1.0)), stirling)
    return out


@given(seed=st.integers(0, 2**31 - 1), size=st.integers(0, 3000))
@settings(max_examples=80, deadline=None)
def test_log_gamma_equals_the_whole_array_version(seed: int, size: int) -> None:
    """Arguments from 1e-13 to 1e6 (a likelihood's κ·share, counts + κ·share, totals + κ),
    some exactly 8 and just below it, all small or none."""
    rng = np.random.default_rng(seed)
    x = np.exp(rng.uniform(-30.0, 14.0, size))
    x[rng.random(size) < 0.05] = 8.0
    x[rng.random(size) < 0.05] = np.nextafter(8.0, 0.0)
    whole = rng.random(size) < 0.1
    x[whole] = rng.integers(1, 50, int(whole.sum()))
    for values in (x, np.minimum(x, 7.5), np.maximum(x, 8.0)):
        assert log_gamma(values).tobytes() == _log_gamma_whole_array(values).tobytes()


def test_log_gamma_of_a_scalar_and_of_a_grid() -> None:
    """0-d and 2-D arguments keep their shapes and values."""
    for x in (np.array(0.3), np.array(12.5), np.array([[0.5, 9.0], [3.0, 1e5]])):
        got, want = log_gamma(x), _log_gamma_whole_array(x)
        assert got.shape == want.shape
        assert got.tobytes() == want.tobytes()


@pytest.mark.parametrize("axis", [0, 1, 2])
@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=40, deadline=None)
def test_count_sums_of_float_counts_equal_numpys_sums(axis: int, seed: int) -> None:
    """Whole counts held as float64 (a build's), mostly zeros, up to millions per bin, on
    blocks of rows as the pooling reads them (views and copies)."""
    rng = np.random.default_rng(seed)
    e, v, h = (int(n) for n in rng.integers(1, 60, 3))
    counts = rng.integers(0, 3_000_000, (e, v, h)).astype(np.float64)
    counts *= rng.random((e, v, h)) < rng.uniform(0.0, 1.0)
    rows = np.sort(rng.choice(e, int(rng.integers(1, e + 1)), replace=False))
    for block in (counts, counts[rows], counts[rows[0] : rows[-1] + 1]):
        got = count_sums(block, axis)
        assert got.dtype == np.float64
        assert got.tobytes() == block.sum(axis=axis).tobytes()


def test_count_sums_of_narrow_counts_stay_integer_sums() -> None:
    """A query's counts read narrow are summed in a wide integer accumulator, as before."""
    counts = np.full((3, 4, 5), 200, np.uint8)
    got = count_sums(counts, 2)
    assert got.dtype == np.uint32
    assert np.array_equal(got, np.full((3, 4), 1000))


@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=60, deadline=None)
def test_value_sums_equal_numpys_sum_over_the_value_bins(seed: int) -> None:
    """Σ count·e^{iωt} per (entry, value bin, period), as the absorption adds them, with
    entries and value bins never counted (zeros), one to 31 periods, one to 12 value bins."""
    rng = np.random.default_rng(seed)
    e, v, k = int(rng.integers(1, 40)), int(rng.integers(1, 13)), int(rng.integers(1, 32))
    t = rng.uniform(0.0, 40 * 86_400.0, 200)
    omega = 2 * np.pi / rng.uniform(3_600.0, 7 * 86_400.0, k)
    phasor = np.exp(1j * np.multiply.outer(t, omega))
    counts = rng.integers(0, 4, (e, v, t.size)) * (rng.random((e, v, 1)) < 0.6)
    sums = np.einsum("evt,tk->evk", counts.astype(np.float64), phasor)
    got = value_sums(sums)
    assert got.tobytes() == sums.sum(axis=1).tobytes()
    rows = np.flatnonzero(rng.random(e) < 0.5)
    assert value_sums(sums[rows]).tobytes() == sums[rows].sum(axis=1).tobytes()


@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=60, deadline=None)
def test_slot_sums_add_the_slots_one_after_the_other(seed: int) -> None:
    """One to four orders, one to 150 slots, one entry or many: the running sum from the
    first slot, value by value."""
    rng = np.random.default_rng(seed)
    m, s, n = int(rng.integers(1, 5)), int(rng.integers(1, 151)), int(rng.integers(1, 40))
    values = rng.exponential(1.0, (m, s, n)) * 10.0 ** rng.integers(-8, 8, (m, s, n))
    if seed % 2:
        values = values[:, :, :1].copy()
    want = values[:, 0, :].copy()
    for j in range(1, values.shape[1]):
        want = want + values[:, j, :]
    got = sum_slots_in_order(values)
    assert got.shape == want.shape
    assert got.tobytes() == want.tobytes()


@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=150, deadline=None)
def test_phasor_sums_in_numpy_equal_the_sparse_product(seed: int) -> None:
    """Rows with one pair or dozens, pairs in any order, whole counts or exposures as
    weights, one to 31 periods; pairs that repeat a (row, slot) (then the sparse product
    itself) in a third of the cases."""
    rng = np.random.default_rng(seed)
    n_rows, slots, k = int(rng.integers(1, 80)), int(rng.integers(1, 150)), int(rng.integers(1, 32))
    n = int(rng.integers(0, 500))
    row, slot = rng.integers(0, n_rows, n), rng.integers(0, slots, n)
    if seed % 3:  # distinct (row, slot) pairs, shuffled
        key = np.unique(row * slots + slot)
        rng.shuffle(key)
        row, slot = key // slots, key % slots
    whole = rng.integers(1, 6, row.size).astype(np.float64)
    weight = whole if seed % 2 else rng.uniform(0.01, 1.0, row.size)
    t = rng.uniform(0.0, 40 * 86_400.0, slots)
    phasor = np.exp(1j * np.multiply.outer(t, 2 * np.pi / rng.uniform(3_600.0, 7 * 86_400.0, k)))
    got = absorption._sum_phasors_in_numpy(row, slot, weight, n_rows, phasor)
    want = absorption._sum_phasors_sparse(row, slot, weight, n_rows, phasor)
    assert got.shape == want.shape
    assert got.tobytes() == want.tobytes()


def test_a_build_of_days_of_few_pairs_does_not_import_scipy_sparse(tmp_path: Path) -> None:
    """The sample log (a patrolling robot, five days of a few hundred pairs each) built in a
    fresh interpreter: every day's phasors summed in numpy, ``scipy.sparse`` never imported
    (0.1–0.2 s of CPU saved per process)."""
    sample = Path(__file__).resolve().parents[2] / "samples" / "office.mcap"
    code = (
        "import sys\n"
        "from aion_cli import api_make\n"
        f"api_make.build({str(sample)!r}, {str(tmp_path / 'office.aion')!r})\n"
        "print('scipy.sparse' in sys.modules)\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=600, check=False
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip().splitlines()[-1] == "False"
    assert (tmp_path / "office.aion").stat().st_size > 0
