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
from aion_cli.engine.types import F64, I64, U64, Layer

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
    return lexicographic_ranks(group_keys(room, xyz, pool_size))  # (no rows: none and 0)


def group_keys(room: U64, xyz: F64, pool_size: float) -> I64:
    """The group key of each entry (or place) with room ``room`` (0: none) at ``xyz``,
    int64[N, 3]: ``(0, room, 0)`` in a room, ``(1, cx, cy)`` (its neighbourhood) otherwise;
    :func:`entry_groups` numbers them in lexicographic order."""
    parent = np.asarray(room, np.uint64)
    in_room = parent != 0
    cell = np.floor(np.nan_to_num(np.asarray(xyz, np.float64)[:, :2]) / float(pool_size))
    cell = cell.astype(np.int64)
    return np.column_stack(
        [
            (~in_room).astype(np.int64),
            np.where(in_room, parent.view(np.int64), cell[:, 0]),
            np.where(in_room, 0, cell[:, 1]),
        ]
    )


def groups_moved(before: tuple[U64, I64], after: tuple[U64, I64]) -> bool:
    """Whether any place in both ``(ids, keys)`` (ids sorted, keys of :func:`group_keys`)
    changed its group: another room, or another neighbourhood."""
    ids_a, keys_a = before
    ids_b, keys_b = after
    if ids_a.size == 0 or ids_b.size == 0:
        return False
    at = np.minimum(np.searchsorted(ids_b, ids_a), ids_b.size - 1)
    both = ids_b[at] == ids_a
    return bool((keys_a[both] != keys_b[at[both]]).any())


def sorted_group_keys(places: Layer, pool_size: float) -> tuple[U64, I64]:
    """A place layer's ids, sorted, and the group key of each (:func:`group_keys`)."""
    order = np.argsort(places.ids, kind="stable")
    ids = np.asarray(places.ids, np.uint64)[order]
    return ids, group_keys(
        np.asarray(places.parent, np.uint64)[order], places.xyz[order], pool_size
    )
