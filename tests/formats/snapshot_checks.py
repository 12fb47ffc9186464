"""Equality of two decoded scene graphs (:class:`aion_cli.engine.types.GraphSnapshot`), member
by member with dtypes, for the tests that decode one graph two ways."""

from __future__ import annotations

import numpy as np

from aion_cli.engine.types import GraphSnapshot, Layer


def _layers_equal(a: Layer, b: Layer) -> None:
    assert a.ids.dtype == b.ids.dtype
    np.testing.assert_array_equal(a.ids, b.ids)
    np.testing.assert_array_equal(a.xyz, b.xyz)
    assert a.xyz.dtype == b.xyz.dtype
    np.testing.assert_array_equal(a.parent, b.parent)
    assert a.labels == b.labels
    assert all(type(x) is str for x in a.labels)


def assert_same_snapshot(a: GraphSnapshot, b: GraphSnapshot) -> None:
    """Equal snapshots: every layer's ids, positions, parents and labels, the edges, layer
    name, time and agents, with the same dtypes."""
    for name in ("places", "rooms", "buildings"):
        _layers_equal(getattr(a, name), getattr(b, name))
    np.testing.assert_array_equal(a.edges, b.edges)
    assert a.edges.dtype == b.edges.dtype
    assert a.layer_name == b.layer_name
    assert a.t_ns == b.t_ns
    assert (a.agents is None) == (b.agents is None)
    if a.agents is not None and b.agents is not None:
        np.testing.assert_array_equal(a.agents.t_ns, b.agents.t_ns)
        np.testing.assert_array_equal(a.agents.xyz, b.agents.xyz)
