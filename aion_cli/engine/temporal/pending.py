"""The closed windows of the current (local) day, held until the day is over.

A day's windows are scored against the forecast the map made *before* the day — its
accumulators without the day (:mod:`~aion_cli.engine.temporal.scoring`) — and only then
absorbed. Holding them (rather than freezing each entry's forecast at the start of the day)
keeps the scores independent of how windows are batched into calls and of where a build is
stopped and continued: the same day gives the same scores whenever it is flushed.

Per window: its index, whether a fixed sensor covered it (every entry observed: the global
observation block), the entries observed otherwise (robot coverage, or detections no source
covered), and the entries' counts per value bin. Sparse: a window costs the entries it saw,
never the whole map. Ownership transfer during the day re-labels the held entries
(:meth:`PendingDay.remap`): counts follow the cell into its node, and a node is observed in a
window if it or any cell it absorbed was (an exact union, unlike the accumulators' "max").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from aion_cli.engine.node_drift import NodeDrift
from aion_cli.engine.temporal.groups import groups_moved
from aion_cli.engine.types import F64, I64, BoolA
from aion_cli.errors import MapCorruptError


@dataclass
class DayWindows:
    """A consolidated pending day: windows, fixed flags, unique (entry, slot) observation
    pairs and summed counts per (entry, slot) (``slot`` indexes ``windows``)."""

    windows: I64
    fixed: BoolA
    obs_entry: I64
    obs_slot: I64
    cnt_entry: I64
    cnt_slot: I64
    cnt_values: F64


@dataclass
class PendingDay:
    """Closed windows of the local day ``day`` not yet absorbed (see the module docstring)."""

    values: int
    day: int | None = None
    windows: list[int] = field(default_factory=list)
    fixed: list[bool] = field(default_factory=list)
    _obs_entry: list[I64] = field(default_factory=list)
    _obs_slot: list[I64] = field(default_factory=list)
    _cnt_entry: list[I64] = field(default_factory=list)
    _cnt_slot: list[I64] = field(default_factory=list)
    _cnt_values: list[F64] = field(default_factory=list)
    #: :meth:`consolidated` until the held windows change (a map's write asks for it up to six
    #: times: scores, components, provisional scores, the stored pending day...)
    _consolidated: DayWindows | None = field(default=None, init=False, repr=False, compare=False)

    def __bool__(self) -> bool:
        return bool(self.windows)

    def _changed(self) -> None:
        self._consolidated = None

    def add_window(
        self,
        day: int,
        window: int,
        fixed: bool,
        observed: npt.ArrayLike,
        count_rows: npt.ArrayLike,
        counts: npt.ArrayLike,
    ) -> None:
        """Hold window ``window`` of local day ``day`` (windows arrive in time order; the
        caller flushes before a window of another day)."""
        if self.day is not None and day != self.day:
            raise ValueError(f"window of day {day} added to the pending day {self.day}")
        if self.windows and window <= self.windows[-1]:
            raise ValueError("pending windows must arrive in increasing order")
        self._changed()
        self.day = int(day)
        slot = len(self.windows)
        self.windows.append(int(window))
        self.fixed.append(bool(fixed))
        obs = np.asarray(observed, dtype=np.int64).reshape(-1)
        if obs.size:
            self._obs_entry.append(obs)
            self._obs_slot.append(np.full(obs.size, slot, np.int64))
        rows = np.asarray(count_rows, dtype=np.int64).reshape(-1)
        if rows.size:
            vals = np.asarray(counts, dtype=np.float64).reshape(rows.size, self.values)
            self._cnt_entry.append(rows)
            self._cnt_slot.append(np.full(rows.size, slot, np.int64))
            self._cnt_values.append(vals)

    def add_observed(self, slot: int, rows: I64) -> None:
        """Entries ``rows`` were observed in the held window ``slot`` too."""
        if not 0 <= slot < len(self.windows):
            raise ValueError(f"no held window {slot}")
        self._changed()
        self._obs_entry.append(np.asarray(rows, np.int64))
        self._obs_slot.append(np.full(len(rows), slot, np.int64))

    def remap(self, src: I64, dst: I64) -> None:
        """Entries ``src`` were moved into ``dst``: held observations and counts follow."""
        if not self.windows or src.size == 0:
            return
        self._changed()
        order = np.argsort(src, kind="stable")
        keys, targets = src[order], dst[order]
        self._compact()  # one array per list: a bind costs one search, not one per window
        for chunks in (self._obs_entry, self._cnt_entry):
            for i, arr in enumerate(chunks):
                pos = np.minimum(np.searchsorted(keys, arr), keys.size - 1)
                hit = keys[pos] == arr
                if hit.any():
                    chunks[i] = np.where(hit, targets[pos], arr)

    def _compact(self) -> None:
        """Each list of held per-window arrays as one array (pairs in the same order, so
        :meth:`consolidated` gives the same day)."""
        for name in ("_obs_entry", "_obs_slot", "_cnt_entry", "_cnt_slot", "_cnt_values"):
            parts = getattr(self, name)
            if len(parts) > 1:
                setattr(self, name, [np.concatenate(parts)])

    def extend(self, later: PendingDay) -> None:
        """Append the windows of ``later`` (the same day, every window after this one's)."""
        if not later.windows:
            return
        if self.windows and (later.day != self.day or later.windows[0] <= self.windows[-1]):
            raise ValueError("only later windows of the same day can extend a pending day")
        self._changed()
        offset = len(self.windows)
        self.day = later.day
        self.windows.extend(later.windows)
        self.fixed.extend(later.fixed)
        self._obs_entry.extend(later._obs_entry)
        self._obs_slot.extend(a + offset for a in later._obs_slot)
        self._cnt_entry.extend(later._cnt_entry)
        self._cnt_slot.extend(a + offset for a in later._cnt_slot)
        self._cnt_values.extend(later._cnt_values)

    def relabelled(self, row_map: I64) -> PendingDay:
        """A copy with every entry row ``r`` replaced by ``row_map[r]`` (into another map)."""
        out = PendingDay(self.values, self.day, list(self.windows), list(self.fixed))
        out._obs_entry = [row_map[a] for a in self._obs_entry]
        out._obs_slot = [a.copy() for a in self._obs_slot]
        out._cnt_entry = [row_map[a] for a in self._cnt_entry]
        out._cnt_slot = [a.copy() for a in self._cnt_slot]
        out._cnt_values = [a.copy() for a in self._cnt_values]
        return out

    def entries(self) -> I64:
        """Every entry row the held windows mention."""
        parts = self._obs_entry + self._cnt_entry
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)

    def consolidated(self) -> DayWindows:
        """The held windows with duplicate pairs merged (sorted by entry, then slot); kept
        until the windows change, its arrays read-only (every caller shares them)."""
        if self._consolidated is None:
            self._consolidated = self._consolidate()
        return self._consolidated

    def _consolidate(self) -> DayWindows:
        slots = max(len(self.windows), 1)
        obs_e, obs_s = _cat(self._obs_entry), _cat(self._obs_slot)
        if obs_e.size:
            keys = np.unique(obs_e * slots + obs_s)
            obs_e, obs_s = np.divmod(keys, slots)
        cnt_e, cnt_s = _cat(self._cnt_entry), _cat(self._cnt_slot)
        vals = np.concatenate(self._cnt_values) if self._cnt_values else np.zeros((0, self.values))
        if cnt_e.size:
            cnt_e, cnt_s, vals = _summed_pairs(cnt_e * slots + cnt_s, vals, slots)
        day = DayWindows(
            np.asarray(self.windows, dtype=np.int64),
            np.asarray(self.fixed, dtype=bool),
            obs_e,
            obs_s,
            cnt_e,
            cnt_s,
            vals,
        )
        for array in vars(day).values():
            array.setflags(write=False)
        return day

    def clear(self) -> None:
        self._changed()
        self.day = None
        self.windows, self.fixed = [], []
        self._obs_entry, self._obs_slot = [], []
        self._cnt_entry, self._cnt_slot, self._cnt_values = [], [], []

    # -- persistence ------------------------------------------------------------------------
    def to_arrays(self, prefix: str, position: I64) -> tuple[dict[str, np.ndarray], Any]:
        """Arrays with entry rows replaced by ``position[row]`` (their index in the saved
        entry order) and the day as meta."""
        day = self.consolidated()
        obs_pos, cnt_pos = position[day.obs_entry], position[day.cnt_entry]
        obs = np.lexsort((day.obs_slot, obs_pos))  # saved order: by position, then slot,
        cnt = np.lexsort((day.cnt_slot, cnt_pos))  # whatever the in-memory row layout
        arrays = {
            prefix + "windows": day.windows,
            prefix + "fixed": day.fixed,
            prefix + "obs_entry": obs_pos[obs],
            prefix + "obs_slot": day.obs_slot[obs],
            prefix + "cnt_entry": cnt_pos[cnt],
            prefix + "cnt_slot": day.cnt_slot[cnt],
            prefix + "cnt_values": day.cnt_values[cnt],
        }
        return arrays, self.day

    @classmethod
    def from_arrays(
        cls, arrays: dict[str, np.ndarray], prefix: str, day: Any, values: int, entries: int
    ) -> PendingDay:
        """Inverse of :meth:`to_arrays` (rows are positions in the loaded entry order)."""
        out = cls(values)
        names = ("windows", "fixed", "obs_entry", "obs_slot", "cnt_entry", "cnt_slot", "cnt_values")
        missing = [prefix + n for n in names if prefix + n not in arrays]
        if missing:
            raise MapCorruptError(f"pending day incomplete, missing: {', '.join(missing)}")
        try:
            windows = np.asarray(arrays[prefix + "windows"], dtype=np.int64).reshape(-1)
            fixed = np.asarray(arrays[prefix + "fixed"], dtype=bool).reshape(-1)
            obs_e = np.asarray(arrays[prefix + "obs_entry"], dtype=np.int64).reshape(-1)
            obs_s = np.asarray(arrays[prefix + "obs_slot"], dtype=np.int64).reshape(-1)
            cnt_e = np.asarray(arrays[prefix + "cnt_entry"], dtype=np.int64).reshape(-1)
            cnt_s = np.asarray(arrays[prefix + "cnt_slot"], dtype=np.int64).reshape(-1)
            vals = np.asarray(arrays[prefix + "cnt_values"], dtype=np.float64)
            vals = vals.reshape(cnt_e.size, values)
        except (TypeError, ValueError) as exc:
            raise MapCorruptError(f"pending day has invalid arrays: {exc}") from exc
        ok = (
            windows.size == fixed.size
            and (windows.size == 0 or bool(np.all(np.diff(windows) > 0)))
            and obs_e.size == obs_s.size
            and cnt_e.size == cnt_s.size
            and all(a.size == 0 or (a.min() >= 0 and a.max() < entries) for a in (obs_e, cnt_e))
            and all(
                a.size == 0 or (a.min() >= 0 and a.max() < windows.size) for a in (obs_s, cnt_s)
            )
            and bool(np.all(np.isfinite(vals)))
            and (windows.size == 0) == (day is None)
        )
        if not ok:
            raise MapCorruptError("pending day arrays are inconsistent")
        if windows.size == 0:
            return out
        out.day = int(day)
        out.windows = [int(w) for w in windows.tolist()]
        out.fixed = [bool(f) for f in fixed.tolist()]
        if obs_e.size:
            out._obs_entry, out._obs_slot = [obs_e], [obs_s]
        if cnt_e.size:
            out._cnt_entry, out._cnt_slot, out._cnt_values = [cnt_e], [cnt_s], [vals]
        return out

    def relabel(self, row_of_position: I64) -> None:
        """After loading: positions in the saved order -> the rows they were loaded into."""
        self._changed()
        self._obs_entry = [row_of_position[a] for a in self._obs_entry]
        self._cnt_entry = [row_of_position[a] for a in self._cnt_entry]


def _summed_pairs(key: I64, values: F64, slots: int) -> tuple[I64, I64, F64]:
    """Entries, slots and summed rows of ``values`` per distinct ``key`` (entry·slots +
    slot), by key. Each window holds an entry's counts once, so repeated keys come only
    from moves; without any, the rows are only sorted (``+ 0.0``: as a sum from 0.0 would,
    a −0.0 reads 0.0)."""
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    if sorted_key.size < 2 or bool(np.all(sorted_key[1:] != sorted_key[:-1])):
        entry, slot = np.divmod(sorted_key, slots)
        summed: F64 = values[order] + 0.0
        return entry, slot, summed
    keys, inverse = np.unique(key, return_inverse=True)
    entry, slot = np.divmod(keys, slots)
    return entry, slot, _sum_by(inverse.reshape(-1), values, keys.size)


def _sum_by(group: I64, values: F64, n_groups: int) -> F64:
    """Rows of ``values`` summed by ``group``: float64[n_groups, V]. One ``bincount`` per
    column adds each group's rows in their order from 0.0, as ``np.add.at`` on zeros would
    (the same sums bit for bit), several times faster than its 2-D form."""
    out = np.empty((n_groups, values.shape[1]))
    for v in range(values.shape[1]):
        out[:, v] = np.bincount(group, values[:, v], minlength=n_groups)
    return out


def _cat(chunks: list[I64]) -> I64:
    return np.concatenate(chunks) if chunks else np.zeros(0, np.int64)


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
        if meta.get("drift") is not None:
            out.drift = NodeDrift.from_arrays(arrays, meta["drift"], "held_drift_")
        out.groups_changed_after_hold = bool(meta.get("groups_changed_after_hold", False))
        out.held_before_graph = bool(meta.get("held_before_graph", False))
        if "held_group_ids" in arrays:
            ids = np.asarray(arrays["held_group_ids"], np.uint64).reshape(-1)
            keys = np.asarray(arrays.get("held_group_keys", np.zeros((0, 3))), np.int64)
            if keys.shape != (ids.size, 3):
                raise MapCorruptError("held_group_keys does not match its ids")
            out.group_keys = (ids, keys)
        return out

