"""Whether two map states hold the same map, whatever their in-memory row layout.

Used to prove that the fast or parallel paths give the maps of the plain sequential one (tests,
``benchmarks/bench_parallel.py``): the states are compared as saved (``MapState.to_arrays``,
canonical entry order) with the pending day's (entry, slot) pairs sorted, metadata and integer
members exactly, float members to ``rtol``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from aion_cli.engine.state import MapState


def plain(arrays: dict[str, Any]) -> dict[str, np.ndarray]:
    """Every member as a numpy array (temporal members are streamed row blocks)."""
    return {name: np.asarray(value) for name, value in arrays.items()}


def pending_sorted(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The pending day's (entry position, slot) pairs sorted by position, then slot: the
    content of the day independent of the order it was written in."""
    out = dict(arrays)
    for kind, extra in (("obs", ()), ("cnt", ("cnt_values",))):
        entry, slot = arrays[f"pending_{kind}_entry"], arrays[f"pending_{kind}_slot"]
        order = np.lexsort((slot, entry))
        for name in (f"{kind}_entry", f"{kind}_slot", *extra):
            out["pending_" + name] = arrays["pending_" + name][order]
    return out


def differences(a: MapState, b: MapState, rtol: float = 1e-12) -> list[str]:
    """What differs between the two maps (empty: the same map), one line per member."""
    xa, ma = a.to_arrays()
    xb, mb = b.to_arrays()
    out = [f"meta {k}: {ma.get(k)!r} != {mb.get(k)!r}" for k in sorted(set(ma) | set(mb))
           if ma.get(k) != mb.get(k)]
    if sorted(xa) != sorted(xb):
        out.append(f"members differ: {sorted(set(xa) ^ set(xb))}")
        return out
    pa, pb = pending_sorted(plain(xa)), pending_sorted(plain(xb))
    for name in sorted(pa):
        u, v = pa[name], pb[name]
        if u.dtype != v.dtype or u.shape != v.shape:
            out.append(f"{name}: {u.dtype}{u.shape} != {v.dtype}{v.shape}")
        elif u.dtype.kind in "fc":
            if not np.allclose(u, v, rtol=rtol, atol=0, equal_nan=True):
                bad = int(np.count_nonzero(~np.isclose(u, v, rtol=rtol, atol=0, equal_nan=True)))
                out.append(f"{name}: {bad} of {u.size} values differ beyond rtol {rtol:g}")
        elif not np.array_equal(u, v):
            out.append(f"{name}: {int(np.count_nonzero(u != v))} of {u.size} values differ")
    return out
