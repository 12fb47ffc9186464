"""Maps read member by member (issue 15): ``open_map`` verifies a member when it is first
read, a query's load keeps the arrays it read (no copies, no reserved rows) and predicts
exactly what the in-memory state predicts; a flipped byte in a member a query reads is
still an error naming it."""

from __future__ import annotations

import io
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.query import historical_table, predict_table
from aion_cli.errors import MapCorruptError
from aion_cli.formats.mapfile import open_map, read_map, write_map
from aion_cli.mapquery import load_map
from tests.formats.map_damage import flip_member_byte

T0_NS = 1_700_006_400 * 10**9  # the benchmark map's window (2023-11-15 00:00 UTC)
DAY_NS = 86_400 * 10**9


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> tuple[object, Path]:
    """A state of ~300 cell entries with two weeks of fixed-sensor history and a pending day
    (``benchmarks.bench_engine.build_state``), and the map written from it."""
    from benchmarks.bench_engine import build_state

    state = build_state(300)
    arrays, meta = state.to_arrays()
    path = tmp_path_factory.mktemp("lazy") / "q.aion"
    write_map(path, arrays, {"state": meta})
    return state, path


def test_members_are_read_when_first_accessed_and_equal_numpys_own(built: tuple) -> None:
    _, path = built
    with open_map(path) as members, zipfile.ZipFile(path) as zf:
        assert members.read_names == []
        assert "temporal_cnt_fourier" in members
        assert "nothing" not in members
        first = members["entry_counts"]
        assert members.read_names == ["entry_counts"]
        assert members["entry_counts"] is first  # read and checksummed once
        for name in members:
            ref = np.load(io.BytesIO(zf.read(name + ".npy")), allow_pickle=False)
            got = members[name]
            assert got.dtype == ref.dtype, name
            assert got.shape == ref.shape, name
            np.testing.assert_array_equal(got, ref, err_msg=name)
        assert sorted(members.read_names) == sorted(members)


def test_a_flipped_byte_fails_when_its_member_is_read(built: tuple, tmp_path: Path) -> None:
    _, path = built
    bad = flip_member_byte(path, "temporal_cnt_fourier", tmp_path / "bad.aion")
    with open_map(bad) as members:  # the archive's own checks pass
        members["entry_counts"]
        with pytest.raises(MapCorruptError, match="temporal_cnt_fourier fails its crc32"):
            members["temporal_cnt_fourier"]
    with pytest.raises(MapCorruptError, match="temporal_cnt_fourier"):
        read_map(bad)
    with pytest.raises(MapCorruptError, match="temporal_cnt_fourier"):
        load_map(bad)


def test_predict_refuses_a_map_with_a_flipped_byte(built: tuple, tmp_path: Path) -> None:
    _, path = built
    bad = flip_member_byte(path, "temporal_cnt_profile", tmp_path / "bad.aion")
    proc = subprocess.run(
        [sys.executable, "-m", "aion_cli", "predict", str(bad), "--top", "3", "--time",
         "2023-11-16 12:00", "--format", "csv"],
        capture_output=True, text=True, check=False,
    )
    assert proc.returncode == 2, proc.stderr
    assert "temporal_cnt_profile" in proc.stderr
    assert proc.stdout == ""


@pytest.mark.parametrize("writable", [False, True])
def test_a_loaded_map_predicts_what_the_state_predicts(built: tuple, writable: bool) -> None:
    state, path = built
    loaded = load_map(path, writable=writable).state
    assert loaded.temporal.n_rows == (
        loaded.entries.capacity if writable else loaded.entries.n
    )  # a query's state reserves no rows (no copy of the accumulators)
    times = [T0_NS + DAY_NS + h * 3_600 * 10**9 for h in (0, 7, 12, 18)] + [T0_NS - 3 * DAY_NS]
    for t in times:
        a, b = predict_table(state, t), predict_table(loaded, t)
        np.testing.assert_array_equal(a.key, b.key)
        for name in ("flow", "flow_var", "rate"):
            np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-9,
                                       atol=1e-12, err_msg=name)
        np.testing.assert_allclose(b.descriptors.probabilities, a.descriptors.probabilities,
                                   rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(a.flow_family, b.flow_family)
        np.testing.assert_array_equal(a.direction_family, b.direction_family)
    np.testing.assert_allclose(historical_table(loaded).flow, historical_table(state).flow,
                               rtol=1e-9)


def test_count_quantiles_without_scipy_stats_are_scipys() -> None:
    from aion_cli.engine.temporal.choice import count_quantiles as exact
    from aion_cli.engine.temporal.quantiles import count_quantiles

    rng = np.random.default_rng(4)
    mu = np.concatenate([rng.exponential(3.0, 400), rng.uniform(0, 300, 200),
                         [0.0, np.nan, 1e-12, 5.0, 2e5]])
    var = mu * np.where(rng.random(mu.size) < 0.5, 1.0, rng.uniform(1.0, 30.0, mu.size))
    var[-3] = np.inf
    for q in (0.1, 0.5, 0.9, 0.99):
        np.testing.assert_array_equal(count_quantiles(mu, var, q), exact(mu, var, q))
    code = ("import sys; import numpy as np; "
            "from aion_cli.engine.temporal.quantiles import count_quantiles as c; "
            "c(np.array([2.5, 0.7]), np.array([2.5, 4.0]), 0.9); "
            "print('scipy.stats' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"


def test_members_are_aligned_and_mapped_in_place_copy_on_write(built: tuple) -> None:
    from aion_cli.formats.mapfile import ALIGN

    _, path = built
    before = path.read_bytes()
    with zipfile.ZipFile(path) as zf:
        for info in zf.infolist():
            if info.filename == "manifest.json":
                continue
            raw = before[info.header_offset : info.header_offset + 30]
            start = (info.header_offset + 30 + int.from_bytes(raw[26:28], "little")
                     + int.from_bytes(raw[28:30], "little"))
            assert start % ALIGN == 0, info.filename
    with open_map(path, in_place=True) as members, open_map(path) as copies:
        for name in members:
            mapped, copied = members[name], copies[name]
            assert mapped.flags.aligned, name
            assert mapped.flags.writeable, name
            np.testing.assert_array_equal(mapped, copied, err_msg=name)
        fourier = members["temporal_cnt_fourier"]
        fourier[:] = 0  # a private mapping: the file is not written
    assert path.read_bytes() == before


def test_a_map_of_the_dense_layout_reads_as_the_sparse_one(built: tuple, tmp_path: Path) -> None:
    """Maps written before the temporal members were sparse (every row stored, counts as
    [R, V, K], no index members) load and predict as the same map written sparsely."""
    state, path = built
    arrays, manifest = read_map(path)
    manifest = {k: v for k, v in manifest.items()
                if k not in ("format", "version", "creator", "created", "members")}
    rows = int(np.asarray(arrays["entry_kind"]).size)
    values = state.params.values
    dense = {k: v for k, v in arrays.items() if not k.endswith("_index")}
    obs_rows = np.asarray(arrays["temporal_obs_index"], np.int64)
    for f in ("n", "fourier", "profile", "first", "last"):
        part = np.asarray(arrays[f"temporal_obs_{f}"], np.float64 if f != "fourier" else None)
        full = np.zeros((rows, *part.shape[1:]), part.dtype)
        if f in ("first", "last"):
            full[:] = np.nan
        full[obs_rows] = part
        dense[f"temporal_obs_{f}"] = full
    pairs = np.asarray(arrays["temporal_cnt_index"], np.int64)
    for f in ("fourier", "profile"):
        part = np.asarray(arrays[f"temporal_cnt_{f}"])
        part = part if f == "fourier" else part.astype(np.float64)
        full = np.zeros((rows * values, part.shape[1]), part.dtype)
        full[pairs] = part
        dense[f"temporal_cnt_{f}"] = full.reshape(rows, values, -1)
    scored = np.asarray(arrays["temporal_score_index"], np.int64)
    for f in ("flow_score", "flow_chi2", "flow_scored", "flow_days", "flow_gain_sq",
              "dir_score", "dir_scored", "dir_days", "dir_gain_sq"):
        part = np.asarray(arrays[f"temporal_{f}"], np.float64)
        full = np.zeros((rows, *part.shape[1:]))
        full[scored] = part
        dense[f"temporal_{f}"] = full
    old = tmp_path / "dense.aion"
    write_map(old, dense, manifest)
    t = T0_NS + DAY_NS + 9 * 3_600 * 10**9
    a, b = predict_table(load_map(path).state, t), predict_table(load_map(old).state, t)
    np.testing.assert_array_equal(a.flow, b.flow)
    np.testing.assert_array_equal(a.descriptors.probabilities, b.descriptors.probabilities)
