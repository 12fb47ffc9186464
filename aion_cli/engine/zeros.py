"""Zero arrays that take memory only where they are written, a small page at a time.

The temporal accumulators are dense per entry row (``[R, V, K]``) but written sparsely: a
map's capacity reserved for new entries, or a query's state whose rows are filled by the
pending day's scattered counts. ``np.zeros`` asks the kernel for huge pages on arrays of a few
MB and more (``madvise(MADV_HUGEPAGE)``), so the first write to any row backs the 2 MB around
it — and where free memory is fragmented the kernel compacts memory to find each one: a
query scattering counts over a map of 100k entries spent 7–14 s there. :func:`lazy_zeros`
maps the same zeros privately and asks for no huge pages: a write backs its 4 KB page only.
"""

from __future__ import annotations

import mmap
from typing import Any

import numpy as np
import numpy.typing as npt

_SMALL = 1 << 22
"""Bytes below which numpy asks for no huge pages either: plain ``np.zeros``."""


def lazy_zeros(shape: int | tuple[int, ...], dtype: npt.DTypeLike = np.float64) -> Any:
    """``np.zeros(shape, dtype)``, backed by memory only in the small pages written (no huge
    pages); a plain ``np.zeros`` under 4 MB or where anonymous private maps are unknown."""
    dt = np.dtype(dtype)
    dims = (shape,) if isinstance(shape, int) else tuple(shape)
    size = int(np.prod(dims, dtype=np.int64)) * dt.itemsize
    private = getattr(mmap, "MAP_PRIVATE", None)
    anonymous = getattr(mmap, "MAP_ANONYMOUS", None)
    if size < _SMALL or private is None or anonymous is None:
        return np.zeros(dims, dt)
    buffer = mmap.mmap(-1, size, flags=private | anonymous)  # private: not shared on fork
    no_huge = getattr(mmap, "MADV_NOHUGEPAGE", None)
    if no_huge is not None:
        buffer.madvise(no_huge)
    return np.frombuffer(buffer, dt).reshape(dims)
