"""The public pedestrian datasets beyond ATC / THÖR / Lincoln: Edinburgh Informatics Forum
tracks, THÖR-MAGNI CSVs (``formats.thor_magni``) and the ETH/UCY 4-column files
(``formats.track_csv``), checked against figures known from the files themselves (the Edinburgh
database's own table of trajectories and detections per day, counts parsed here independently)
and against synthetic files whose answers follow from how they were written."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from aion_cli.formats import datasets, thor_magni, track_types
from aion_cli.formats import tracks as ft
from tests.formats.dataset_files import (
    EDINBURGH,
    ETH_UCY,
    MAGNI_HEADER,
    edinburgh_file,
    magni_file,
)

S = 1_000_000_000
PX = 0.0247


# ----------------------------------------------------------------------------- Edinburgh


@pytest.mark.skipif(not EDINBURGH.is_file(), reason="../shared/data/tracks/edinburgh is absent")
def test_edinburgh_real_day() -> None:
    start = 1_277_938_800 * S  # 2010-07-01 00:00 Europe/London (BST)
    data = ft.read_track_data(EDINBURGH, "edinburgh", start_ns=start)
    batch = data.batch
    # the database's table: "Jul 01 ... tracks.Jul01  1262 (trajectories)  111230 (detections)"
    assert len(batch) == 111_230
    assert len(np.unique(batch.track_id)) == 1262
    assert set(batch.track_id.tolist()) == set(range(1, 1263))
    assert data.notes == ()  # every Properties.Rn point count matches its track
    # pixels (x 3..635, y 2..456 in the file) at 24.7 mm, rows flipped (y up)
    assert batch.xyz[:, 0].min() == pytest.approx(3 * PX)
    assert batch.xyz[:, 0].max() == pytest.approx(635 * PX)
    assert batch.xyz[:, 1].min() == pytest.approx((480 - 456) * PX)
    assert batch.xyz[:, 1].max() == pytest.approx((480 - 2) * PX)
    np.testing.assert_array_equal(batch.xyz[:, 2], 0)
    # frames 95 .. 323836 at 9 fps after frame 0 = start
    assert batch.t_ns[0] == start + round(95 / 9 * 1e6) * 1000
    assert batch.t_ns[-1] == start + round(323836 / 9 * 1e6) * 1000
    assert (np.diff(batch.t_ns) >= 0).all()
    # the first point of R1 is [593 42 95]
    first = np.flatnonzero((batch.track_id == 1) & (batch.t_ns == batch.t_ns[0]))
    np.testing.assert_allclose(batch.xyz[first[0], :2], [593 * PX, (480 - 42) * PX])
    # people walk: median speed 1.2 m/s at 9 fps
    assert 0.9 < float(np.nanmedian(batch.speed)) < 1.5
    # (94.6 %: people standing still, no 0.3 m step within 5 s, have none; 95.2 % before
    # headings were differenced by the linker's rule)
    assert np.isfinite(batch.heading).mean() > 0.94


def test_edinburgh_synthetic_positions_times_and_headings(tmp_path: Path) -> None:
    # R7 walks +x (right in the image), R9 walks down the image (+py) = -y in the map, in steps
    # of 0.49 m and 0.32 m: longer than the 0.3 m a heading needs (LinkerConfig.min_step)
    path = edinburgh_file(
        tmp_path / "tracks.test.txt",
        {7: [(100, 200, 18), (120, 200, 19), (140, 200, 20)], 9: [(50, 50, 0), (50, 63, 3)]},
    )
    data = ft.read_track_data(path, "edinburgh", start_ns=1000 * S, fps=10.0)
    b = data.batch
    assert len(b) == 5
    assert sorted(set(b.track_id.tolist())) == [7, 9]
    r7 = b.track_id == 7
    np.testing.assert_allclose(b.xyz[r7, 0], np.array([100, 120, 140]) * PX)
    np.testing.assert_allclose(b.xyz[r7, 1], (480 - 200) * PX)
    assert b.t_ns[r7].tolist() == [1000 * S + 1.8 * S, 1000 * S + 1.9 * S, 1002 * S]
    np.testing.assert_allclose(b.heading[r7], 0.0, atol=1e-12)
    np.testing.assert_allclose(b.speed[r7], 20 * PX / 0.1)
    r9 = b.track_id == 9
    np.testing.assert_allclose(b.heading[r9], -math.pi / 2)
    np.testing.assert_allclose(b.speed[r9], 13 * PX / 0.3)
    assert data.notes == ()
    # the default frame rate is about 9 fps
    assert ft.read_tracks(path, "edinburgh").t_ns.max() == round(20 / 9 * 1e6) * 1000


def test_edinburgh_point_count_mismatch_is_a_note(tmp_path: Path) -> None:
    path = edinburgh_file(tmp_path / "t.txt", {1: [(1, 2, 3), (2, 2, 4)]}, R1=5)
    data = ft.read_track_data(path, "edinburgh")
    assert len(data.batch) == 2
    assert len(data.notes) == 1
    assert "R1" in data.notes[0]
    assert "Properties" in data.notes[0]


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("% nothing here\n", "no track rows"),  # % comments alone: nobody came
        ("% header\nnot an entry\n", "no TRACK.Rn"),
        ("Properties.R1=[2 1 2];\nTRACK.R1=[[1 2 3];[4 5]];\n", "TRACK.R1 point 2"),
        ("TRACK.R1=[[1 2 3];[4 x 6]];\n", "TRACK.R1 point 2"),
        ("TRACK.R1=[[1 2 3];[4 5 6.5]];\n", "whole frame"),
        ("TRACK.R1=[[1 2 3]];\nTRACK.R2=[1 2 3];\n", "line 2: a TRACK entry"),
        ("TRACK.R1=[[1 2 3]];\nTRACK.R1=[[1 2 4]];\n", "R1 is defined twice"),
        ("", "no track rows"),
    ],
)
def test_bad_edinburgh_files(text: str, fragment: str, tmp_path: Path) -> None:
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(track_types.TracksFormatError, match=re.escape(fragment)):
        ft.read_tracks(path, "edinburgh")


def test_edinburgh_missing_file_and_bad_fps(tmp_path: Path) -> None:
    with pytest.raises(track_types.TracksFormatError, match="not found"):
        ft.read_tracks(tmp_path / "none.txt", "edinburgh")
    path = edinburgh_file(tmp_path / "t.txt", {1: [(1, 2, 3)]})
    for fps in (0.0, float("inf"), float("nan"), 1e300):  # inf: every frame at one instant
        with pytest.raises(track_types.TracksFormatError, match=r"fps must be 0 \.\. 10,000"):
            datasets.read_edinburgh(path, fps=fps)


# ----------------------------------------------------------------------------- THÖR-MAGNI

def test_thor_magni_synthetic(tmp_path: Path) -> None:
    path = magni_file(tmp_path / "THOR-Magni_120522_SC1A_R1.csv")
    start = 1_652_342_400 * S
    data = ft.read_track_data(path, "thor-magni", start_ns=start)
    b = data.batch
    assert sorted(set(b.track_id.tolist())) == [3, 11]  # Helmet_3, Helmet_11
    h3, h11 = b.track_id == 3, b.track_id == 11
    assert int(h3.sum()) == 50
    assert int(h11.sum()) == 45  # 5 untracked frames skipped
    assert b.t_ns[h3].tolist() == [start + k * 10_000_000 for k in range(50)]
    np.testing.assert_allclose(b.xyz[h3][0], [1.0, 2.0, 1.7002])
    np.testing.assert_allclose(b.xyz[h11][0], [5.0, -3.0, 1.65])
    np.testing.assert_allclose(b.speed[h3], 1.2, rtol=1e-9)
    np.testing.assert_allclose(b.heading[h3], 0.0, atol=1e-12)
    np.testing.assert_allclose(b.speed[h11], 0.8, rtol=1e-9)
    # headings by the linker's rule (a step of at least LinkerConfig.min_step = 0.3 m either
    # way): Helmet_11's 0.4 m track leaves the rows less than 0.3 m from both of its ends none
    y = b.xyz[h11, 1]
    short = (y - y.min() < 0.3) & (y.max() - y < 0.3)
    assert 0 < short.sum() < len(y)
    np.testing.assert_allclose(b.heading[h11][~short], math.pi / 2)
    assert np.isnan(b.heading[h11][short]).all()
    assert (np.diff(b.t_ns) >= 0).all()
    notes = " | ".join(data.notes)
    assert "5 of 150 rows have no position" in notes
    assert "not people, skipped: DARKO_Robot" in notes
    assert "positions read as millimetres" in notes


def test_thor_magni_columns_by_name_units_and_ids(tmp_path: Path) -> None:
    # other column order, metres, no z, ids without unique trailing numbers
    header = "ag_id,Time,y,x,extra"
    rows = ["Helmet_A,0.0,1.0,2.0,q", "Helmet_B,0.0,3.0,4.0,q", "Helmet_A,0.5,1.5,2.0,q"]
    path = magni_file(tmp_path / "m.csv", header, rows)
    data = ft.read_track_data(path, "thor-magni")
    b = data.batch
    np.testing.assert_allclose(b.xyz, [[2.0, 1.0, 0.0], [4.0, 3.0, 0.0], [2.0, 1.5, 0.0]])
    assert b.track_id.tolist() == [0, 1, 0]  # ranks of Helmet_A, Helmet_B
    assert b.t_ns.tolist() == [0, 0, S // 2]
    assert "positions read as metres" in " ".join(data.notes)
    # forcing the unit
    mm = ft.read_track_data(path, "thor-magni", units="mm").batch
    np.testing.assert_allclose(mm.xyz[:, :2], b.xyz[:, :2] / 1000)
    assert not any("read as" in n for n in ft.read_track_data(path, "thor-magni", units="m").notes)
    # a file without helmets keeps every agent
    rows = ["0.0,1,1000,0,0,LO1,x,m,1", "0.1,2,1100,0,0,LO1,x,m,1"]
    only = ft.read_track_data(magni_file(tmp_path / "o.csv", rows=rows), "thor-magni")
    assert only.batch.track_id.tolist() == [1, 1]


@pytest.mark.parametrize(
    ("header", "rows", "fragment"),
    [
        ("Time,frame_id,x,y,z,data_label", ["0,1,1,2,3,a"], "ag_id missing"),
        ("frame_id,x,y,ag_id", ["1,1,2,Helmet_1"], "Time missing"),
        (MAGNI_HEADER, ["0.0,1,10,abc,0,Helmet_1,a,m,1"], "line 2, column y: 'abc' is not"),
        (
            MAGNI_HEADER,
            ["0.0,1,10,0,0,Helmet_1,a,m,1", ",2,10,0,0,Helmet_1,a,m,1"],
            "line 3, column Time",
        ),
        (MAGNI_HEADER, ["0.0,1,,,,Helmet_1,a,m,1"], "no row with a position"),
        (MAGNI_HEADER, [], "no track rows"),
        (MAGNI_HEADER, ["0.0,1,10"], "not a valid thor-magni tracks file"),
    ],
)
def test_bad_thor_magni_files(header: str, rows: list[str], fragment: str, tmp_path: Path) -> None:
    path = magni_file(tmp_path / "bad.csv", header, rows)
    with pytest.raises(track_types.TracksFormatError, match=re.escape(fragment)):
        ft.read_tracks(path, "thor-magni")


def test_thor_magni_missing_empty_and_unit(tmp_path: Path) -> None:
    with pytest.raises(track_types.TracksFormatError, match="not found"):
        ft.read_tracks(tmp_path / "none.csv", "thor-magni")
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(track_types.TracksFormatError, match="no track rows"):
        ft.read_tracks(empty, "thor-magni")
    with pytest.raises(track_types.TracksFormatError, match="unknown length unit"):
        thor_magni.read_thor_magni(magni_file(tmp_path / "m.csv"), units="feet")


# ----------------------------------------------------------------------------- ETH / UCY

ETH_FILES = [
    "biwi_eth.txt",
    "biwi_hotel.txt",
    "crowds_zara01.txt",
    "crowds_zara02.txt",
    "crowds_zara03.txt",
    "students001.txt",
    "students003.txt",
    "uni_examples.txt",
]


def _rows(path: Path) -> list[list[float]]:
    return [[float(v) for v in line.split()] for line in path.read_text().splitlines() if line]


@pytest.mark.skipif(not ETH_UCY.is_dir(), reason="../shared/data/tracks/eth_ucy is absent")
@pytest.mark.parametrize("name", ETH_FILES)
def test_every_real_eth_ucy_file(name: str) -> None:
    path = ETH_UCY / name
    rows = _rows(path)
    layout = "eth" if name.startswith("biwi") else "ucy"
    batch = ft.read_tracks(path, layout, start_ns=10 * S)
    assert len(batch) == len(rows)
    assert set(batch.track_id.tolist()) == {int(r[1]) for r in rows}
    frames = [r[0] for r in rows]
    assert batch.t_ns[0] == 10 * S + round(min(frames) / 25 * 1e9)
    assert batch.t_ns[-1] == 10 * S + round(max(frames) / 25 * 1e9)
    # each person every 10 frames at 25 fps: 0.4 s steps within a track
    order = np.lexsort((batch.t_ns, batch.track_id))
    same = np.diff(batch.track_id[order]) == 0
    steps = np.diff(batch.t_ns[order])[same]
    assert set(steps.tolist()) == {400_000_000}
    np.testing.assert_allclose(
        np.sort(batch.xyz[:, 0]), np.sort([r[2] for r in rows]), rtol=0, atol=1e-9
    )
    speed = float(np.nanmedian(batch.speed))
    if name == "biwi_eth.txt":
        # this 10-frame version was interpolated from the original, annotated every 6 frames
        # = 0.4 s (so 15 fps): read at 25 fps, people walk 1.6 times too fast
        assert 2.2 < speed < 2.7
        slow = ft.read_tracks(path, "eth", fps=15.0)
        assert 1.3 < float(np.nanmedian(slow.speed)) < 1.7
    else:
        assert 0.4 < speed < 1.6
