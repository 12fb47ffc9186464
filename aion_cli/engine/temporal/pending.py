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

from aion_cli.engine.temporal.stored_layout import narrowest_whole
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
    obs_weight: F64 | None = None
    """Per observation pair, the fraction of its window the entry was observed in (the
    robot's exposure, :mod:`~aion_cli.engine.observation`); None: every pair whole."""
    fixed_share: F64 | None = None
    """Per slot, the fraction of a fixed-sensor window the logs recorded (a log that starts or
    ends inside it, ``ObservationSource.fixed_share``); 1 for the other slots; None: every
    slot whole."""

    def slot_shares(self) -> F64:
        """:attr:`fixed_share`, ones where it is None."""
        if self.fixed_share is None:
            return np.ones(self.windows.size)
        return self.fixed_share

    def fixed_slots(self) -> tuple[I64, F64 | None]:
        """The fixed-sensor slots and their shares (None: all whole)."""
        slots = np.flatnonzero(self.fixed)
        return slots, None if self.fixed_share is None else self.fixed_share[slots]

    def fixed_windows(self) -> float:
        """The fixed-sensor windows, each for the share of it recorded: what the day adds to
        every entry's observed windows."""
        slots, share = self.fixed_slots()
        return float(slots.size) if share is None else float(share.sum())

    def weights(self) -> F64:
        """:attr:`obs_weight`, ones where it is None."""
        if self.obs_weight is None:
            return np.ones(self.obs_entry.size)
        return self.obs_weight

    def weights_at(self, obs: I64 | BoolA) -> F64 | None:
        """:attr:`obs_weight` of the observation pairs ``obs`` (indices or a mask; None where
        it is None)."""
        return None if self.obs_weight is None else self.obs_weight[obs]

    def own_pairs(self) -> tuple[I64, I64, F64]:
        """The observation pairs outside fixed-sensor slots (those are counted by the fixed
        slots, for every entry): entries, slots and exposures."""
        keep = ~self.fixed[self.obs_slot]
        return self.obs_entry[keep], self.obs_slot[keep], self.weights()[keep]

    def count_weights(self) -> F64:
        """Per count pair, the exposure of its (entry, window): the window's recorded share in
        a fixed-sensor window, 1 where no observation pair holds it, else its observation
        pair's weight (the pairs of both kinds are sorted by entry, then slot)."""
        out = np.ones(self.cnt_entry.size)
        if self.fixed_share is not None:
            out = self.fixed_share[self.cnt_slot].astype(np.float64)
        if self.obs_weight is None or self.cnt_entry.size == 0 or self.obs_entry.size == 0:
            return out
        slots = max(self.windows.size, 1)
        obs_key = self.obs_entry * slots + self.obs_slot
        cnt_key = self.cnt_entry * slots + self.cnt_slot
        at = np.minimum(np.searchsorted(obs_key, cnt_key), obs_key.size - 1)
        hit = (obs_key[at] == cnt_key) & ~self.fixed[self.cnt_slot]
        out[hit] = self.obs_weight[at[hit]]
        return out

    def select(self, obs: I64, cnt: I64) -> DayWindows:
        """The same windows with the observation pairs ``obs`` and count pairs ``cnt``."""
        return DayWindows(
            self.windows,
            self.fixed,
            self.obs_entry[obs],
            self.obs_slot[obs],
            self.cnt_entry[cnt],
            self.cnt_slot[cnt],
            np.take(self.cnt_values, cnt, axis=0),  # rows of V values: take is ~2x faster
            self.weights_at(obs),
            self.fixed_share,
        )


def joined(parts: list[DayWindows]) -> DayWindows:
    """Consecutive ``parts`` of one local day (each part's windows after the part's before
    it: a query's pending day, then its open window) as one day, as
    :meth:`PendingDay.consolidated` holds a day whose windows were all closed: slots in
    window order, the pairs of both kinds sorted by entry, then slot. One part is returned
    as it is."""
    if len(parts) == 1:
        return parts[0]
    sizes = np.array([p.windows.size for p in parts], np.int64)
    offset = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    obs_e = np.concatenate([p.obs_entry for p in parts]).astype(np.int64, copy=False)
    cnt_e = np.concatenate([p.cnt_entry for p in parts]).astype(np.int64, copy=False)
    # each part's pairs by entry, then slot, its slots after the parts' before it: a stable
    # sort by entry orders the whole day's pairs by entry, then slot
    obs, cnt = np.argsort(obs_e, kind="stable"), np.argsort(cnt_e, kind="stable")
    obs_s = np.concatenate([p.obs_slot + o for p, o in zip(parts, offset, strict=True)])
    cnt_s = np.concatenate([p.cnt_slot + o for p, o in zip(parts, offset, strict=True)])
    weight = np.concatenate([p.weights() for p in parts])[obs]
    share = np.concatenate([p.slot_shares() for p in parts])
    return DayWindows(
        np.concatenate([p.windows for p in parts]),
        np.concatenate([p.fixed for p in parts]),
        obs_e[obs],
        obs_s[obs],
        cnt_e[cnt],
        cnt_s[cnt],
        np.concatenate([p.cnt_values for p in parts])[cnt],
        None if bool(np.all(weight == 1.0)) else weight,
        None if bool(np.all(share == 1.0)) else share,
    )


@dataclass
class PendingDay:
    """Closed windows of the local day ``day`` not yet absorbed (see the module docstring)."""

    values: int
    day: int | None = None
    windows: list[int] = field(default_factory=list)
    fixed: list[bool] = field(default_factory=list)
    fixed_share: list[float] = field(default_factory=list)
    _obs_entry: list[I64] = field(default_factory=list)
    _obs_slot: list[I64] = field(default_factory=list)
    _obs_weight: list[F64] = field(default_factory=list)
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
        exposure: npt.ArrayLike | None = None,
        fixed_share: float = 1.0,
    ) -> None:
        """Hold window ``window`` of local day ``day`` (windows arrive in time order; the
        caller flushes before a window of another day); ``exposure``: per entry of
        ``observed``, the fraction of the window it was observed in (default whole);
        ``fixed_share``: of a fixed-sensor window, the fraction the logs recorded."""
        if fixed and not 0.0 < fixed_share <= 1.0:
            raise ValueError(f"a window's recorded share must be in (0, 1], got {fixed_share!r}")
        if self.day is not None and day != self.day:
            raise ValueError(f"window of day {day} added to the pending day {self.day}")
        if self.windows and window <= self.windows[-1]:
            raise ValueError("pending windows must arrive in increasing order")
        self._changed()
        self.day = int(day)
        slot = len(self.windows)
        self.windows.append(int(window))
        self.fixed.append(bool(fixed))
        self.fixed_share.append(float(fixed_share) if fixed else 1.0)
        obs = np.asarray(observed, dtype=np.int64).reshape(-1)
        if obs.size:
            self._obs_entry.append(obs)
            self._obs_slot.append(np.full(obs.size, slot, np.int64))
            self._obs_weight.append(_weights(exposure, obs.size))
        rows = np.asarray(count_rows, dtype=np.int64).reshape(-1)
        if rows.size:
            vals = np.asarray(counts, dtype=np.float64).reshape(rows.size, self.values)
            self._cnt_entry.append(rows)
            self._cnt_slot.append(np.full(rows.size, slot, np.int64))
            self._cnt_values.append(vals)

    def add_observed(self, slot: int, rows: I64, exposure: npt.ArrayLike | None = None) -> None:
        """Entries ``rows`` were observed in the held window ``slot`` too (for ``exposure``
        of it, default whole)."""
        if not 0 <= slot < len(self.windows):
            raise ValueError(f"no held window {slot}")
        self._changed()
        self._obs_entry.append(np.asarray(rows, np.int64))
        self._obs_slot.append(np.full(len(rows), slot, np.int64))
        self._obs_weight.append(_weights(exposure, len(rows)))

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
        for name in ("_obs_entry", "_obs_slot", "_obs_weight", "_cnt_entry", "_cnt_slot",
                     "_cnt_values"):
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
        self.fixed_share.extend(later.fixed_share)
        self._obs_entry.extend(later._obs_entry)
        self._obs_slot.extend(a + offset for a in later._obs_slot)
        self._obs_weight.extend(later._obs_weight)
        self._cnt_entry.extend(later._cnt_entry)
        self._cnt_slot.extend(a + offset for a in later._cnt_slot)
        self._cnt_values.extend(later._cnt_values)

    def relabelled(self, row_map: I64) -> PendingDay:
        """A copy with every entry row ``r`` replaced by ``row_map[r]`` (into another map)."""
        out = PendingDay(
            self.values, self.day, list(self.windows), list(self.fixed), list(self.fixed_share)
        )
        out._obs_entry = [row_map[a] for a in self._obs_entry]
        out._obs_slot = [a.copy() for a in self._obs_slot]
        out._obs_weight = [a.copy() for a in self._obs_weight]
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
        weight = np.concatenate(self._obs_weight) if self._obs_weight else np.zeros(0)
        if obs_e.size:
            # a node observed through itself and the cells it absorbed: the largest exposure
            keys, inverse = np.unique(obs_e * slots + obs_s, return_inverse=True)
            obs_e, obs_s = np.divmod(keys, slots)
            most = np.zeros(keys.size)
            np.maximum.at(most, inverse.reshape(-1), weight)
            weight = most
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
            None if bool(np.all(weight == 1.0)) else weight,
            _partial(self.fixed_share),
        )
        for array in vars(day).values():
            if array is not None:
                array.setflags(write=False)
        return day

    def clear(self) -> None:
        self._changed()
        self.day = None
        self.windows, self.fixed, self.fixed_share = [], [], []
        self._obs_entry, self._obs_slot, self._obs_weight = [], [], []
        self._cnt_entry, self._cnt_slot, self._cnt_values = [], [], []

    # -- persistence ------------------------------------------------------------------------
    def to_arrays(self, prefix: str, position: I64) -> tuple[dict[str, np.ndarray], Any]:
        """Arrays with entry rows replaced by ``position[row]`` (their index in the saved
        entry order) and the day as meta."""
        day = self.consolidated()
        obs_pos, cnt_pos = position[day.obs_entry], position[day.cnt_entry]
        obs = np.lexsort((day.obs_slot, obs_pos))  # saved order: by position, then slot,
        cnt = np.lexsort((day.cnt_slot, cnt_pos))  # whatever the in-memory row layout
        arrays = {  # indices, slots and counts in the narrowest exact type (readers widen)
            prefix + "windows": day.windows,
            prefix + "fixed": day.fixed,
            prefix + "obs_entry": narrowest_whole(obs_pos[obs]),
            prefix + "obs_slot": narrowest_whole(day.obs_slot[obs]),
            prefix + "cnt_entry": narrowest_whole(cnt_pos[cnt]),
            prefix + "cnt_slot": narrowest_whole(day.cnt_slot[cnt]),
            prefix + "cnt_values": narrowest_whole(day.cnt_values[cnt]),
        }
        if day.obs_weight is not None:  # some robot window observed in part
            arrays[prefix + "obs_weight"] = day.obs_weight[obs]
        if day.fixed_share is not None:  # some fixed-sensor window recorded in part
            arrays[prefix + "fixed_share"] = day.fixed_share
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
            weight = np.asarray(
                arrays.get(prefix + "obs_weight", np.ones(obs_e.size)), dtype=np.float64
            ).reshape(-1)
            share = np.asarray(
                arrays.get(prefix + "fixed_share", np.ones(windows.size)), dtype=np.float64
            ).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise MapCorruptError(f"pending day has invalid arrays: {exc}") from exc
        ok = (
            windows.size == fixed.size
            and (windows.size == 0 or bool(np.all(np.diff(windows) > 0)))
            and obs_e.size == obs_s.size == weight.size
            and bool(np.all((weight > 0.0) & (weight <= 1.0)))
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
        if share.size != windows.size or not bool(
            np.all((share > 0.0) & (share <= 1.0) & (fixed | (share == 1.0)))
        ):
            raise MapCorruptError(
                f"{prefix}fixed_share is not one share in (0, 1] per window of "
                f"{prefix}windows, below 1 only where a fixed sensor observed"
            )
        if windows.size == 0:
            return out
        out.day = int(day)
        out.windows = [int(w) for w in windows.tolist()]
        out.fixed = [bool(f) for f in fixed.tolist()]
        out.fixed_share = [float(f) for f in share.tolist()]
        if obs_e.size:
            out._obs_entry, out._obs_slot, out._obs_weight = [obs_e], [obs_s], [weight]
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


def _weights(exposure: npt.ArrayLike | None, n: int) -> F64:
    """Exposures of ``n`` observation pairs: ones by default; each in (0, 1]."""
    if exposure is None:
        return np.ones(n)
    out = np.asarray(exposure, dtype=np.float64).reshape(-1)
    if out.size != n or not bool(np.all((out > 0.0) & (out <= 1.0))):
        raise ValueError("exposure must give each observed entry a fraction in (0, 1]")
    return out


def _cat(chunks: list[I64]) -> I64:
    return np.concatenate(chunks) if chunks else np.zeros(0, np.int64)


def _partial(shares: list[float]) -> F64 | None:
    """The slots' recorded shares as an array, None when every slot is whole."""
    out = np.asarray(shares, dtype=np.float64)
    return None if bool(np.all(out == 1.0)) else out
