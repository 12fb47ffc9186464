"""Parents for pooling: which group each entry borrows temporal shape and directions from.

The hierarchy is entry → group → map. A place node whose scene graph gives it a room belongs
to that room; every other entry (unbound hash cells, places without a room) to its
*neighbourhood*, the square of ``pool_size`` metres (``ModelConfig.pool_size``) around it on
a grid aligned to the origin. Groups are recomputed from the current graph whenever they are
needed, so they follow loop closures and re-segmented rooms.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aion_cli.engine.grouping import lexicographic_ranks
from aion_cli.engine.types import F64, I64, U64

_NODE = 1


def entry_groups(
    kind: npt.NDArray[np.int8],
    node_id: U64,
    xyz: F64,
    place_ids: U64,
    place_parent: U64,
    pool_size: float,
) -> tuple[I64, int]:
    """Group index 0..G-1 of each entry and G. Rooms first (by id), then neighbourhoods
    (by cell), so the numbering is deterministic."""
    n = len(kind)
    room = np.zeros(n, dtype=np.uint64)
    if len(place_ids) and n:
        order = np.argsort(place_ids)
        ids, parents = place_ids[order], place_parent[order]
        pos = np.minimum(np.searchsorted(ids, node_id), len(ids) - 1)
        found = (ids[pos] == node_id) & (kind == _NODE)
        room = np.where(found, parents[pos], np.uint64(0)).astype(np.uint64)
    in_room = room != 0
    cell = np.floor(np.nan_to_num(xyz[:, :2]) / float(pool_size)).astype(np.int64)
    # rooms as (0, id) and neighbourhoods as (1, cx, cy): one lexicographic numbering
    keys = np.column_stack(
        [
            (~in_room).astype(np.int64),
            np.where(in_room, room.view(np.int64), cell[:, 0]),
            np.where(in_room, 0, cell[:, 1]),
        ]
    )
    return lexicographic_ranks(keys)  # (no rows: none and 0)
