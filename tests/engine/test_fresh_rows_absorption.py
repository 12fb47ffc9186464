"""Absorbing counts into rows never written writes them without reading them first
(``absorption._add_at``), and a state read from a map knows which rows the map stored
(``TemporalState.high_water`` past the last one): the first query of a big map whose counts
are all pending faults each page it writes once, not twice. The counts absorbed are what the
code it replaced absorbed, to the bit (verbatim copy below)."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import aion_cli as aion
from aion_cli.engine.config import ModelConfig
from aion_cli.engine.grouping import unique_inverse
from aion_cli.engine.temporal import absorption
from aion_cli.engine.temporal.absorption import _profile_for, _sum_phasors
from aion_cli.engine.temporal.accumulators import TemporalState
from aion_cli.engine.temporal.params import TemporalParams
from aion_cli.engine.types import F64, I64
from tests.engine.test_lazy_zeros import _big_map_repro

PARAMS = TemporalParams.from_config(ModelConfig())


def _absorb_counts_before(
    params: TemporalParams,
    state: TemporalState,
    cnt_entry: I64,
    cnt_slot: I64,
    cnt_values: F64,
    h: I64,
    phasor: absorption.C128,
) -> None:
    """``absorption._absorb_counts`` before rows never written were written unread (verbatim)."""
    n_prof = params.n_profile
    pair, value = np.nonzero(cnt_values)
    counts = cnt_values[pair, value]
    rows = cnt_entry[pair]
    slots = cnt_slot[pair]
    if state.fourier_loaded:
        flat_fourier = state.cnt_fourier.reshape(-1, state.n_periods)
        targets, which = unique_inverse(rows * params.values + value)
        flat_fourier[targets] += _sum_phasors(which, slots, counts, targets.size, phasor)
    keys, inverse = unique_inverse((rows * params.values + value) * n_prof + h[slots])
    added: F64 = np.bincount(inverse, counts, minlength=keys.size).astype(np.float64)
    flat_profile = _profile_for(state, keys, added)
    flat_profile[keys] += added.astype(flat_profile.dtype, copy=False)
    state.touch(rows)


def _state(
    rng: np.random.Generator, rows: int, written: int, fourier: bool, narrow: bool
) -> TemporalState:
    """R rows, the first ``written`` holding counts (some −0 sums among them), the rest zeros."""
    k, v, h = PARAMS.n_periods, PARAMS.values, PARAMS.n_profile
    state = TemporalState.empty(rows, v, k if fourier else 0, h, 2, 2)
    state.fourier_loaded = fourier
    if fourier:
        sums = rng.normal(size=(written, v, k)) + 1j * rng.normal(size=(written, v, k))
        sums[rng.random(sums.shape) < 0.3] = -0.0
        state.cnt_fourier[:written] = sums
    if narrow:
        state.cnt_profile = np.zeros((rows, v, h), np.uint8)
        state.cnt_profile[:written] = rng.integers(0, 250, (written, v, h))
    else:
        state.cnt_profile[:written] = rng.integers(0, 5, (written, v, h))
    state.high_water = written
    return state


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    rows=st.integers(1, 40),
    written_share=st.floats(0.0, 1.0),
    pairs=st.integers(0, 300),
    density=st.sampled_from([0.02, 0.3, 1.0]),
    whole=st.booleans(),
    fourier=st.booleans(),
    narrow=st.booleans(),
)
def test_counts_absorbed_as_before(
    seed: int,
    rows: int,
    written_share: float,
    pairs: int,
    density: float,
    whole: bool,
    fourier: bool,
    narrow: bool,
) -> None:
    """Random states (rows written below the high-water mark, zeros above) and random sparse
    and dense counts, whole or not, with and without Fourier sums, float or narrow profiles:
    every accumulator the same to the bit as the code this replaced, and the same mark."""
    rng = np.random.default_rng(seed)
    written = round(written_share * rows)
    new = _state(rng, rows, written, fourier, narrow and not fourier)
    old = new.copy()
    old.high_water, old.fourier_loaded = new.high_water, new.fourier_loaded
    slots = 7
    entry = rng.integers(0, rows, pairs)
    slot = rng.integers(0, slots, pairs)
    values = rng.random((pairs, PARAMS.values))
    values = np.where(rng.random(values.shape) < density, values * 4, 0.0)
    if whole:
        values = np.ceil(values)
    h = rng.integers(0, PARAMS.n_profile, slots)
    t_s = rng.uniform(0, 1e6, slots)
    phasor = np.exp(1j * np.multiply.outer(t_s, PARAMS.omega))
    absorption._absorb_counts(PARAMS, new, entry, slot, values, h, phasor)
    _absorb_counts_before(PARAMS, old, entry, slot, values, h, phasor)
    assert new.high_water == old.high_water
    for name in ("cnt_fourier", "cnt_profile"):
        a, b = getattr(new, name), getattr(old, name)
        assert a.dtype == b.dtype
        assert a.tobytes() == b.tobytes()


def test_a_read_map_knows_the_rows_it_stored(tmp_path: Path) -> None:
    """A map whose counts are all pending (the report's big.py at 5k entries) stores no
    accumulator row: its state's rows are all unwritten (it pickles without them); its first
    query writes them up to the last entry with a count."""
    path = _big_map_repro(5_000, 400.0, tmp_path / "big.aion")
    loaded = aion.Map.load(path)
    state = loaded._loaded.state
    temporal = state.temporal
    assert temporal.n_rows > 4_000
    assert temporal.high_water == 0
    assert len(pickle.dumps(temporal)) < 100_000  # the rows: 5k x (9 x 31 complex + ...)
    loaded.predict("2026-01-05 10:30", tz="UTC", top=1)
    view = state.query_temporal()
    assert view.high_water == int(view.cnt_profile.sum(axis=(1, 2)).nonzero()[0].max()) + 1
