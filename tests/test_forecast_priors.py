"""The pooling's prior strengths a map stores (``forecast_priors``, engine/temporal/pool_priors.py,
engine/view_priors.py): a query with them forecasts exactly as one that estimates them, every
write (build, ``--map`` continuation, merge, a parallel build's join) stores what a query of the
written file would estimate (never a stale copy), and computing them leaves the state as it was."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.temporal import direction_prior
from aion_cli.engine.temporal.pool_priors import MEMBER, PoolPriors
from aion_cli.engine.view_priors import view_priors
from aion_cli.errors import MapCorruptError
from aion_cli.formats.mapfile import read_map
from aion_cli.mapquery import load_map
from tests.cli.conftest import run
from tests.engine.engine_builders import assert_temporal_unchanged
from tests.test_part_maps import _each_built, _logs

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "office.mcap"


def _without_priors(path: Path, out: Path) -> Path:
    """The map without its ``forecast_priors`` member, as a map written before them (and
    before the seal of derived members, which would tell a member removed since)."""
    with zipfile.ZipFile(path) as zin:
        contents = {n: zin.read(n) for n in zin.namelist() if n != MEMBER + ".npy"}
    manifest = json.loads(contents["manifest.json"])
    del manifest["members"][MEMBER]
    manifest.pop("derived", None)
    contents["manifest.json"] = json.dumps(manifest).encode()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_STORED) as zout:
        for name, data in contents.items():
            zout.writestr(name, data)
    return out


def _stored(path: Path) -> PoolPriors:
    priors = PoolPriors.from_arrays(read_map(path)[0])
    assert priors is not None
    return priors


def _estimated(path: Path, tmp_path: Path) -> PoolPriors:
    """What a query of the map estimates without the member (κ, κ_t, κ_G searched again)."""
    state = load_map(_without_priors(path, tmp_path / "bare.aion"), forecast_only=True).state
    rows, predictor = state.predictor()
    pool = predictor.forecaster.pool
    kappa_g = None if pool.shift is None else pool.shift.kappa
    return PoolPriors(pool.kappa, pool.kappa_t, kappa_g, rows.size, len(pool.histogram))


@pytest.fixture(scope="module")
def sample_map(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("sample") / "office.aion"
    assert run("build", SAMPLE, "-o", out, "-q").exit_code == 0
    return out


def test_a_map_forecasts_the_same_with_its_priors_and_without(
    sample_map: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The bundled sample's map (a pending day and an open window, which the stored priors
    must have absorbed as a query does) forecasts every entry to the bit with the member read
    and with it left out; with it, no κ is searched for."""
    meta = read_map(sample_map)[1]["state"]
    assert meta["pending_day"] is not None
    assert meta["open_window"] is not None
    bare = load_map(_without_priors(sample_map, tmp_path / "bare.aion"), forecast_only=True)
    _, expected = bare.state.predictor()
    searched: list[int] = []
    real = direction_prior.fitted_kappa

    def counted(*args: object, **kwargs: object) -> float:
        searched.append(1)
        return real(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(direction_prior, "fitted_kappa", counted)
    monkeypatch.setattr("aion_cli.engine.temporal.group_shift.fitted_kappa", counted)
    _, got = load_map(sample_map, forecast_only=True).state.predictor()
    assert searched == []
    stored = _stored(sample_map)
    assert stored.kappa_g is not None  # the sample's groups keep to the hour: a shift
    pool, fresh = got.forecaster.pool, expected.forecaster.pool
    assert (pool.kappa, pool.kappa_t) == (fresh.kappa, fresh.kappa_t)
    assert pool.shift is not None
    assert fresh.shift is not None
    assert pool.shift.ratio.tobytes() == fresh.shift.ratio.tobytes()
    for t_ns in (1767960000 * 10**9, 1767999600 * 10**9):  # 2026-01-09 12:00 and 23:00 UTC
        a, b = got.at(t_ns), expected.at(t_ns)
        assert a.flow.tobytes() == b.flow.tobytes()
        assert a.probabilities.tobytes() == b.probabilities.tobytes()
        assert a.variance.tobytes() == b.variance.tobytes()


@pytest.mark.parametrize("kind", ["robot", "fixed"])
def test_writing_the_priors_leaves_the_state_as_it_was(sample_map: Path, kind: str) -> None:
    """Absorbing the pending day and the open window in place and putting them back: every
    accumulator, the global block and the map-wide sums hold the same bits afterwards, and
    the state's generation (its cached forecasts' key) and high-water mark are unchanged. The
    bundled sample's map (a robot: its entries' own windows) read to be continued, and the
    benchmark's state in memory (a fixed sensor: the global block; a pending day)."""
    if kind == "robot":
        state = load_map(sample_map, writable=True).state
        assert view_priors(state) == _stored(sample_map)
    else:
        from benchmarks.bench_engine import build_state

        state = build_state(400)
        assert state.pending
        assert state.observation.to_arrays()["obs_fixed_start"].size
    t = state.temporal
    before = t.copy()
    generation, high_water = t.generation, t.high_water
    priors = view_priors(state)
    assert priors.entries == state.entries.canonical_order().size
    assert_temporal_unchanged(before, t.copy())
    assert (t.generation, t.high_water) == (generation, high_water)
    assert t.fourier_loaded


def _doctored(path: Path) -> PoolPriors:
    """Replace the map's stored priors by others that pass every check (κ 7, κ_t 9, no
    shift, its own counts), as a stale copy would be; returns them."""
    from aion_cli.formats.mapfile import RESERVED_KEYS, write_map

    arrays, manifest = read_map(path)
    real = _stored(path)
    bogus = PoolPriors(7.0, 9.0, None, real.entries, real.groups)
    assert bogus != real
    arrays.update(bogus.to_arrays())
    write_map(path, arrays, {k: v for k, v in manifest.items() if k not in RESERVED_KEYS})
    assert _stored(path) == bogus
    return bogus


def test_every_write_stores_what_a_query_of_the_written_map_estimates(
    sample_map: Path, tmp_path: Path
) -> None:
    """A build, its continuation with ``--map``, a parallel build's join and merges each store
    the priors a query of the map they wrote estimates afresh, never the priors of a map they
    read: maps whose stored priors were replaced by others come out with their own again."""
    assert _stored(sample_map) == _estimated(sample_map, tmp_path)
    logs = _logs(tmp_path, [0, 1, 2, 4])
    continued = tmp_path / "continued.aion"
    assert run("build", *logs[:2], "-o", continued, "-q").exit_code == 0
    assert _stored(continued) == _estimated(continued, tmp_path)
    bogus = _doctored(continued)
    assert run("build", *logs[2:], "--map", continued, "-q").exit_code == 0
    assert _stored(continued) == _estimated(continued, tmp_path) != bogus
    whole = tmp_path / "whole.aion"
    assert run("build", *logs, "-o", whole, "--workers", "2", "-q").exit_code == 0
    assert _stored(whole) == _estimated(whole, tmp_path)
    parts = _each_built(tmp_path, logs, "part", "--part")
    assert all(MEMBER not in read_map(p)[0] for p in parts)  # a part forecasts nothing
    merged = tmp_path / "merged.aion"
    assert run("merge", *parts, "-o", merged, "-q").exit_code == 0
    assert _stored(merged) == _estimated(merged, tmp_path)
    sample = tmp_path / "sample.aion"
    sample.write_bytes(sample_map.read_bytes())
    bogus = _doctored(sample)
    again = tmp_path / "again.aion"
    assert run("merge", sample, continued, "-o", again, "-q").exit_code == 0
    assert _stored(again) == _estimated(again, tmp_path) != bogus


def test_priors_of_another_pooling_are_not_used() -> None:
    """Priors estimated over other entries or groups than a query pools are left aside."""
    priors = PoolPriors(3.0, 40.0, None, 151, 10)
    assert priors.fits(151, 10)
    assert not priors.fits(150, 10)
    assert not priors.fits(151, 11)
    assert PoolPriors.from_arrays(priors.to_arrays()) == priors
    assert PoolPriors.from_arrays({}) is None


@pytest.mark.parametrize(
    "values",
    [
        np.array([3.0, 40.0, np.nan, 151.0]),  # four numbers
        np.array([3.0, 40.0, np.nan, 151.0, 10.0], np.float32),
        np.array([-1.0, 40.0, np.nan, 151.0, 10.0]),  # κ negative
        np.array([3.0, np.inf, np.nan, 151.0, 10.0]),
        np.array([3.0, 40.0, 0.0, 151.0, 10.0]),  # κ_G zero
        np.array([3.0, 40.0, np.nan, 151.5, 10.0]),  # a count not whole
    ],
)
def test_damaged_priors_are_refused(values: np.ndarray) -> None:
    with pytest.raises(MapCorruptError, match=MEMBER):
        PoolPriors.from_arrays({MEMBER: values})


def test_a_week_map_stores_the_priors_of_the_calendar_it_forecasts_with(tmp_path: Path) -> None:
    """A ``profile = "week"`` map whose evidence does not ask for the week forecasts with its
    sums pooled into weekdays and weekends (``calendar_view.pooled_view``): the priors it
    stores are that pooled view's, so the map forecasts the same with the member and without."""
    config = tmp_path / "week.toml"
    config.write_text('profile = "week"\n')
    week_map = tmp_path / "week.aion"
    assert run("build", SAMPLE, "-o", week_map, "--config", config, "-q").exit_code == 0
    assert json.loads(zipfile.ZipFile(week_map).read("manifest.json"))["families"]["calendar"]
    assert _stored(week_map) == _estimated(week_map, tmp_path)


def test_a_merge_copies_its_inputs_without_estimating_their_priors(
    sample_map: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``merge_states`` leaves its inputs as they were by merging copies of them; a copy is
    read back writable (which never uses stored priors) and never written, so its priors are
    not estimated (0.8 s of CPU at 10^5 entries each): the merge estimates none, the copy
    holds every member the original does, to the bit, and writing the merged map still
    stores the priors a query of it would estimate."""
    from aion_cli.engine import merge, state_arrays
    from aion_cli.engine.state import MapState, merge_states

    state = load_map(sample_map, writable=True).state
    want, want_meta = state.to_arrays()
    calls: list[int] = []

    def counted(s: MapState) -> PoolPriors:
        calls.append(1)
        return view_priors(s)

    monkeypatch.setattr(state_arrays, "view_priors", counted)
    copy = merge._copy(state)
    merged = merge_states(state, MapState.empty(state.config))
    assert calls == []
    got, meta = copy.to_arrays()
    assert calls == [1]
    assert sorted(got) == sorted(want)
    assert meta == want_meta
    for name, array in want.items():
        assert np.asarray(got[name]).tobytes() == np.asarray(array).tobytes(), name
    stored = PoolPriors.from_arrays(merged.to_arrays()[0])
    assert stored == view_priors(merged) == PoolPriors.from_arrays(want)


def test_the_atc_map_size_counts_the_priors_without_estimating_them(
    sample_map: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The evaluation's map bytes are every member's, the priors' five numbers included, as
    the map written holds them, but the priors are not estimated for it."""
    from aion_cli.engine import state_arrays
    from aion_cli.evaluation.atc import _state_bytes

    state = load_map(sample_map, writable=True).state
    arrays, _ = state.to_arrays()
    monkeypatch.setattr(state_arrays, "view_priors", None)  # called: a TypeError
    assert _state_bytes(state) == sum(np.asarray(a).nbytes for a in arrays.values())
    assert MEMBER in arrays
