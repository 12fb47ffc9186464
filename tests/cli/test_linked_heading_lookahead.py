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

from aion_cli.engine.config import ModelConfig
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


# ------------------------------------------------------------ scene graphs every 5 s

GRAPH = Path(__file__).resolve().parents[1] / "data" / "dsg" / "apartment_dsg.json"
#: walkers in the apartment graph's places, one at a time: start (s after T0), duration (s),
#: origin, heading (rad), speed (m/s). The log writes the graph at T0 and every 5 s; the
#: second and fourth walkers start 50 ms before a graph (at 1 m/s they wait 0.3 s for their
#: first displacement), the third and fifth 1.2 s and 1.5 s before one (0.2 m/s: 1.5 s). The
#: fourth's first row lies in the 10 s window that the graph at 30 s closes.
WALKERS = (
    (0.0, 3, (-14.0, -6.0), 0.3, 1.0),
    (4.95, 4, (-14.0, -3.0), -0.4, 1.0),
    (13.8, 10, (-8.0, -2.0), 2.5, 0.2),
    (29.95, 4, (-7.0, -1.5), -2.6, 1.0),
    (38.5, 10, (-12.0, -6.5), 1.2, 0.2),
)


def _walkers(walkers: tuple[tuple[float, int, tuple[float, float], float, float], ...]
             = WALKERS) -> DetectionBatch:
    """The walkers' rows at 10 Hz with their true heading, speed and a track id each."""
    t, xy, heading, speed, ids = [], [], [], [], []
    for i, (start_s, duration_s, origin, h, v) in enumerate(walkers):
        k = np.arange(duration_s * 10)
        d = v * k / 10
        t.append(T0 + round(start_s * 10) * S // 10 + k * S // 10)
        xy.append(np.c_[origin[0] + d * math.cos(h), origin[1] + d * math.sin(h)])
        heading.append(np.full(len(k), h))
        speed.append(np.full(len(k), v))
        ids.append(np.full(len(k), i))
    xy_all = np.concatenate(xy)
    return DetectionBatch(np.concatenate(t), np.c_[xy_all, np.zeros(len(xy_all))],
                          np.concatenate(heading), np.concatenate(speed), np.concatenate(ids))


def _idless_log(truth: DetectionBatch, path: Path) -> Path:
    """``truth`` without ids and headings, as convert --drop-ids writes it, with the graph
    every 5 s."""
    n = len(truth)
    idless = DetectionBatch(truth.t_ns, truth.xyz, np.full(n, np.nan), np.full(n, np.nan),
                            np.full(n, -1, np.int64))
    tracks_to_log(idless, path, graph_file=GRAPH, graph_period_s=5.0, msgtype=POSE_ARRAY,
                  headings=False, graph_clock=True)
    return path


@pytest.mark.parametrize("batch_size", [4000, 1])
def test_a_scene_graph_does_not_take_the_heading_of_a_track_that_just_started(
    tmp_path: Path, batch_size: int
) -> None:
    """The build holds a graph that comes while a track's first rows wait behind them: every
    row gets its heading (before, the hold was emptied before each graph, and the rows
    waiting then went without one: 27 of 310 here), and the map equals the one built from
    the same people with their track ids and velocities, where no row waits: the rows land
    in the same entries and windows, with the same speeds, and the graphs bind the same
    cells. A row that waited takes the speed of the displacement that gave its heading
    (before, a track's first row got its heading but no speed: 305 speeds of 310 rows,
    summing to 146.6 m/s of the walkers' 150)."""
    truth = _walkers()
    n = len(truth)
    # the known answer: linking the id-less rows offline gives every row its true heading
    assert np.allclose(link_tracks(truth.t_ns, truth.xyz[:, :2]).heading, truth.heading)

    ids_log = tmp_path / "ids.mcap"
    tracks_to_log(truth, ids_log, graph_file=GRAPH, graph_period_s=5.0, graph_clock=True)
    idless_log = _idless_log(truth, tmp_path / "idless.mcap")
    config = ModelConfig(window_s=10.0)
    maps = []
    for log_path in (ids_log, idless_log):
        out = tmp_path / f"{log_path.stem}.aion"
        report = build_map(BuildOptions(logs=(log_path,), output=out, config=config,
                                        batch_size=batch_size))
        assert report.graph_messages == 10  # every 5 s of the 48.5 s
        maps.append(_map_arrays(out))
    assert report.headings == {"none": 0, "linked": n}
    with_ids, without = maps
    assert with_ids.keys() == without.keys()
    differ = [k for k in with_ids if not (
        with_ids[k].shape == without[k].shape
        and np.allclose(with_ids[k], without[k], rtol=0, atol=1e-9, equal_nan=True))]
    assert differ == []
    assert without["entry_counts"].sum() == n  # every row in a direction bin
    assert without["entry_nodir"].sum() == 0
    # the known speeds: each walker's true speed on every one of his rows
    assert without["entry_speed_n"].sum() == n
    assert without["entry_speed_sum"].sum() == pytest.approx(truth.speed.sum(), rel=1e-12)


#: walkers every 15 s, then a person standing until 587 s, and two more walkers from 600 s
_QUIET_AT_600 = (
    *((s0, 6, (-14.0 + k % 5, -6.0 + k % 4), 0.5 * k, 1.0 if k % 2 else 0.2)
      for k, s0 in enumerate(range(0, 570, 15))),
    (575.0, 12, (-10.0, -4.0), 0.0, 0.0),  # stands till 587 s
    (600.0, 6, (-12.0, -5.0), 1.0, 0.2), (615.0, 6, (-9.0, -3.0), -2.0, 1.0),
)


def test_workers_and_a_continued_map_build_the_one_pass_map_of_an_id_less_log(
    tmp_path: Path,
) -> None:
    """Graphs wait behind held rows across a quiet moment: a person stands until 13 s before
    the window at 600 s (his last rows wait for a displacement that never comes, the graphs
    of the quiet seconds behind them, until the next person lapses them). Two time shards cut
    there give the one-pass map, and so does the log cut there into two logs, the first
    built and then continued with the second (``--map``), the one pass over both
    (``differences``: ints exact, floats to 1e-12)."""
    from aion_cli.engine.compare import differences
    from aion_cli.mapquery import load_map

    truth = _walkers(_QUIET_AT_600)
    log = _idless_log(truth, tmp_path / "idless.mcap")
    cut = truth.t_ns < T0 + 600 * S
    first = _idless_log(truth.select(cut), tmp_path / "first.mcap")
    second = _idless_log(truth.select(~cut), tmp_path / "second.mcap")
    one, shards, both, continued = (tmp_path / f"{k}.aion" for k in
                                    ("one", "shards", "both", "continued"))
    report = build_map(BuildOptions(logs=(log,), output=one, workers=1))
    parallel = build_map(BuildOptions(logs=(log,), output=shards, workers=2))
    assert len(parallel.workers) == 2  # cut at 600 s
    assert report.headings == parallel.headings
    assert report.headings["none"] == 120  # the person standing, and no one else
    assert differences(load_map(one, writable=True).state,
                       load_map(shards, writable=True).state) == []
    build_map(BuildOptions(logs=(first, second), output=both, workers=1))
    build_map(BuildOptions(logs=(first,), output=continued))
    build_map(BuildOptions(logs=(second,), output=continued, continue_from=continued))
    assert differences(load_map(both, writable=True).state,
                       load_map(continued, writable=True).state) == []


def test_two_workers_differ_from_one_only_in_the_last_bits_of_sums_both_shards_add_to(
    tmp_path: Path,
) -> None:
    """Where a parallel build of an id-less log is not byte-identical to one pass, and why:
    linking, the heading hold and every count are exact across the cut (every array but the
    float sums equal byte for byte), and a float sum differs only in an entry and direction
    bin that rows on both sides of the cut add to -- the join adds the shard's sum to the
    earlier map's at once, where one pass adds term by term (docs/SCALING.md, "Joins")."""
    truth = _walkers(_QUIET_AT_600)
    log = _idless_log(truth, tmp_path / "idless.mcap")
    cut = truth.t_ns < T0 + 600 * S
    sides = []
    for name, rows in (("first", cut), ("second", ~cut)):
        out = tmp_path / f"{name}.aion"
        build_map(BuildOptions(logs=(_idless_log(truth.select(rows), tmp_path / f"{name}.mcap"),),
                               output=out, workers=1))
        sides.append(_map_arrays(out))
    one, two = tmp_path / "one.aion", tmp_path / "two.aion"
    build_map(BuildOptions(logs=(log,), output=one, workers=1))
    assert len(build_map(BuildOptions(logs=(log,), output=two, workers=2)).workers) == 2
    a, b = _map_arrays(one), _map_arrays(two)
    sums = ("entry_speed_sum", "entry_heading_cos", "entry_heading_sin")
    assert a.keys() == b.keys()
    assert [k for k in a if k not in sums and k.startswith("entry_")
            and a[k].tobytes() != b[k].tobytes()] == []
    # the entries and bins that rows of both sides add to: those holding more than either
    # side's map alone (a cell or a place: one pass may move a side's cell into a place,
    # which only makes more of them count as both)
    counts = a["entry_counts"]
    alone = []
    for side in sides:
        where = {(int(kd), int(nd) if kd else int(k)): i for i, (kd, k, nd) in
                 enumerate(zip(side["entry_kind"], side["entry_key"], side["entry_node_id"],
                               strict=True))}
        c = np.zeros_like(counts)
        for i, (kd, k, nd) in enumerate(zip(a["entry_kind"], a["entry_key"],
                                            a["entry_node_id"], strict=True)):
            j = where.get((int(kd), int(nd) if kd else int(k)))
            if j is not None:
                c[i] = side["entry_counts"][j]
        alone.append(c)
    both = (counts > alone[0]) & (counts > alone[1])
    assert both.any()  # (a place both shards' walkers pass)
    assert (~both & (counts > 0)).any()
    for k in sums:
        assert np.array_equal(a[k][~both], b[k][~both])  # one side alone: bit for bit
        assert np.allclose(a[k][both], b[k][both], rtol=0, atol=1e-12)
