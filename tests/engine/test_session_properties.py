"""Properties of stop 69's session handling: ``Mapper.begin_session`` (another Hydra session's
graph: every node entry released to its hash cell, the graph forgotten) conserves every
detection, and ``tf_trees.overlap_groups`` (which recordings are at once) groups spans into
the connected components of their overlaps, numbered in time order, for any uint64 times."""

from __future__ import annotations

import random

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from aion_cli.engine.config import ModelConfig
from aion_cli.engine.mapper import Mapper
from aion_cli.tf_trees import overlap_groups, overlapping
from tests.engine.engine_builders import (
    T0_DAY_END,
    S,
    check_invariants,
    feed_detect,
    graph,
    start_fed_mapper,
)
from tests.engine.test_ownership import POOL, _totals

# -- Mapper.begin_session ---------------------------------------------------------------------
op = st.one_of(
    st.tuples(st.just("detect"), st.integers(1, 30), st.integers(0, 10**6)),
    # the same session's graph: toggle one pool node (or none: -1), shift every node
    st.tuples(st.just("graph"), st.integers(-1, 4), st.sampled_from([0.0, 0.1, 2.0])),
    # another session: its graph comes this many seconds after the last step (negative: a
    # log of the next group whose first graph is stamped before the last detections read),
    # holding the pool's ids at places shifted by the offset (0: the same places)
    st.tuples(st.just("session"), st.integers(-90, 900), st.sampled_from([0.0, 0.3, 5.0])),
    st.tuples(st.just("wait"), st.integers(1, 400), st.just(0.0)),
)


def _directions(m: Mapper) -> np.ndarray:
    """Σ cos, Σ sin of the live entries' heading sums."""
    ent = m.state.entries
    live = ent.live_rows()
    return np.array([ent.heading_cos[live].sum(), ent.heading_sin[live].sum()])


@given(st.lists(op, min_size=2, max_size=14), st.booleans())
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_a_session_change_accounts_for_every_detection(
    ops: list[tuple[str, int, float]], robot: bool
) -> None:
    """Whatever came before and after (detections, graphs of either session, waits across a
    day's end): ``begin_session`` releases every node entry (those before it and those the
    windows it closes bind) and forgets the graph; the detections accepted are all still
    counted, each once (closed, pending or in the open window; the ownership invariants of
    DESIGN.md §4), with their heading sums, and nothing is counted that was not accepted. A
    robot's poses or a fixed sensor observe."""
    cfg = ModelConfig(stability_s=10.0, window_s=60.0, cell_size=0.5, bind_radius=1.0)
    start = T0_DAY_END - 300 * S  # five minutes before midnight: many sequences close a day
    m = start_fed_mapper(cfg, start, robot, 3000, 10**5, POOL)
    present = np.ones(len(POOL), bool)
    t, accepted, walked = start, 0, np.zeros(2)
    for kind, a, b in ops:
        t += 7 * S
        if kind == "detect":
            taken, turned = feed_detect(m, t, int(a), b)
            accepted += taken
            walked += turned  # NaN from a drop on: stop checking
        elif kind == "graph":
            if int(a) >= 0:
                present[int(a)] = ~present[int(a)]
            idx = np.flatnonzero(present)
            m.add_graph(graph(t, idx.tolist(), POOL[idx] + float(b)))
        elif kind == "session":
            at = t + int(a) * S
            state = m.state
            nodes = len(state.entries.node_rows())
            total, directions = sum(_totals(state)), _directions(m)
            released = m.begin_session(at)
            assert released >= nodes  # and those of cells bound as the closed windows ended
            assert len(state.entries.node_rows()) == 0
            assert state.graph is None
            assert len(state.redirects) == 0
            assert len(state.nodes.ids) == 0
            assert sum(_totals(state)) == total  # closing windows and releasing move counts
            np.testing.assert_allclose(_directions(m), directions, rtol=0, atol=1e-9)
            t = max(t, at)
            present[:] = True  # the new session's graph: the pool's ids at other places
            m.add_graph(graph(t, list(range(len(POOL))), POOL + float(b)))
            event(f"session change released {min(released, 2)}+ nodes")
        else:
            t += int(a) * S
            m.advance(t)
        assert m.state.accepted == accepted
        check_invariants(m.state)
        if np.isfinite(walked).all():
            np.testing.assert_allclose(_directions(m), walked, rtol=0, atol=1e-9)


# -- tf_trees.overlap_groups ------------------------------------------------------------------
U64 = 2**64 - 1


def _components(spans: dict[int, tuple[int, int]]) -> set[frozenset[int]]:
    """The connected components of "overlaps": two spans overlap when each starts before the
    other ends (sharing more than an instant, or a one-instant span strictly inside another);
    pairwise, with a union-find (an oracle apart from the sweep under test)."""
    keys = list(spans)
    parent = {k: k for k in keys}

    def root(k: int) -> int:
        while parent[k] != k:
            k = parent[k]
        return k

    for i, a in enumerate(keys):
        for b in keys[i + 1 :]:
            (lo_a, hi_a), (lo_b, hi_b) = spans[a], spans[b]
            if lo_a < hi_b and lo_b < hi_a:
                parent[root(a)] = root(b)
    out: dict[int, set[int]] = {}
    for k in keys:
        out.setdefault(root(k), set()).add(k)
    return {frozenset(group) for group in out.values()}


def _span(bound: int) -> st.SearchStrategy[tuple[int, int]]:
    return st.tuples(st.integers(0, bound), st.integers(0, bound)).map(lambda p: (min(p), max(p)))


spans_strategy = st.one_of(
    # small times: many ties, touching ends and one-instant spans
    st.dictionaries(st.integers(-5, 40), _span(12), max_size=12),
    # uint64 log times (MCAP), past 2^63 and up to its largest
    st.dictionaries(st.integers(0, 10**6), _span(U64), max_size=8),
    st.dictionaries(
        st.integers(0, 50), _span(40).map(lambda p: (U64 - 40 + p[0], U64 - 40 + p[1])), max_size=8
    ),
)


@given(spans_strategy, st.randoms(use_true_random=False))
@settings(max_examples=600, deadline=None)
def test_overlap_groups_are_the_components_of_overlapping_spans(
    spans: dict[int, tuple[int, int]], rnd: random.Random
) -> None:
    """Every key gets a group; the groups are the connected components of the overlaps;
    they are numbered 0, 1, ... in time order (a group's spans all start at or after the end
    of every span of the groups before it); the input's order does not change them; and
    :func:`overlapping` names exactly the keys of groups of two or more."""
    groups = overlap_groups(spans)
    assert set(groups) == set(spans)
    found: dict[int, set[int]] = {}
    for key, group in groups.items():
        found.setdefault(group, set()).add(key)
    assert {frozenset(g) for g in found.values()} == _components(spans)
    assert sorted(found) == list(range(len(found)))
    for g in range(1, len(found)):
        assert min(spans[k][0] for k in found[g]) >= max(spans[k][1] for k in found[g - 1])
        assert all(spans[k][0] >= spans[j][1] for k in found[g] for j in found[g - 1])
    shuffled = list(spans.items())
    rnd.shuffle(shuffled)
    again = overlap_groups(dict(shuffled))
    assert {frozenset(k for k in again if again[k] == g) for g in set(again.values())} == {
        frozenset(g) for g in found.values()
    }
    # numbered by time: the same numbers whatever the order, except among spans that are
    # one-instant and equal (each its own group; their order among themselves is the input's)
    tied = {
        k for k, (lo, hi) in spans.items() if lo == hi and list(spans.values()).count((lo, hi)) > 1
    }
    assert {k: g for k, g in again.items() if k not in tied} == {
        k: g for k, g in groups.items() if k not in tied
    }
    several = sorted(k for g in found.values() if len(g) > 1 for k in g)
    assert overlapping(spans) == several
    if any(len(g) > 1 for g in found.values()):
        event("some spans overlap")
    if any(hi > 2**63 for _, hi in spans.values()):
        event("times past 2^63")
