"""Bounded resources: crafted maps cannot expand into gigabytes, and TF lookups over long
frame chains take memory for one block of query times, not for every chain step at once.

Memory is measured with ``tracemalloc`` (numpy reports its buffers to it); no test asserts a
time. The figures of the unbounded versions are in docs/ROBUSTNESS.md.
"""

from __future__ import annotations

import hashlib
import io
import json
import tracemalloc
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aion_cli.errors import MapFileError
from aion_cli.formats.mapfile import (
    DEFAULT_MAX_MEMBERS,
    MAP_FORMAT,
    RATIO_MIN_BYTES,
    format_version,
    read_manifest,
    read_map,
    write_map,
)
from aion_cli.formats.tf import TfBuffer
from tests.robustness.conftest import Office, assert_one_error, run

MB = 1024**2


def peak_mb(fn: Callable[[], Any]) -> tuple[Any, float]:
    """``fn()`` and the peak of memory traced while it ran, in MiB (exceptions are returned)."""
    tracemalloc.start()
    try:
        result: Any = fn()
    except Exception as exc:  # the refusal is the result
        result = exc
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return result, peak / MB


def npy_bytes(arr: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, arr, allow_pickle=False)
    return buf.getvalue()


def crafted_map(path: Path, members: dict[str, bytes], deflate: bool) -> Path:
    """A zip that is a valid map in every respect (manifest, sha256, sizes, dtypes, shapes)
    except, when ``deflate``, that its members are deflated as another tool might write them."""
    records = {}
    for name, data in members.items():
        arr = np.load(io.BytesIO(data), allow_pickle=False)
        records[name] = {
            "sha256": hashlib.sha256(data).hexdigest(),
            "size": len(data),
            "dtype": arr.dtype.str,
            "shape": list(arr.shape),
        }
    manifest = {
        "format": MAP_FORMAT,
        "version": format_version(),
        "creator": "a test",
        "created": "2026-01-01T00:00:00Z",
        "members": records,
    }
    method = zipfile.ZIP_DEFLATED if deflate else zipfile.ZIP_STORED
    with zipfile.ZipFile(path, "w", compression=method) as zf:
        for name, data in members.items():
            zf.writestr(name + ".npy", data)
        zf.writestr("manifest.json", json.dumps(manifest))
    return path


def test_many_small_deflated_members_cannot_bypass_the_ratio_check(tmp_path: Path) -> None:
    """200 members of 1 MiB of zeros, each just under the per-member ratio threshold, deflate
    to about 1 KB each: a 0.2 MB file that would expand to 200 MiB. Refused before any member
    is read, in a few MiB."""
    zeros = npy_bytes(np.zeros((RATIO_MIN_BYTES - 200) // 8))
    assert len(zeros) <= RATIO_MIN_BYTES  # every member escapes the per-member check
    bomb = crafted_map(tmp_path / "bomb.aion", {f"m{i:03d}": zeros for i in range(200)}, True)
    assert bomb.stat().st_size < 1 * MB
    result, peak = peak_mb(lambda: read_map(bomb))
    assert isinstance(result, MapFileError), result
    assert "refusing a possible zip bomb" in result.message
    assert "expand" in result.message
    assert peak < 20, peak
    # the same members stored (as aion writes them) are a genuine 200 MiB map: read in full
    # when the caller allows that much (the default does), refused over a total it sets
    stored = crafted_map(tmp_path / "stored.aion", {f"m{i:03d}": zeros for i in range(20)}, False)
    arrays, _ = read_map(stored)
    assert len(arrays) == 20
    with pytest.raises(MapFileError, match="in all, over the"):
        read_map(stored, max_total_bytes=10 * MB)


def test_a_map_with_too_many_members_is_refused_before_parsing_them(tmp_path: Path) -> None:
    small = npy_bytes(np.zeros(1))
    many = crafted_map(tmp_path / "many.aion", {f"m{i}": small for i in range(300)}, False)
    with pytest.raises(MapFileError, match="301 zip entries, over the 100-entry limit"):
        read_map(many, max_members=100)
    with pytest.raises(MapFileError, match="301 zip entries"):  # the manifest counts too
        read_map(many, max_members=300)
    with pytest.raises(MapFileError, match="zip entries"):
        read_manifest(many, max_members=100)
    arrays, _ = read_map(many, max_members=301)  # 300 arrays + the manifest
    assert len(arrays) == 300
    assert DEFAULT_MAX_MEMBERS >= 1000  # real maps (~50 members) are far below the default


def test_the_entry_count_comes_from_the_end_record_not_the_parsed_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Over the limit, zipfile never parses the central directory (which costs one Python
    object per entry): a ZipFile constructor that fails proves it is not reached."""
    small = npy_bytes(np.zeros(1))
    many = crafted_map(tmp_path / "many.aion", {f"m{i}": small for i in range(50)}, False)

    def never(*a: Any, **k: Any) -> Any:
        raise AssertionError("the central directory was parsed")

    monkeypatch.setattr(zipfile, "ZipFile", never)
    with pytest.raises(MapFileError, match="51 zip entries"):
        read_map(many, max_members=10)


def test_a_real_map_reads_within_the_default_limits(office: Office) -> None:
    arrays, manifest = read_map(office.map)
    assert len(manifest["members"]) == len(arrays) < DEFAULT_MAX_MEMBERS
    with zipfile.ZipFile(office.map) as zf:
        total = sum(i.file_size for i in zf.infolist())
    assert total <= 1.01 * office.map.stat().st_size  # stored: ratio 1


def test_a_map_bomb_through_the_cli_is_one_error_line(tmp_path: Path) -> None:
    zeros = npy_bytes(np.zeros((RATIO_MIN_BYTES - 200) // 8))
    bomb = crafted_map(tmp_path / "bomb.aion", {f"m{i:03d}": zeros for i in range(50)}, True)
    result = run("predict", bomb, "--historical")
    assert result.exit_code == 2
    assert_one_error(result.stderr, "refusing a possible zip bomb")


def test_write_map_output_is_read_back_exactly(tmp_path: Path) -> None:
    """The limits do not touch what aion writes itself (members stored, totals = file)."""
    arrays = {f"a{i}": np.arange(i * 1000, dtype=np.float64) for i in range(1, 30)}
    write_map(tmp_path / "m.aion", arrays, {})
    back, _ = read_map(tmp_path / "m.aion", max_members=30, max_total_bytes=4 * MB)
    for name, arr in arrays.items():
        np.testing.assert_array_equal(back[name], arr)


# -- TF chains --------------------------------------------------------------------------------


def chain_buffer(n_frames: int, samples: int, seed: int = 0, **kw: Any) -> TfBuffer:
    """``f0 -> f1 -> ... -> f<n>``: dynamic edges with ``samples`` noisy samples each, every
    third edge stored child->parent (so lookups invert it) and every fifth static."""
    rng = np.random.default_rng(seed)
    buf = TfBuffer(**kw)
    for k in range(n_frames):
        t = np.arange(samples, dtype=np.int64) * 1_000_000_000 + k * 1_000_000
        tr = rng.normal(size=(samples, 3))
        q = np.array([0.0, 0.0, 0.0, 1.0]) + rng.normal(size=(samples, 4)) * 0.3
        parent, child = (f"f{k}", f"f{k + 1}") if k % 3 else (f"f{k + 1}", f"f{k}")
        buf.add_transforms(parent, child, t, tr, q, static=(k % 5 == 4))
    return buf


def test_blocked_lookups_equal_the_unblocked_answer() -> None:
    n = 23
    whole = chain_buffer(n, 6, block_rows=10**9)
    blocked = chain_buffer(n, 6, block_rows=7)
    rng = np.random.default_rng(1)
    times = rng.integers(-2_000_000_000, 7_000_000_000, size=500)  # some outside the range
    for target, source in (("f0", f"f{n}"), (f"f{n}", "f3"), ("f4", "f5"), ("f9", "f9")):
        R1, t1, ok1 = whole.lookup(target, source, times)
        R2, t2, ok2 = blocked.lookup(target, source, times)
        np.testing.assert_array_equal(ok1, ok2)
        np.testing.assert_allclose(R1, R2, rtol=0, atol=1e-12, equal_nan=True)
        np.testing.assert_allclose(t1, t2, rtol=0, atol=1e-12, equal_nan=True)
    ok = whole.lookup("f0", f"f{n}", times)[2]
    assert 0 < ok.sum() < len(times)  # rows inside and outside the recorded range
    traj1 = whole.trajectory("f0", f"f{n}")
    traj2 = blocked.trajectory("f0", f"f{n}")
    np.testing.assert_array_equal(traj1.t_ns, traj2.t_ns)
    np.testing.assert_allclose(traj1.xyz, traj2.xyz, rtol=0, atol=1e-12)


def test_blocked_chain_matches_composing_the_edges_by_hand() -> None:
    """An independent answer: the chain's transform built from each edge's own lookup."""
    buf = chain_buffer(6, 4, block_rows=3)
    times = np.array([0, 500_000_000, 1_700_000_000, 2_900_000_000], dtype=np.int64) + 5_000_000
    R, t, ok = buf.lookup("f0", "f6", times)
    assert ok.all()
    R_acc = np.broadcast_to(np.eye(3), (len(times), 3, 3)).copy()
    t_acc = np.zeros((len(times), 3))
    for k in range(6):
        Rk, tk, okk = buf.lookup(f"f{k}", f"f{k + 1}", times)
        assert okk.all()
        t_acc = t_acc + np.einsum("nij,nj->ni", R_acc, tk)
        R_acc = R_acc @ Rk
    np.testing.assert_allclose(R, R_acc, atol=1e-12)
    np.testing.assert_allclose(t, t_acc, atol=1e-12)


def test_a_thousand_frame_chain_stays_within_a_memory_bound() -> None:
    """1,000 frames with 3 samples each: the trajectory is looked up at the chain's 3,000
    sample times through 1,000 edges. Holding every step took 293 MiB; now the output plus one
    block's temporaries: under 32 MiB."""
    buf = chain_buffer(1000, 3)
    buf.frames  # ingest before measuring
    traj, peak = peak_mb(lambda: buf.trajectory("f0", "f1000"))
    assert not isinstance(traj, Exception), traj
    assert len(traj.t_ns) > 0
    assert peak < 32, peak
