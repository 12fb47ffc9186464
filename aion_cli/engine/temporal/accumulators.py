"""The additive temporal accumulators of a map: observation, counts and forecast scores.

Per entry row e (an unbound hash cell or a node) and value bin v (the B direction bins, then
one bin for detections without a heading; V = B + 1):

* **observation** — which windows saw the entry, as sums over its observed windows: ``n``
  (windows), ``fourier[K]`` = Σ e^{iω_k t_w}, ``profile[H]`` = windows per profile bin,
  ``first`` / ``last`` (model seconds, NaN before any). The B+1 value bins of an entry share
  them. A fixed sensor observes every entry at once, so its windows live in one *global* block
  (:attr:`TemporalState.glob`) that counts for every entry, including entries created later
  (the sensor saw their place empty before); per-entry blocks hold the rest (robot coverage, or
  windows in which the entry had detections although no source covered it). An entry's
  observation is ``glob + obs[e]`` (:meth:`TemporalState.observation`).
* **counts** — ``cnt_fourier[V, K]`` = Σ n_{w,v}·e^{iω_k t_w} (FreMEn) and
  ``cnt_profile[V, H]`` = Σ n_{w,v} per profile bin (the periodic profile; its sum over H is
  the entry's count N_v over closed windows).
* **scores** — sums over day-ahead forecasts (see :mod:`~aion_cli.engine.temporal.scoring`):
  ``flow_score[F]`` Poisson log-likelihood of the window counts per flow family,
  ``flow_chi2[F]`` Pearson χ² (over-dispersion for the predictive spread), ``flow_scored``
  windows scored, ``flow_days`` days scored and ``flow_gain_sq[F]`` Σ over days of the squared
  daily gain over ``static`` (how consistent a family's advantage is); ``dir_score[D]``,
  ``dir_scored`` (detections), ``dir_days`` and ``dir_gain_sq[D]`` the same for the
  log-probability of each detection's direction bin.

Every field is a sum (or min/max), so states of disjoint time add exactly
(:meth:`TemporalState.add_rows` with ``observation="add"``). When ownership moves a cell into
a node (same time span) counts and scores add, and the observation of whichever had more
windows is kept (``observation="max"``): the two were seen in nearly the same windows, and a
sum would divide the node's rate by the number of cells it absorbed. The map as a whole keeps
``window_chi2``, how bursty its window totals are (:mod:`.shape_prior`), and ``day_level``,
how its days differ in level (:mod:`.day_level`); maps' sums add (:meth:`add_map_sums`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from aion_cli.engine.temporal.observation_block import _OBS_FIELDS, C128, ObsBlock
from aion_cli.engine.temporal.stored_layout import ROW_BLOCK
from aion_cli.engine.types import F64, I64
from aion_cli.engine.zeros import lazy_zeros

__all__ = ["C128", "ObsBlock", "TemporalState"]

_SCORES = (
    "flow_score",
    "flow_chi2",
    "flow_scored",
    "flow_days",
    "flow_gain_sq",
    "dir_score",
    "dir_scored",
    "dir_days",
    "dir_gain_sq",
)
_ADDITIVE = ("cnt_fourier", "cnt_profile", *_SCORES)
_TALLIES = ("flow_scored", "flow_days", "dir_scored", "dir_days")


@dataclass
class TemporalState:
    """The accumulators of R entry rows (struct of arrays; see the module docstring)."""

    glob: ObsBlock
    obs: ObsBlock
    cnt_fourier: C128
    cnt_profile: F64
    flow_score: F64
    flow_chi2: F64
    flow_scored: F64
    flow_days: F64
    flow_gain_sq: F64
    dir_score: F64
    dir_scored: F64
    dir_days: F64
    dir_gain_sq: F64
    window_chi2: F64 = field(default_factory=lambda: np.zeros(2), compare=False)
    """Σ χ² and Σ degrees of freedom of the map's window totals (:mod:`.shape_prior`)."""
    day_level: F64 = field(default_factory=lambda: np.zeros((4, 0)), compare=False)
    """Per (kind of slot, profile bin), the days observed and sums of their rates: how much
    whole days differ in level (:mod:`.day_level`; shape ``(4, 0)`` before any day)."""
    week_sums: F64 = field(default_factory=lambda: np.zeros((4, 0)), compare=False)
    """Per hour of the week, the map's days, detections and units observed and the week
    calendar's day-ahead gain (:mod:`.week_evidence`; shape ``(4, 0)`` before any day)."""
    high_water: int = field(default=-1, compare=False, repr=False)
    """Rows from here on were never written (hold zeros): :meth:`resize` does not copy them
    (reserved capacity stays unbacked by memory) and absorbing counts writes them without
    reading them first. Whatever writes a row raises it (:meth:`touch`). −1 at construction
    means every row; a state read from a map starts past the last row the map stored."""
    generation: int = field(default=0, compare=False, repr=False)
    """Bumped by every change (invalidates cached forecasts)."""
    fourier_loaded: bool = field(default=True, compare=False, repr=False)
    """False for a query's state read without the per-entry Fourier sums (``cnt_fourier`` and
    the entries' own ``obs.fourier`` then have no period axis: shape ``(R, V, 0)`` /
    ``(R, 0)``): its FreMEn components come from the map file
    (:mod:`~aion_cli.engine.temporal.components`), it absorbs windows without their phasors,
    and it cannot be written back (:meth:`to_arrays` refuses)."""

    def __post_init__(self) -> None:
        if self.high_water < 0:
            self.high_water = self.n_rows

    @classmethod
    def empty(
        cls,
        rows: int,
        values: int,
        periods: int,
        bins: int,
        flow_families: int,
        dir_families: int,
    ) -> TemporalState:
        out = cls(
            glob=ObsBlock.empty(1, periods, bins),
            obs=ObsBlock.empty(rows, periods, bins),
            cnt_fourier=lazy_zeros((rows, values, periods), np.complex128),
            cnt_profile=lazy_zeros((rows, values, bins)),
            flow_score=lazy_zeros((rows, flow_families)),
            flow_chi2=lazy_zeros((rows, flow_families)),
            flow_scored=lazy_zeros(rows),
            flow_days=lazy_zeros(rows),
            flow_gain_sq=lazy_zeros((rows, flow_families)),
            dir_score=lazy_zeros((rows, dir_families)),
            dir_scored=lazy_zeros(rows),
            dir_days=lazy_zeros(rows),
            dir_gain_sq=lazy_zeros((rows, dir_families)),
        )
        out.high_water = 0
        return out

    # -- shape ------------------------------------------------------------------------------
    @property
    def n_rows(self) -> int:
        return int(self.obs.n.shape[0])

    @property
    def n_values(self) -> int:
        return int(self.cnt_profile.shape[1])

    @property
    def n_periods(self) -> int:
        """K, the FreMEn periods (from the global block, which every state reads whole)."""
        return int(self.glob.fourier.shape[1])

    @property
    def n_bins(self) -> int:
        return int(self.obs.profile.shape[1])

    def _like(self, rows: int) -> TemporalState:
        out = TemporalState.empty(
            rows,
            self.n_values,
            int(self.cnt_fourier.shape[2]),  # 0 in a query's state without the sums
            self.n_bins,
            self.flow_score.shape[1],
            self.dir_score.shape[1],
        )
        out.glob, out.window_chi2 = self.glob.take([0]), self.window_chi2.copy()
        out.day_level, out.week_sums = self.day_level.copy(), self.week_sums.copy()
        out.fourier_loaded = self.fourier_loaded
        return out

    @property
    def nbytes(self) -> int:
        """Bytes held in memory by the accumulators (dense arrays of every row)."""
        obs = sum(getattr(block, f).nbytes for block in (self.glob, self.obs) for f in _OBS_FIELDS)
        return int(obs + sum(getattr(self, name).nbytes for name in _ADDITIVE))

    def touch(self, rows: I64 | None = None) -> None:
        """Note a change (and that ``rows`` were written)."""
        self.generation += 1
        if rows is not None and rows.size:
            self.high_water = max(self.high_water, int(rows.max()) + 1)

    # -- reading ----------------------------------------------------------------------------
    def observation(self, rows: npt.ArrayLike, fourier: bool = True) -> ObsBlock:
        """The observation of entries ``rows``: the global block plus their own. Without
        ``fourier`` the Fourier sums are left out (shape ``(n, 0)``): a forecast reads them
        per block of entries where it needs them, and copying them for every entry would cost
        more than the rest of the observation."""
        out = self.obs.take(rows, fourier)
        out.n += self.glob.n[0]
        if fourier:
            out.fourier += self.glob.fourier[0]
        out.profile += self.glob.profile[0]
        out.first = np.fmin(out.first, self.glob.first[0])
        out.last = np.fmax(out.last, self.glob.last[0])
        return out

    def windows_observed(self, rows: npt.ArrayLike) -> F64:
        """Closed windows in which each entry was observed."""
        r = np.asarray(rows, dtype=np.int64)
        out: F64 = self.obs.n[r] + self.glob.n[0]
        return out

    # -- row operations ---------------------------------------------------------------------
    def add_rows(
        self, src: npt.ArrayLike, dst: npt.ArrayLike, observation: Literal["max", "add"]
    ) -> None:
        """``dst += src`` row by row (``dst`` may repeat; sources are read before writing).

        Counts and scores add. ``observation="add"`` adds the per-entry observation blocks
        (states of disjoint time); ``"max"`` keeps, per destination, the block with the most
        windows among the destination's own and its sources' (ownership transfer within one
        map; ties keep the destination's, then the first source's)."""
        s = np.asarray(src, dtype=np.int64).reshape(-1)
        d = np.asarray(dst, dtype=np.int64).reshape(-1)
        if s.shape != d.shape:
            raise ValueError("src and dst must have the same length")
        written = s < self.high_water
        s, d = s[written], d[written]
        if s.size == 0:
            return
        self.touch(d)
        if observation == "add":
            self.obs.add_block(d, self.obs.take(s))
        else:
            self._keep_larger_observation(s, d)
        for a in range(0, s.size, ROW_BLOCK):
            sb, db = s[a : a + ROW_BLOCK], d[a : a + ROW_BLOCK]
            vals = {name: getattr(self, name)[sb] for name in _ADDITIVE}
            for name in _ADDITIVE:
                np.add.at(getattr(self, name), db, vals[name])

    def add_map_sums(self, other: TemporalState) -> None:
        """Add ``other``'s sums of the map as a whole (``window_chi2``, ``day_level``,
        ``week_sums``): those of
        a map of other days, merged or continued into this one."""
        from aion_cli.engine.temporal import week_evidence
        from aion_cli.engine.temporal.day_level import add_sums

        self.window_chi2 += other.window_chi2
        self.day_level = add_sums(self.day_level, other.day_level)
        self.week_sums = week_evidence.add_sums(self.week_sums, other.week_sums)

    def add_from(
        self,
        other: TemporalState,
        src: npt.ArrayLike,
        dst: npt.ArrayLike,
        observation: Literal["max", "add"],
    ) -> None:
        """``self[dst] += other[src]`` as :meth:`add_rows` does within one state (another
        map's entries added into this one's), touching only the rows involved: no copy of
        the whole state (a merge of a few entries into a large map stays cheap)."""
        s = np.asarray(src, dtype=np.int64).reshape(-1)
        d = np.asarray(dst, dtype=np.int64).reshape(-1)
        if s.shape != d.shape:
            raise ValueError("src and dst must have the same length")
        if s.size == 0:
            return
        targets, slot, hits = np.unique(d, return_inverse=True, return_counts=True)
        once = hits[slot.reshape(-1)] == 1
        if once.any():  # one source per destination (the common case): in place
            so, do = s[once], d[once]
            theirs = other.obs.take(so)
            if observation == "add":
                self.obs.add_block(do, theirs)
            else:  # the larger block; a tie keeps the destination's
                larger = theirs.n > self.obs.n[do]
                if larger.any():
                    self.obs.put(do[larger], theirs.take(np.flatnonzero(larger)))
            if int(do.min()) >= self.high_water:  # rows never written hold zeros: assign
                for name in _ADDITIVE:
                    getattr(self, name)[do] = getattr(other, name)[so]
            else:
                for name in _ADDITIVE:
                    getattr(self, name)[do] += getattr(other, name)[so]
            self.touch(do)
            s, d = s[~once], d[~once]
            if s.size == 0:
                return
            targets, slot = np.unique(d, return_inverse=True)
        small = TemporalState.concat([self.take(targets), other.take(s)])
        small.high_water = small.n_rows
        small.add_rows(targets.size + np.arange(s.size), slot.reshape(-1), observation)
        head = np.arange(targets.size)
        self.obs.put(targets, small.obs.take(head))
        for name in _ADDITIVE:
            getattr(self, name)[targets] = getattr(small, name)[: targets.size]
        self.touch(targets)

    def _keep_larger_observation(self, s: I64, d: I64) -> None:
        targets = np.unique(d)
        cand_row = np.concatenate([targets, s])
        cand_dst = np.concatenate([targets, d])
        order = np.lexsort((np.arange(cand_row.size), -self.obs.n[cand_row], cand_dst))
        first = np.ones(order.size, dtype=bool)
        first[1:] = cand_dst[order][1:] != cand_dst[order][:-1]
        chosen, into = cand_row[order][first], cand_dst[order][first]
        change = chosen != into
        if change.any():
            self.obs.put(into[change], self.obs.take(chosen[change]))

    def zero_rows(self, rows: npt.ArrayLike) -> None:
        """Forget rows ``rows`` (they become never-observed rows)."""
        r = np.asarray(rows, dtype=np.int64).reshape(-1)
        r = r[r < self.high_water]
        self.obs.zero(r)
        for name in _ADDITIVE:
            getattr(self, name)[r] = 0.0
        self.touch()

    def __getstate__(self) -> dict[str, Any]:
        """Pickled with the rows below the high-water mark only: the rest were never written
        (a parallel build's shards send their states to the parent, and a shard whose days
        are held has written none)."""
        keep = self.high_water
        state: dict[str, Any] = {name: getattr(self, name)[:keep] for name in _ADDITIVE}
        state["obs"] = ObsBlock(*(getattr(self.obs, f)[:keep] for f in _OBS_FIELDS))
        state["glob"], state["window_chi2"] = self.glob, self.window_chi2
        state["day_level"], state["week_sums"] = self.day_level, self.week_sums
        state["rows"], state["high_water"] = self.n_rows, keep
        state["generation"] = self.generation
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        """The written rows, extended to the full capacity by :meth:`resize`."""
        keep = int(state["high_water"])
        written = TemporalState(
            glob=state["glob"],
            obs=state["obs"],
            **{name: state[name] for name in _ADDITIVE},
            window_chi2=state["window_chi2"],
            day_level=state["day_level"],
            week_sums=state.get("week_sums", np.zeros((4, 0))),
            high_water=keep,
        )
        written.resize(int(state["rows"]))
        written.generation = int(state["generation"])
        self.__dict__.update(written.__dict__)

    def resize(self, rows: int) -> None:
        """Truncate to, or extend with empty rows up to, ``rows`` rows (in place); rows past
        the high-water mark are not copied."""
        if rows < 0:
            raise ValueError("rows must be >= 0")
        keep = min(rows, self.high_water)
        new = self._like(rows)
        for name in _OBS_FIELDS:
            getattr(new.obs, name)[:keep] = getattr(self.obs, name)[:keep]
        for name in _ADDITIVE:
            getattr(new, name)[:keep] = getattr(self, name)[:keep]
        self.obs, self.window_chi2, self.day_level = new.obs, new.window_chi2, new.day_level
        self.week_sums = new.week_sums
        for name in _ADDITIVE:
            setattr(self, name, getattr(new, name))
        self.high_water = keep
        self.touch()

    def take(self, rows: npt.ArrayLike) -> TemporalState:
        """A new state with copies of rows ``rows`` (in that order) and the same global block."""
        r = np.asarray(rows, dtype=np.int64).reshape(-1)
        return TemporalState(
            glob=self.glob.take([0]),
            obs=self.obs.take(r),
            **{name: getattr(self, name)[r].copy() for name in _ADDITIVE},
            window_chi2=self.window_chi2.copy(),
            day_level=self.day_level.copy(),
            week_sums=self.week_sums.copy(),
            fourier_loaded=self.fourier_loaded,
        )

    def put_rows(self, rows: I64, other: TemporalState, src: I64) -> None:
        """``self[rows] = other[src]`` (observation blocks and accumulators; another map's
        rows copied in, as they are)."""
        self.obs.put(rows, other.obs.take(src))
        for name in _ADDITIVE:
            getattr(self, name)[rows] = getattr(other, name)[src]
        self.touch(rows)

    def copy(self) -> TemporalState:
        return self.take(np.arange(self.n_rows))

    @classmethod
    def concat(cls, states: list[TemporalState]) -> TemporalState:
        """Rows of every state in order; the global block (and ``window_chi2``,
        ``day_level``, ``week_sums``) is the first state's."""
        if not states:
            raise ValueError("concat needs at least one state")
        obs = ObsBlock(*(np.concatenate([getattr(s.obs, f) for s in states]) for f in _OBS_FIELDS))
        joined: dict[str, Any] = {
            name: np.concatenate([getattr(s, name) for s in states]) for name in _ADDITIVE
        }
        loaded = all(s.fourier_loaded for s in states)
        chi2, level = states[0].window_chi2.copy(), states[0].day_level.copy()
        week = states[0].week_sums.copy()
        return cls(states[0].glob.take([0]), obs, **joined, window_chi2=chi2, day_level=level,
                   week_sums=week, fourier_loaded=loaded)

    # -- persistence (:mod:`.accumulator_files`) --------------------------------------------
    def to_arrays(self, prefix: str, rows: I64) -> dict[str, Any]:
        """Members ``prefix + name`` for rows ``rows`` (``state_to_arrays``)."""
        from aion_cli.engine.temporal.accumulator_files import state_to_arrays

        return state_to_arrays(self, prefix, rows)

    @classmethod
    def from_arrays(
        cls,
        arrays: Mapping[str, np.ndarray],
        prefix: str,
        rows: int,
        values: int,
        periods: int,
        bins: int,
        flow_families: int,
        dir_families: int,
        copy: bool = True,
        fourier: bool = True,
    ) -> TemporalState:
        """Inverse of :meth:`to_arrays` (``state_from_arrays``)."""
        from aion_cli.engine.temporal.accumulator_files import state_from_arrays

        shape = (rows, values, periods, bins, flow_families, dir_families)
        return state_from_arrays(arrays, prefix, *shape, copy=copy, fourier=fourier)
