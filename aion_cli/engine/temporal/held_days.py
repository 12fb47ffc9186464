"""A parallel build's shard holds its closed days unscored (:class:`DeferredDays`), for the
join that scores them against every earlier shard's history (:mod:`aion_cli.engine.shards`);
each held day is a :class:`~aion_cli.engine.temporal.pending.PendingDay` with the entries live
when it closed (:class:`HeldDay`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.node_drift import NodeDrift
from aion_cli.engine.temporal.groups import groups_moved
from aion_cli.engine.temporal.pending import PendingDay
from aion_cli.engine.types import F64, I64
from aion_cli.errors import MapCorruptError


@dataclass
class HeldDay:
    """A closed day of a shard, unscored: its windows and the entries live when it closed
    (the population a single pass would have pooled its forecasts over)."""

    pending: PendingDay
    live: I64


@dataclass
class DeferredDays:
    """The closed days of a parallel build's shard, in time order, held for the join that
    scores them against the history of every earlier shard (:mod:`aion_cli.engine.shards`).
    Ownership transfer re-labels them as it does the pending day."""

    days: list[HeldDay] = field(default_factory=list)
    #: the node ids and positions of the shard's first bind check with a stable node: the
    #: graph the earlier shards' cells met first in a single pass
    first_stable: tuple[npt.NDArray[np.uint64], F64] | None = None
    #: the place ids of the first scene graph the shard applied (None: none yet)
    first_graph: npt.NDArray[np.uint64] | None = None
    #: whether that first check came after a held day (its binds came late)
    first_stable_late: bool = False
    #: the keys (sorted) of the cells that checks before it had in reach of places not yet
    #: stable (one pass, with the timers the map before the shard gave them, may have bound
    #: them there)
    unstable_keys: I64 = field(default_factory=lambda: np.zeros(0, np.int64))
    #: every place stable at one of the shard's bind checks (ids sorted) and the box of its
    #: positions at those checks (low, high): where it may have bound cells the map before
    #: the shard had (None: no such check yet, and in part maps of older versions)
    reach: tuple[npt.NDArray[np.uint64], F64, F64] | None = None
    #: whether ownership moved an entry that a held day had live (that day's forecast would
    #: have pooled over the entries as they were then: the join cannot be exact)
    moved_after_hold: bool = False
    #: how the nodes of the shard's first graph moved until their timers first restarted
    #: (:mod:`aion_cli.engine.node_drift`; None before a graph, and in part maps of older
    #: versions)
    drift: NodeDrift | None = None
    #: the places' group keys (ids sorted, :func:`~aion_cli.engine.temporal.groups.group_keys`)
    #: of the last graph since a day was held (None: no day held under a graph yet)
    group_keys: tuple[npt.NDArray[np.uint64], I64] | None = None
    #: whether a place changed its pooling group (room, or neighbourhood) after a day was
    #: held: that day's forecast pooled over the groups as they were then (not exact)
    groups_changed_after_hold: bool = False
    #: whether a day was held before the shard's first graph (one pass pooled it by the
    #: graph of the map before the shard: the join compares that graph's groups)
    held_before_graph: bool = False

    def hold(
        self, pending: PendingDay, live: I64, keys: tuple[npt.NDArray[np.uint64], I64] | None
    ) -> None:
        """Hold a closed day: its windows, the entries live at its close, and the places'
        group keys then (``keys``; None without a graph)."""
        self.days.append(HeldDay(pending, np.asarray(live, np.int64).copy()))
        if keys is None:
            self.held_before_graph = True
        elif self.group_keys is None:
            self.group_keys = keys

    def graph_groups(self, keys: tuple[npt.NDArray[np.uint64], I64]) -> None:
        """A new graph's group keys (asked for once :attr:`group_keys` is set, i.e. after a
        day was held under a graph): a place that changed its group since the graph before
        marks the join as not exact."""
        if self.group_keys is not None and groups_moved(self.group_keys, keys):
            self.groups_changed_after_hold = True
        self.group_keys = keys

    def remember_stable(self, ids: npt.NDArray[np.uint64], xyz: F64) -> None:
        """The shard's first bind check with a stable node (see :attr:`first_stable`)."""
        if self.first_stable is None:
            self.first_stable = (ids.copy(), xyz.copy())
            self.first_stable_late = bool(self.days)

    def checked_stable(self, ids: npt.NDArray[np.uint64], xyz: F64) -> None:
        """A bind check with the places ``ids`` (sorted) stable at ``xyz``: their boxes of
        :attr:`reach` take these positions in."""
        if ids.size == 0:
            return
        if self.reach is None:
            self.reach = (ids.copy(), xyz.copy(), xyz.copy())
            return
        known, low, high = self.reach
        if np.array_equal(known, ids):  # the usual check: the same places
            np.minimum(low, xyz, out=low)
            np.maximum(high, xyz, out=high)
            return
        at = np.minimum(np.searchsorted(known, ids), known.size - 1)
        old = known[at] == ids
        low[at[old]] = np.minimum(low[at[old]], xyz[old])
        high[at[old]] = np.maximum(high[at[old]], xyz[old])
        if not old.all():
            new_ids = np.concatenate([known, ids[~old]])
            order = np.argsort(new_ids, kind="stable")
            self.reach = (
                new_ids[order],
                np.concatenate([low, xyz[~old]])[order],
                np.concatenate([high, xyz[~old]])[order],
            )

    def reached_unstable(self, keys: I64) -> None:
        """A check before the first stable one had the cells of ``keys`` in reach of places
        not yet stable (see :attr:`unstable_keys`)."""
        if keys.size:
            self.unstable_keys = np.union1d(self.unstable_keys, keys).astype(np.int64)

    def remap(self, src: I64, dst: I64) -> None:
        """Entries ``src`` were moved into ``dst``: every held day follows."""
        if src.size == 0:
            return
        if self.days and np.isin(src, np.concatenate([d.live for d in self.days])).any():
            self.moved_after_hold = True
        order = np.argsort(src, kind="stable")
        keys, targets = src[order], dst[order]
        for held in self.days:
            held.pending.remap(src, dst)
            pos = np.minimum(np.searchsorted(keys, held.live), keys.size - 1)
            hit = keys[pos] == held.live
            if hit.any():
                held.live = np.unique(np.where(hit, targets[pos], held.live))

    # -- persistence (a part map, ``aion build --part``) ----------------------------------
    def to_arrays(self, position: I64) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Members ``held{k}_*`` per held day (rows as saved positions) and the meta."""
        arrays: dict[str, np.ndarray] = {}
        days = []
        for k, held in enumerate(self.days):
            part, day = held.pending.to_arrays(f"held{k}_", position)
            arrays.update(part)
            live = position[held.live]
            arrays[f"held{k}_live"] = np.sort(live[live >= 0])
            days.append(day)
        if self.first_graph is not None:
            arrays["held_first_graph"] = self.first_graph.copy()
        if self.unstable_keys.size:
            arrays["held_unstable_keys"] = self.unstable_keys.copy()
        if self.reach is not None:
            for name, value in zip(("ids", "low", "high"), self.reach, strict=True):
                arrays[f"held_reach_{name}"] = value.copy()
        if self.first_stable is not None:
            arrays["held_first_stable_ids"] = self.first_stable[0].copy()
            arrays["held_first_stable_xyz"] = self.first_stable[1].copy()
        meta: dict[str, Any] = {
            "days": days,
            "first_stable_late": bool(self.first_stable_late),
            "moved_after_hold": bool(self.moved_after_hold),
        }
        if self.drift is not None:
            drift_arrays, meta["drift"] = self.drift.to_arrays("held_drift_")
            arrays.update(drift_arrays)
        if self.group_keys is not None:
            arrays["held_group_ids"] = self.group_keys[0].copy()
            arrays["held_group_keys"] = self.group_keys[1].copy()
        meta["groups_changed_after_hold"] = bool(self.groups_changed_after_hold)
        meta["held_before_graph"] = bool(self.held_before_graph)
        return arrays, meta

    @classmethod
    def from_arrays(
        cls, arrays: dict[str, np.ndarray], meta: Any, values: int, entries: int
    ) -> DeferredDays:
        """Inverse of :meth:`to_arrays` (:class:`MapCorruptError` for inconsistent input)."""
        try:
            days = list(meta["days"])
            out = cls(
                first_stable_late=bool(meta["first_stable_late"]),
                moved_after_hold=bool(meta["moved_after_hold"]),
            )
        except (KeyError, TypeError) as exc:
            raise MapCorruptError(f"held days metadata is incomplete: {exc}") from exc
        for k, day in enumerate(days):
            pending = PendingDay.from_arrays(arrays, f"held{k}_", day, values, entries)
            if f"held{k}_live" not in arrays:
                raise MapCorruptError(f"held day {k} incomplete, missing: held{k}_live")
            live = np.asarray(arrays[f"held{k}_live"], dtype=np.int64).reshape(-1)
            if live.size and (live.min() < 0 or live.max() >= entries):
                raise MapCorruptError(f"held{k}_live indexes entries that do not exist")
            if not pending:
                raise MapCorruptError(f"held day {k} holds no window")
            out.days.append(HeldDay(pending, live))
        if "held_first_graph" in arrays:
            out.first_graph = np.asarray(arrays["held_first_graph"], dtype=np.uint64).reshape(-1)
        if "held_first_stable_ids" in arrays:
            ids = np.asarray(arrays["held_first_stable_ids"], dtype=np.uint64).reshape(-1)
            xyz = np.asarray(arrays.get("held_first_stable_xyz", np.zeros((0, 3))), np.float64)
            if xyz.shape != (ids.size, 3):
                raise MapCorruptError("held_first_stable_xyz does not match its ids")
            out.first_stable = (ids, xyz)
        if "held_reach_ids" in arrays:  # older part maps did not keep it
            ids = np.asarray(arrays["held_reach_ids"], np.uint64).reshape(-1)
            low = np.asarray(arrays.get("held_reach_low", np.zeros((0, 3))), np.float64)
            high = np.asarray(arrays.get("held_reach_high", np.zeros((0, 3))), np.float64)
            if low.shape != (ids.size, 3) or high.shape != (ids.size, 3):
                raise MapCorruptError("held_reach_low / held_reach_high do not match their ids")
            if ids.size > 1 and not bool(np.all(ids[1:] > ids[:-1])):
                raise MapCorruptError("held_reach_ids are not sorted and unique")
            out.reach = (ids, low, high)
        if meta.get("drift") is not None:
            out.drift = NodeDrift.from_arrays(arrays, meta["drift"], "held_drift_")
        out.groups_changed_after_hold = bool(meta.get("groups_changed_after_hold", False))
        if "held_unstable_keys" in arrays:  # older part maps did not keep them
            out.unstable_keys = np.unique(np.asarray(arrays["held_unstable_keys"], np.int64))
        out.held_before_graph = bool(meta.get("held_before_graph", False))
        if "held_group_ids" in arrays:
            ids = np.asarray(arrays["held_group_ids"], np.uint64).reshape(-1)
            keys = np.asarray(arrays.get("held_group_keys", np.zeros((0, 3))), np.int64)
            if keys.shape != (ids.size, 3):
                raise MapCorruptError("held_group_keys does not match its ids")
            out.group_keys = (ids, keys)
        return out

