"""``Redirects`` with a pending table (stop 66): every add, lookup, drop and read gives what
the redirect table before it gave (a verbatim copy below: each add copied the whole sorted
table), with the pending table merged at its threshold and on a read of ``keys`` /
``nodes``; a map's redirects (the arrays it saves) come out the same."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aion_cli.engine import nodes as nodes_module
from aion_cli.engine.grouping import insert_sorted
from aion_cli.engine.nodes import Redirects
from aion_cli.engine.types import I64, U64, BoolA


@dataclass
class RedirectsBefore:
    """φ: cell ``keys`` (sorted, unique) -> owning ``nodes`` (node ids)."""

    keys: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    nodes: U64 = field(default_factory=lambda: np.zeros(0, np.uint64))

    def __len__(self) -> int:
        return len(self.keys)

    def add(self, keys: I64, nodes: U64) -> None:
        """Record new redirects (keys must not be redirected already: ``ValueError``, the
        table left as it was).

        The new keys are merged into the sorted table where they belong: the stable sort of
        old and new keys together, without sorting the whole table again at every bind
        (issue 15: a live graph binds cells at most of its updates, against tens of thousands
        of redirects). A repeated key is looked for only where it could be: among the new
        keys, sorted, side by side, and in the old key just before each new key's place (the
        ``side="right"`` search puts a new key after an equal old one), so the check costs
        O(new keys · log table) instead of a pass over the whole table at every bind."""
        new_keys = np.asarray(keys, dtype=np.int64)
        new_nodes = np.asarray(nodes, dtype=np.uint64)
        if new_keys.size > 1 and not bool(np.all(new_keys[1:] >= new_keys[:-1])):
            order = np.argsort(new_keys, kind="stable")
            new_keys, new_nodes = new_keys[order], new_nodes[order]
        at = np.searchsorted(self.keys, new_keys, side="right")
        after = at > 0
        if bool(np.any(new_keys[1:] == new_keys[:-1])) or bool(
            np.any(self.keys[at[after] - 1] == new_keys[after])
        ):
            raise ValueError("a cell key was redirected twice")
        self.keys = insert_sorted(self.keys, at, new_keys)
        self.nodes = insert_sorted(self.nodes, at, new_nodes)

    def drop_nodes(self, node_ids: U64) -> None:
        """Forget every redirect to the given nodes."""
        keep = ~np.isin(self.nodes, node_ids)
        self.keys, self.nodes = self.keys[keep], self.nodes[keep]

    def lookup(self, keys: I64) -> tuple[U64, BoolA]:
        """Node ids for ``keys`` and a found mask (0 where not redirected)."""
        if len(self.keys) == 0:
            return np.zeros(len(keys), np.uint64), np.zeros(len(keys), bool)
        pos = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        found = self.keys[pos] == keys
        return np.where(found, self.nodes[pos], np.uint64(0)).astype(np.uint64), found


OPS = st.lists(
    st.tuples(st.sampled_from(["add", "add", "add", "lookup", "drop", "read"]),
              st.integers(0, 40), st.booleans(), st.integers(0, 2**31 - 1)),
    min_size=1, max_size=30,
)  # fmt: skip


@pytest.mark.parametrize("pending", [1, 8, 4096])
@given(ops=OPS)
@settings(max_examples=150, deadline=None)
def test_the_pending_table_gives_what_the_sorted_table_gave(
    pending: int, ops: list[tuple[str, int, bool, int]]
) -> None:
    """Adds of fresh keys (sorted or not), of keys redirected already or given twice (which
    raise, the table unchanged), lookups of keys in and out of the table, drops of nodes
    and reads of the arrays, in any order, with the pending table merged after 1, 8 or
    4,096 keys: the same outcome and the same table at every step."""
    mp = pytest.MonkeyPatch()
    mp.setattr(nodes_module, "PENDING", pending)
    try:
        new, old = Redirects(), RedirectsBefore()
        for op, size, flag, seed in ops:
            rng = np.random.default_rng(seed)
            if op == "add":
                keys = rng.choice(np.arange(-300, 300), size=size, replace=False).astype(np.int64)
                if flag and len(old.keys) and size:  # a key redirected already
                    keys[0] = rng.choice(old.keys)
                if not flag and size > 2 and seed % 5 == 0:  # a key twice among the new
                    keys[-1] = keys[0]
                if seed % 2:
                    keys = np.sort(keys)
                nodes = rng.integers(1, 50, size).astype(np.uint64)
                said = []
                for red in (new, old):
                    try:
                        red.add(keys, nodes)
                        said.append(None)
                    except ValueError as exc:
                        said.append(str(exc))
                assert said[0] == said[1]
                if said[1] is not None:  # the reference is left broken: start again
                    new, old = Redirects(), RedirectsBefore()
            elif op == "lookup":
                keys = rng.integers(-320, 320, size).astype(np.int64)
                got, want = new.lookup(keys), old.lookup(keys)
                assert got[0].dtype == want[0].dtype == np.uint64
                assert np.array_equal(got[0], want[0])
                assert np.array_equal(got[1], want[1])
            elif op == "drop":
                drop = rng.integers(1, 50, size % 6).astype(np.uint64)
                new.drop_nodes(drop)
                old.drop_nodes(drop)
            assert len(new) == len(old)
            if op == "read" or flag:
                assert new.keys.dtype == old.keys.dtype
                assert new.nodes.dtype == old.nodes.dtype
                assert np.array_equal(new.keys, old.keys)
                assert np.array_equal(new.nodes, old.nodes)
        saved = new.to_arrays()
        assert np.array_equal(saved["redirect_keys"], old.keys)
        assert np.array_equal(saved["redirect_nodes"], old.nodes)
    finally:
        mp.undo()


def test_adds_stay_pending_until_the_threshold_or_a_read() -> None:
    """5,000 single adds into a table of 10^6 keys: merged when the pending keys pass
    4 · √10^6 = 4,000 (more than PENDING), not at every add; a read merges the rest."""
    base = np.arange(0, 2_000_000, 2, dtype=np.int64)
    red = Redirects(base, np.ones(len(base), np.uint64))
    for k in range(5_000):
        red.add(np.array([2 * k + 1], np.int64), np.array([7], np.uint64))
    assert len(red._pending_keys) == 5_000 - 4_001  # merged once, at the 4,001st
    assert len(red) == 1_005_000
    found = red.lookup(np.array([1, 9_999, 9_998, 10_001], np.int64))
    assert found[0].tolist() == [7, 7, 1, 0]
    assert found[1].tolist() == [True] * 3 + [False]
    assert np.array_equal(red.keys[:10_001], np.arange(10_001))
    assert len(red._pending_keys) == 0
