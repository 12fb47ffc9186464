"""aion build on id-less detections: a linked track's first rows get the heading of its first
displacement (held back until it comes), as converting the tracks offline gives them, and a
slow walker (0.2 m/s) has his heading throughout; a person standing still has none on both
paths. Before, the build's causal rule left every track's first 0.3 m without a heading."""

from __future__ import annotations

import io
import math
import zipfile
from pathlib import Path

import numpy as np
import pytest

from aion_cli.engine.heading import HeadingEstimator
from aion_cli.engine.heading_hold import HeadingHold
from aion_cli.engine.tracking import link_tracks
from aion_cli.engine.types import DetectionBatch
from aion_cli.formats.tracks_log import POSE_ARRAY, tracks_to_log
from aion_cli.pipeline import BuildOptions, build_map

S = 1_000_000_000
T0 = 1_700_006_400 * S  # window-aligned
FAST, SLOW = 2.0, -0.7  # true headings (rad)


def _people() -> tuple[np.ndarray, np.ndarray, int, int, int]:
    """A walker at 1 m/s (10 s), then a slow walker at 0.2 m/s (20 s), then a person standing
    still (8 s), at 10 Hz, one at a time and far apart: times, positions and row counts."""
    parts = []
    for start_s, duration_s, origin, heading, speed in (
        (0, 10, (0.0, 0.0), FAST, 1.0),
        (20, 20, (30.0, 30.0), SLOW, 0.2),
        (50, 8, (-30.0, 10.0), 0.0, 0.0),
    ):
        k = np.arange(duration_s * 10)
        d = speed * k / 10
        xy = np.c_[origin[0] + d * math.cos(heading), origin[1] + d * math.sin(heading)]
        parts.append((T0 + start_s * S + k * S // 10, xy))
    t = np.concatenate([p[0] for p in parts])
    xy = np.concatenate([p[1] for p in parts])
    return t, xy, *(len(p[0]) for p in parts)


def _map_arrays(path: Path) -> dict[str, np.ndarray]:
    with zipfile.ZipFile(path) as z:
        return {n[:-4]: np.load(io.BytesIO(z.read(n))) for n in z.namelist()
                if n.endswith(".npy")}


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    t, xy, *_ = _people()
    n = len(t)
    batch = DetectionBatch(t, np.c_[xy, np.zeros(n)], np.full(n, np.nan), np.full(n, np.nan),
                           np.full(n, -1, np.int64))
    path = tmp_path_factory.mktemp("lookahead") / "legs.mcap"
    tracks_to_log(batch, path, msgtype=POSE_ARRAY, headings=False)  # as convert --drop-ids
    return path


@pytest.mark.parametrize("batch_size", [4000, 7])
def test_every_row_of_a_walker_gets_its_heading_from_the_first_one_on(
    log: Path, tmp_path: Path, batch_size: int
) -> None:
    t, xy, n_fast, n_slow, n_still = _people()
    # the offline path (aion convert's link_tracks) on the same rows: the known answer
    offline = link_tracks(t, xy).heading
    assert np.allclose(offline[:n_fast], FAST)
    assert np.allclose(offline[n_fast:-n_still], SLOW)
    assert np.isnan(offline[-n_still:]).all()

    out = tmp_path / "m.aion"
    report = build_map(BuildOptions(logs=(log,), output=out, batch_size=batch_size))
    assert report.headings["linked"] == n_fast + n_slow  # was 280 - 3 - 15: first rows none
    assert report.headings["none"] == n_still
    a = _map_arrays(out)
    assert a["entry_counts"].sum() == n_fast + n_slow  # counts per direction bin
    assert a["entry_nodir"].sum() == n_still
    cos, sin = a["entry_heading_cos"].sum(), a["entry_heading_sin"].sum()
    assert cos == pytest.approx(n_fast * math.cos(FAST) + n_slow * math.cos(SLOW), abs=1e-6)
    assert sin == pytest.approx(n_fast * math.sin(FAST) + n_slow * math.sin(SLOW), abs=1e-6)


def test_pieces_of_any_size_give_the_same_map(log: Path, tmp_path: Path) -> None:
    """Where a track's wait ends does not depend on where the stream was cut (the sums may
    differ in the last bit: each piece is summed on its own, as before the hold)."""
    maps = []
    for size in (4000, 7, 1):
        out = tmp_path / f"m{size}.aion"
        build_map(BuildOptions(logs=(log,), output=out, batch_size=size))
        maps.append(_map_arrays(out))
    for other in maps[1:]:
        assert other.keys() == maps[0].keys()
        differ = [k for k in other if other[k].shape != maps[0][k].shape
                  or not np.allclose(other[k], maps[0][k], rtol=0, atol=1e-9, equal_nan=True)]
        assert differ == []


def test_the_hold_stays_bounded_by_the_lapse_of_a_reference() -> None:
    """A person standing still for a minute (never 0.3 m from his reference) is held at most
    the 5 s of his lapsing reference, and every row leaves, in order, without a heading."""
    est = HeadingEstimator(min_displacement=0.3, max_gap_s=5.0, look_ahead=True)
    hold = HeadingHold()
    t = T0 + np.arange(600) * S // 10
    held, out = [], []
    for i in range(len(t)):
        b = est.estimate(t[i : i + 1], np.zeros((1, 3)), track_id=np.zeros(1, np.int64))
        got, _ = hold.push(b, np.zeros(1, np.int64), est.look)
        out.append(got.t_ns)
        held.append(len(hold))
    got, _ = hold.release()
    out.append(got.t_ns)
    assert max(held) <= 51  # 5 s at 10 Hz, and the row that lapses them
    assert np.array_equal(np.concatenate(out), t)
