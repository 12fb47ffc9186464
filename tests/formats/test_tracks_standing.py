"""Tracks with their own ids but no direction column (ETH/UCY, Edinburgh): a person standing
in position noise has no heading, as the id-less linker's tracks have none.

Before: the headings of these layouts came from the plain neighbour difference, so centimetre
jitter of a standing person became a walking direction (about 12 % of the headed detections
of biwi_hotel and students003 were slower than 0.2 m/s)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aion_cli.engine.tracking import link_tracks
from aion_cli.formats import tracks as ft

S = 1_000_000_000


def _standing_and_walking(seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frames (25 fps, 10 apart = 0.4 s), ids and positions: person 1 stands at (3, 4) with
    up to 3 cm of noise for 40 samples (16 s); person 2 walks 1.2 m/s due north meanwhile."""
    rng = np.random.default_rng(seed)
    k = np.arange(40)
    frames = np.r_[k, k] * 10
    ids = np.r_[np.full(40, 1), np.full(40, 2)]
    standing = np.c_[3.0 + rng.uniform(-0.03, 0.03, 40), 4.0 + rng.uniform(-0.03, 0.03, 40)]
    walking = np.c_[np.full(40, -2.0), 1.2 * 0.4 * k]
    return frames, ids, np.r_[standing, walking]


def test_a_standing_person_has_no_heading_a_walker_keeps_hers(tmp_path: Path) -> None:
    frames, ids, xy = _standing_and_walking()
    path = tmp_path / "eth.txt"
    rows = zip(frames, ids, xy, strict=True)
    path.write_text("".join(f"{f} {i} {x:.4f} {y:.4f}\n" for f, i, (x, y) in rows))
    batch = ft.read_tracks(path, "eth")
    one, two = batch.track_id == 1, batch.track_id == 2
    assert np.isnan(batch.heading[one]).all()  # before: 40 headings of jitter
    assert (batch.speed[one] < 0.2).all()  # a standing speed (neighbour difference) stays
    np.testing.assert_allclose(batch.heading[two], np.pi / 2, atol=1e-9)  # due north
    np.testing.assert_allclose(batch.speed[two], 1.2, atol=1e-9)
    # the same rule as the linker's: its tracks of these positions have the same headings
    links = link_tracks(batch.t_ns, batch.xyz)
    np.testing.assert_array_equal(np.isnan(links.heading), np.isnan(batch.heading))


def test_edinburgh_standing_person_has_no_heading(tmp_path: Path) -> None:
    frames, ids, xy = _standing_and_walking()
    px = xy / 0.0247 + [0.0, 100.0]  # pixels (y flipped on reading: the walker goes south)
    tracks = []
    for n in (1, 2):
        pts = zip(frames[ids == n], px[ids == n], strict=True)
        body = ";".join(f"[{x:.2f} {y:.2f} {f}]" for f, (x, y) in pts)
        tracks.append(f"TRACK.R{n}=[{body}];\n")
    path = tmp_path / "tracks.01Jul.txt"
    path.write_text("".join(tracks))
    batch = ft.read_tracks(path, "edinburgh")
    assert np.isnan(batch.heading[batch.track_id == 1]).all()
    np.testing.assert_allclose(batch.heading[batch.track_id == 2], -np.pi / 2, atol=1e-6)
