"""Aggregation up the scene graph: places -> rooms -> buildings.

Counts and expected counts are additive, so a room's dynamics are the sum of its places' (and a
building's the sum of its rooms'). Descriptors are then recomputed from the sums.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

F64 = npt.NDArray[np.float64]
U64 = npt.NDArray[np.uint64]


def aggregate(parent: npt.ArrayLike, values: npt.ArrayLike) -> tuple[U64, F64]:
    """Sum ``values[E, ...]`` per parent id; rows whose parent is 0 (none) are skipped.

    Returns the distinct parent ids in increasing order, ``uint64[P]``, and the sums
    ``float64[P, ...]`` (NaN in a value propagates into its parent's sum).
    """
    par = np.asarray(parent, dtype=np.uint64).reshape(-1)
    val = np.asarray(values, dtype=np.float64)
    if val.shape[:1] != par.shape:
        raise ValueError(f"values must have {par.size} rows, got shape {val.shape}")
    keep = par != 0
    ids, inverse = np.unique(par[keep], return_inverse=True)
    sums = np.zeros((ids.size, *val.shape[1:]))
    np.add.at(sums, inverse, val[keep])
    return ids.astype(np.uint64), sums
