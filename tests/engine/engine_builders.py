"""Small builders and invariant checks shared by the mapper / ownership / state tests."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.entries import CELL, NODE
from aion_cli.engine.state import MapState
from aion_cli.engine.types import DetectionBatch, GraphSnapshot, Layer

S = 1_000_000_000
T0 = 1_700_000_400 * S  # a window start for 600 s and 60 s windows (1_700_000_400 % 600 == 0)
DAY_NS = 86_400 * S
# T0 is 2023-11-14 22:20 UTC (a Tuesday): the local (UTC) day ends 100 minutes later
T0_DAY_END = (T0 // DAY_NS + 1) * DAY_NS


def pid(index: int | npt.ArrayLike, category: str = "p") -> np.ndarray:
    """spark_dsg NodeSymbol ids."""
    return (np.uint64(ord(category)) << np.uint64(56)) | np.asarray(index, dtype=np.uint64)


def graph(
    t_ns: int,
    indices: list[int],
    xyz: npt.ArrayLike,
    parents: list[int] | None = None,
    rooms: Layer | None = None,
    buildings: Layer | None = None,
) -> GraphSnapshot:
    ids = pid(np.array(indices, dtype=np.uint64)) if indices else np.zeros(0, np.uint64)
    par = np.zeros(len(indices), np.uint64) if parents is None else pid(parents, "R")
    places = Layer(ids.astype(np.uint64), np.asarray(xyz, float).reshape(-1, 3), par)
    return GraphSnapshot(
        int(t_ns),
        places,
        np.zeros((0, 2), np.int64),
        rooms if rooms is not None else Layer.empty(),
        buildings if buildings is not None else Layer.empty(),
    )


def detections(
    t_ns: npt.ArrayLike,
    xyz: npt.ArrayLike,
    heading: npt.ArrayLike | None = None,
    speed: npt.ArrayLike | None = None,
) -> DetectionBatch:
    t = np.atleast_1d(np.asarray(t_ns, dtype=np.int64))
    p = np.asarray(xyz, dtype=float).reshape(-1, 3)
    if len(t) == 1 and len(p) > 1:
        t = np.full(len(p), t[0])
    h = np.zeros(len(p)) if heading is None else heading
    return DetectionBatch.from_arrays(t, p, h, speed)


# -- where the detections of a map are ------------------------------------------------------
def closed_counts(state: MapState, rows: npt.ArrayLike) -> np.ndarray:
    """Detections per value bin (B directions, then "no heading") absorbed into the temporal
    accumulators of entries ``rows``: Σ over profile bins of ``cnt_profile``, float64[r, V]."""
    r = np.asarray(rows, dtype=np.int64)
    out: np.ndarray = state.temporal.cnt_profile[r].sum(axis=2)
    return out


def pending_counts(state: MapState) -> np.ndarray:
    """Detections per entry row and value bin held in the pending day, float64[capacity, V]."""
    out = np.zeros((state.temporal.n_rows, state.params.values))
    if state.pending:
        day = state.pending.consolidated()
        np.add.at(out, day.cnt_entry, day.cnt_values)
    return out


def open_counts(state: MapState) -> np.ndarray:
    """Detections per entry row and value bin in the open window, float64[capacity, V]."""
    ent = state.entries
    return np.column_stack([ent.window_counts, ent.window_nodir])


def temporal_detections(state: MapState) -> float:
    """Σ over live entries of ``cnt_profile`` + the pending day's counts + the open window's:
    every accepted detection must be in exactly one of the three."""
    rows = state.entries.live_rows()
    closed = float(closed_counts(state, rows).sum())
    return closed + float(pending_counts(state)[rows].sum()) + float(open_counts(state)[rows].sum())


def check_invariants(state: MapState) -> None:
    """The ownership invariants of DESIGN.md §4 and the temporal model's conservation
    (raises AssertionError)."""
    ent = state.entries
    assert ent.total_count() == state.accepted
    assert temporal_detections(state) == state.accepted, "temporal counts not conserved"
    cells, nodes = ent.cell_rows(), ent.node_rows()
    cell_keys = ent.key[cells]
    node_ids = ent.node_id[nodes]
    assert len(np.unique(cell_keys)) == len(cell_keys), "duplicate cell entry"
    assert len(np.unique(node_ids)) == len(node_ids), "duplicate node entry"
    assert not np.isin(state.redirects.keys, cell_keys).any(), "redirected key has a cell"
    assert np.isin(state.redirects.nodes, node_ids).all(), "redirect to a node without entry"
    assert np.isin(state.redirects.nodes, state.nodes.ids).all(), "redirect to a dead node"
    assert np.isin(node_ids, state.nodes.ids).all(), "entry of a vanished node"
    assert np.all(ent.kind[cells] == CELL)
    assert np.all(ent.kind[nodes] == NODE)
    live = ent.live_rows()
    free = np.setdiff1d(np.arange(ent.n), live)
    tmp = state.temporal
    assert tmp.n_rows >= ent.capacity
    assert tmp.obs.n[free].sum() == 0, "a free row keeps observations"
    assert tmp.cnt_profile[free].sum() == 0, "a free row keeps counts"
    assert not np.any(tmp.cnt_fourier[free]), "a free row keeps Fourier counts"
    assert tmp.flow_scored[free].sum() == 0, "a free row keeps scores"
    assert ent.counts[free].sum() == 0
    assert not ent.heading_cos[free].any(), "a free row keeps heading sums"
    assert not ent.heading_sin[free].any(), "a free row keeps heading sums"
    if state.pending:
        assert np.isin(state.pending.entries(), live).all(), "the pending day names a free row"


def feed_bursts(
    m: Any, rng: np.random.Generator, start: int, end: int, gap_s: tuple[int, int]
) -> dict[str, np.ndarray]:
    """Feed mapper ``m`` from ``start`` to ``end``: after a gap of ``gap_s`` seconds (drawn),
    a burst of up to 39 detections (60 % of the time) and a graph whose 12 nodes come, go and
    move (50 %); then advance to ``end`` and return the state's arrays."""
    pool = np.c_[rng.uniform(-6, 6, (12, 2)), rng.choice([0.0, 3.0], 12)]
    present = rng.random(12) < 0.7
    t = start
    while t < end - 700 * S:
        t += int(rng.integers(*gap_s)) * S
        if rng.random() < 0.6:
            n = int(rng.integers(1, 40))
            xyz = np.c_[rng.uniform(-7, 7, (n, 2)), rng.choice([0.0, 3.0], n)]
            stamps = t + rng.integers(0, 60 * S, n)
            heading = np.where(rng.random(n) < 0.2, np.nan, rng.uniform(-np.pi, np.pi, n))
            m.add_detections(detections(np.sort(stamps), xyz, heading, rng.uniform(0, 2, n)))
        if rng.random() < 0.5:
            flip = rng.random(12) < 0.1
            present ^= flip
            pool[rng.random(12) < 0.05, :2] += rng.normal(0, 1.0, 2)
            idx = np.flatnonzero(present)
            m.add_graph(graph(t + 61 * S, idx.tolist(), pool[idx]))
            t += 61 * S
    m.advance(end)
    arrays, _meta = m.state.to_arrays()
    return {k: np.asarray(v) for k, v in arrays.items()}


def start_fed_mapper(
    cfg: Any, start: int, robot: bool, robot_s: int, fixed_s: int, pool: np.ndarray
) -> Any:
    """The property tests' mapper before their operations: a robot driving along x from −1
    to 3 m over ``robot_s`` seconds (a pose every 5 s), or a fixed sensor watching for
    ``fixed_s`` seconds, from ``start``; and a first graph of every place of ``pool``."""
    from aion_cli.engine.mapper import Mapper
    from aion_cli.engine.types import Trajectory

    m = Mapper(cfg)
    if robot:
        t = np.arange(start, start + robot_s * S, 5 * S, dtype=np.int64)
        xyz = np.c_[np.linspace(-1, 3, t.size), np.zeros(t.size), np.zeros(t.size)]
        m.add_trajectory(Trajectory(t, xyz))
    else:
        m.set_fixed_sensor(start, start + fixed_s * S)
    m.add_graph(graph(start, list(range(len(pool))), pool))
    return m


def feed_detect(m: Any, t: int, n: int, seed: float) -> tuple[int, np.ndarray]:
    """The property tests' ``detect`` operation: ``n`` detections at ``t`` drawn with ``seed``
    over the 4 m square of their places on two floors, a fifth without a heading. Returns the
    number the mapper accepted and the [Σ cos, Σ sin] of their headings, which the tests
    follow through the map; NaN where any was dropped (which rows is not said)."""
    rng = np.random.default_rng(int(seed))
    xyz = np.c_[rng.uniform(-1, 3, (n, 2)), rng.choice([0.0, 3.0], n)]
    heading = np.where(rng.random(n) < 0.2, np.nan, rng.uniform(-np.pi, np.pi, n))
    drops = m.add_detections(detections(t, xyz, heading, rng.uniform(0, 2, n)))
    directed = heading[np.isfinite(heading)]
    walked = np.array([np.cos(directed).sum(), np.sin(directed).sum()])
    taken = n - sum(drops.values())
    return taken, walked if taken == n else np.full(2, np.nan)


def assert_temporal_unchanged(before: Any, after: Any) -> None:
    """Every accumulator of two temporal states (:class:`TemporalState`), the global and
    observation blocks included, the same bits."""
    for name in ("cnt_fourier", "cnt_profile", "flow_score", "dir_score", "window_chi2",
                 "day_level", "week_sums"):  # fmt: skip
        assert getattr(after, name).tobytes() == getattr(before, name).tobytes(), name
    for block in ("obs", "glob"):
        for field in ("n", "fourier", "profile", "first", "last"):
            old, new = getattr(getattr(before, block), field), getattr(getattr(after, block), field)
            assert new.tobytes() == old.tobytes(), (block, field)
