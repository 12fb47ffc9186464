"""Small builders and invariant checks shared by the mapper / ownership / state tests."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.entries import CELL, NODE, fremen_rows
from aion_cli.engine.state import MapState
from aion_cli.engine.types import DetectionBatch, GraphSnapshot, Layer

S = 1_000_000_000
T0 = 1_700_000_400 * S  # a window start for 600 s and 60 s windows (1_700_000_400 % 600 == 0)


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


def activity_n(state: MapState) -> float:
    """Σ n over every activity row of live entries (FreMEn observations absorbed)."""
    rows = fremen_rows(state.entries.live_rows(), state.bins)[:, 0]
    return float(state.fremen.n[rows].sum())


def activity_sum_s(state: MapState) -> float:
    rows = fremen_rows(state.entries.live_rows(), state.bins)[:, 0]
    return float(state.fremen.sum_s[rows].sum())


def check_invariants(state: MapState) -> None:
    """The ownership invariants of DESIGN.md §4 (raises AssertionError)."""
    ent = state.entries
    assert ent.total_count() == state.accepted
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
    free = np.setdiff1d(np.arange(ent.n), ent.live_rows())
    assert state.fremen.n[fremen_rows(free, state.bins).ravel()].sum() == 0
    assert ent.counts[free].sum() == 0
