"""Walking direction (heading) and speed of each detection, in the map frame.

The rule (DESIGN.md §4 "Direction bins"), per detection, first that applies:

1. **Velocity.** The message carries a velocity whose horizontal part is finite and non-zero:
   ``heading = atan2(vy, vx)``, ``speed = hypot(vx, vy)``.
2. **Differencing the track.** The detection has a track id (>= 0) seen before, at most
   ``max_gap_s`` earlier, in this call or an earlier one: with ``d`` the horizontal displacement
   from the track's reference point and ``dt`` the time since it, ``speed = |d| / dt``; if
   ``|d| >= min_displacement`` then ``heading = atan2(dy, dx)`` and the detection becomes the
   new reference point, else the track's previous heading is kept (NaN if it has none) and the
   reference stays, so slow walkers accumulate displacement instead of producing noise.
3. **Pose yaw.** Otherwise the yaw of the pose orientation (NaN if the message has none); speed
   is NaN.

A track's reference resets when it has not been seen for ``max_gap_s`` (ids get reused); such
tracks are dropped from the state once it holds more than ``prune_above`` tracks.
Everything is in the MAP frame: the caller rotates positions, velocity vectors and yaws with TF
before calling (a heading in a moving robot frame means nothing). Speeds are horizontal (m/s),
headings in radians in (-π, π].

State between calls is a struct of arrays sorted by track id (id, reference time and position,
last heading). Within one call the rows of each track are taken in time order (with
``segment``: in (segment, time) order, as if each segment were a call of its own) and rule 2 is
a scan over them whose only sequential part is the reference point: a row resets it when it
lies more than ``max_gap_s`` after (or any time before) the reference, or at least
``min_displacement`` away from it after any time has passed. That scan is vectorised without a
loop over rows (see :meth:`HeadingEstimator._difference`): each row's *next reset* if it were
the reference is found for all rows at once (the range within ``max_gap_s`` by
``searchsorted``, a standing person's range passed over by a bounding-box test, the rest by a
search that widens geometrically), the chain of resets from each track's current reference is
followed by pointer doubling (log2 of the chain's length in steps), and the previous-heading
carry is a running maximum of event indices. Before issue 15 a call ran one vectorised round
per occurrence of a track (``tests/formats/heading_reference.py`` keeps that version, which
the tests compare against bit for bit); a build decoding 28-message pieces spent 4.7 s of a
20-day log's 7 s decode there. The
cost per call is a few dozen numpy operations over the call's rows, whatever the number of
rows per track, so a batch of thousands of messages costs about what one message used to.

After each call :attr:`HeadingEstimator.sources` says which rule gave each row its heading
(codes of :data:`SOURCES`), so a build can count headings by source.

With ``look_ahead`` (a build's linked tracks) :attr:`HeadingEstimator.look` also says which
rows *wait* -- rows whose reference has given no heading yet: a track's first rows, and those
after a reset for staleness -- and which row of the track ends the wait (its first
displacement of ``min_displacement``, or the lapse of the reference after ``max_gap_s``);
:class:`aion_cli.engine.heading_hold.HeadingHold` gives the waiting rows that displacement's
heading, as the offline rule (:func:`aion_cli.engine.differencing.difference_tracks`, which
looks ``max_gap_s`` both ways) gives it to them. A walker keeps his reference as long as he
covers ``min_displacement`` within ``max_gap_s`` (0.3 m in 5 s for linked tracks: 0.06 m/s);
slower is standing on both paths. The headings this estimator returns are unchanged by it.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import numpy.typing as npt

from aion_cli.engine.heading_chain import _chains, _inside_circle
from aion_cli.engine.heading_hold import LookAhead
from aion_cli.engine.types import F64, I64, DetectionBatch
from aion_cli.errors import ConfigError


class TrackedPositions(Protocol):
    """What heading estimation reads of decoded detections (``formats.detections.frame.
    FrameDetections`` is one): stamps, positions, velocities and yaws where known (NaN where
    not), track ids (-1 without)."""

    t_ns: I64
    xyz: F64
    velocity: F64
    yaw: F64
    track_id: I64

#: Heading source codes of :attr:`HeadingEstimator.sources`: no heading, the message's
#: velocity, differencing the track, the pose yaw.
SOURCES: tuple[str, ...] = ("none", "velocity", "track", "pose_yaw")
NO_HEADING, FROM_VELOCITY, FROM_TRACK, FROM_YAW = range(4)


class HeadingEstimator:
    """Stateful heading/speed estimation over successive calls (see the module docstring)."""

    def __init__(
        self,
        min_displacement: float = 0.05,
        max_gap_s: float = 5.0,
        prune_above: int = 4096,
        look_ahead: bool = False,
    ) -> None:
        if not min_displacement >= 0.0 or not max_gap_s > 0.0:
            raise ConfigError(
                f"heading estimation needs min_displacement >= 0 and max_gap_s > 0, got "
                f"{min_displacement} and {max_gap_s}"
            )
        self.min_displacement = float(min_displacement)
        self.max_gap_ns = int(max_gap_s * 1e9)
        self.prune_above = int(prune_above)
        self.ids: I64 = np.zeros(0, np.int64)
        self.ref_t: I64 = np.zeros(0, np.int64)
        self.ref_xy: F64 = np.zeros((0, 2))
        self.heading: F64 = np.zeros(0)
        #: Per row of the last :meth:`estimate` call, the code (index into :data:`SOURCES`) of
        #: the rule that gave its heading.
        self.sources: npt.NDArray[np.int8] = np.zeros(0, np.int8)
        #: With ``look_ahead``: per row of the last call, which rows wait for their track's
        #: next displacement and which settle them (:mod:`aion_cli.engine.heading_hold`).
        self.look_ahead = look_ahead
        self.look = LookAhead.none(0)

    def __len__(self) -> int:
        """Number of tracks remembered."""
        return len(self.ids)

    def to_batch(
        self, det: TrackedPositions, segment: npt.ArrayLike | None = None
    ) -> DetectionBatch:
        """The engine batch of detections already transformed into the map frame."""
        return self.estimate(det.t_ns, det.xyz, det.velocity, det.yaw, det.track_id, segment)

    def estimate(
        self,
        t_ns: npt.ArrayLike,
        xyz: npt.ArrayLike,
        velocity: npt.ArrayLike | None = None,
        yaw: npt.ArrayLike | None = None,
        track_id: npt.ArrayLike | None = None,
        segment: npt.ArrayLike | None = None,
    ) -> DetectionBatch:
        """Headings and speeds for map-frame arrays; rows keep their order.

        ``segment`` (int per row, non-decreasing along the stream): rows are differenced in
        (segment, time) order, which gives what calling once per segment in order gives (the
        state is pruned once, at the end of the call), so a build can decode many scene-graph
        intervals in one call."""
        t = np.asarray(t_ns, np.int64).reshape(-1)
        n = len(t)
        p = np.asarray(xyz, np.float64).reshape(n, 3)
        v = np.full((n, 3), np.nan) if velocity is None else np.asarray(velocity, np.float64)
        v = v.reshape(n, 3)
        y = np.full(n, np.nan) if yaw is None else np.asarray(yaw, np.float64).reshape(n)
        k = np.full(n, -1, np.int64) if track_id is None else np.asarray(track_id, np.int64)
        k = k.reshape(n)

        vxy = v[:, :2]
        vspeed = np.hypot(vxy[:, 0], vxy[:, 1])
        has_vel = np.isfinite(vspeed) & (vspeed > 0.0)
        heading = np.full(n, np.nan)
        moving = np.flatnonzero(has_vel)
        if moving.size:  # (logs without velocities skip the arctan2 entirely)
            heading[moving] = np.arctan2(vxy[moving, 1], vxy[moving, 0])
        speed = np.where(has_vel, vspeed, np.nan)

        source = np.where(has_vel, FROM_VELOCITY, NO_HEADING).astype(np.int8)
        if self.look_ahead:
            self.look = LookAhead.none(n)
        tracked = np.flatnonzero(k >= 0)
        if len(tracked):
            seg = None if segment is None else np.asarray(segment, np.int64).reshape(n)
            self._difference(tracked, t, p[:, :2], k, has_vel, heading, speed, seg)
            if len(self.ids) > self.prune_above:
                self._prune(int(t[tracked].max()))
            source[tracked] = np.where(
                has_vel[tracked], FROM_VELOCITY,
                np.where(np.isnan(heading[tracked]), NO_HEADING, FROM_TRACK),
            )
        unset = np.isnan(heading)
        source[unset & ~np.isnan(y)] = FROM_YAW
        self.sources = source
        heading = np.where(unset, y, heading)
        outside = np.flatnonzero(np.abs(heading) > np.pi)  # yaws moved by TF: wrap them
        if outside.size:
            h = heading[outside]
            heading[outside] = np.arctan2(np.sin(h), np.cos(h))
        return DetectionBatch(t, np.ascontiguousarray(p), heading, speed, k)

    # --- internals -------------------------------------------------------------------------------
    def _prune(self, t_now: int) -> None:
        """Forget tracks not seen for ``max_gap_s`` (they would start over anyway), so the state
        stays the size of the recently active tracks over a long log."""
        keep = self.ref_t >= t_now - self.max_gap_ns
        self.ids, self.ref_t = self.ids[keep], self.ref_t[keep]
        self.ref_xy, self.heading = self.ref_xy[keep], self.heading[keep]

    def _difference(
        self,
        rows: I64,
        t: I64,
        xy: F64,
        k: I64,
        has_vel: npt.NDArray[np.bool_],
        heading: F64,
        speed: F64,
        segment: I64 | None,
    ) -> None:
        """Rule 2 for the tracked ``rows`` (updates ``heading``/``speed`` and the state in
        place), vectorised over rows and tracks.

        The rows are laid out as *nodes*, track after track in (segment,) time order, each track
        preceded by a virtual node holding its remembered reference (when it has one). A
        track's reference resets exactly at the nodes of a chain: its first node, then, from
        each chain node ``i``, the first later node ``j`` of the track that would reset with
        ``i`` as reference (:meth:`_next_resets`); the chain is marked by pointer doubling
        (:func:`_chains`). Each row's reference is then the last chain node before it, and its
        previous heading the value of the last *event* (velocity, new differenced heading, or
        stale reset) before it: both running maxima of node indices. Every comparison and
        arithmetic step is the one the sequential rule makes, on the same values, so the
        results are identical to processing the rows one at a time."""
        keys = (t[rows], k[rows]) if segment is None else (t[rows], segment[rows], k[rows])
        rows = rows[np.lexsort(keys)]
        kr = k[rows]
        n = len(rows)
        starts = np.empty(n, dtype=bool)
        starts[0] = True
        np.not_equal(kr[1:], kr[:-1], out=starts[1:])
        group = np.cumsum(starts) - 1
        ids = kr[starts]
        n_groups = len(ids)

        # remembered tracks: their slot in the state arrays; those with a reference get a
        # virtual node before their rows
        if len(self.ids):
            slot = np.minimum(np.searchsorted(self.ids, ids), len(self.ids) - 1)
            found = self.ids[slot] == ids
            known = found & (self.ref_t[slot] != _UNSET)
        else:
            slot = np.zeros(n_groups, np.int64)
            found = known = np.zeros(n_groups, dtype=bool)
        virtual = known.astype(np.int64)
        real = np.arange(n) + np.cumsum(virtual)[group]  # node of each row
        count = np.diff(np.append(np.flatnonzero(starts), n))
        size = count + virtual
        g_end = np.cumsum(size)
        g_start = g_end - size
        n_nodes = int(g_end[-1])
        vnodes = g_start[known]
        vslot = slot[known]
        t_rows, x_rows, y_rows = t[rows], xy[rows, 0], xy[rows, 1]
        if len(vnodes):
            T = np.empty(n_nodes, np.int64)
            x = np.empty(n_nodes)
            y = np.empty(n_nodes)
            T[real], x[real], y[real] = t_rows, x_rows, y_rows
            T[vnodes], x[vnodes], y[vnodes] = (
                self.ref_t[vslot], self.ref_xy[vslot, 0], self.ref_xy[vslot, 1]
            )
        else:
            T, x, y = t_rows, x_rows, y_rows
        node_end = np.repeat(g_end, size)

        nxt = self._next_resets(T, x, y, node_end, g_start, size)
        chain = _chains(nxt, g_start)

        # each row's reference: the last chain node before it (a track's first node is on
        # the chain, so it lies in the row's own track), except for the first node of a track
        # without one, which has no reference (it resets: stale)
        root = starts.copy()
        root[starts] = ~known
        node_index = np.arange(n_nodes)
        last_chain = np.maximum.accumulate(np.where(chain, node_index, -1))
        before = real - 1  # -1 only for a root: masked
        ref = last_chain[before]
        dt = t_rows - T[ref]
        fresh = ~root & (dt > 0) & (dt <= self.max_gap_ns)
        stale = ~fresh & (root | (dt != 0))
        dx = x_rows - x[ref]
        dy = y_rows - y[ref]
        dist = np.hypot(dx, dy)
        moved = fresh & (dist >= self.min_displacement)
        diff_heading = np.arctan2(dy, dx)
        if self.look_ahead:
            self._look(rows, kr, chain, last_chain, real, ref, root, stale, moved,
                       diff_heading, dist, dt, T, vnodes, vslot)

        # previous heading: the value of the last event before each row (a track's first node
        # is an event; a root is stale, so its own previous heading is NaN anyway)
        vel = has_vel[rows]
        event = np.ones(n_nodes, dtype=bool)
        value = np.full(n_nodes, np.nan)
        value[vnodes] = self.heading[vslot]
        event[real] = vel | moved | stale
        value[real] = np.where(vel, heading[rows], np.where(moved, diff_heading, np.nan))
        last_event = np.maximum.accumulate(np.where(event, node_index, -1))
        prev = np.where(stale, np.nan, value[last_event[before]])
        diff_heading = np.where(moved, diff_heading, prev)
        use = np.flatnonzero(~vel & fresh)
        heading[rows[use]] = diff_heading[use]
        speed[rows[use]] = dist[use] / (dt[use] * 1e-9)
        if self.look_ahead:  # a waiting row that got a heading (a velocity's carry) waits not
            self.look.waiting[rows] &= np.isnan(heading[rows])

        # the state after the call: per track, its last chain node and its last event
        last = g_end - 1
        ref_last, ev_last = last_chain[last], last_event[last]
        new_t, new_heading = T[ref_last], value[ev_last]
        new_xy = np.stack([x[ref_last], y[ref_last]], axis=1)
        hit = slot[found]
        self.ref_t[hit], self.ref_xy[hit] = new_t[found], new_xy[found]
        self.heading[hit] = new_heading[found]
        if not found.all():
            at = np.searchsorted(self.ids, ids[~found])
            self.ids = np.insert(self.ids, at, ids[~found])
            self.ref_t = np.insert(self.ref_t, at, new_t[~found])
            self.ref_xy = np.insert(self.ref_xy, at, new_xy[~found], axis=0)
            self.heading = np.insert(self.heading, at, new_heading[~found])

    def _look(
        self, rows: I64, kr: I64, chain: npt.NDArray[np.bool_], last_chain: I64, real: I64,
        ref: I64,
        root: npt.NDArray[np.bool_], stale: npt.NDArray[np.bool_], moved: npt.NDArray[np.bool_],
        diff_heading: F64, dist: F64, dt: I64, T: I64, vnodes: I64, vslot: I64,
    ) -> None:
        """:attr:`look` of ``rows`` (in node order): a reference *waits* while no heading has
        been taken from it (a track's first row, a stale reset, a remembered reference
        without a heading); the rows it is the reference of wait with it, and the track's
        next reset settles them -- with its displacement's heading when it moved, with none
        when the reference lapsed (stale), and with its speed (``dist / dt``, as a moved
        row's own)."""
        waits = np.zeros(len(T), dtype=bool)
        waits[real] = stale  # (roots are stale)
        waits[vnodes] = np.isnan(self.heading[vslot])
        owner = last_chain[real]  # each row's reference, or the row itself on the chain
        on_chain = chain[real]
        settles = on_chain & ~root & waits[np.where(root, 0, ref)]
        look = self.look
        look.key[rows] = kr
        look.waiting[rows] = waits[owner]
        look.expire_ns[rows] = T[owner] + self.max_gap_ns
        look.settles[rows] = settles
        given = settles & moved  # (moved rows are fresh: dt > 0)
        look.heading[rows] = np.where(given, diff_heading, np.nan)
        look.speed[rows] = np.nan
        look.speed[rows[given]] = dist[given] / (dt[given] * 1e-9)

    def _next_resets(
        self, T: I64, x: F64, y: F64, node_end: I64, g_start: I64, size: I64
    ) -> I64:
        """For every node ``i``: the first later node ``j`` of its track that resets the
        reference if ``i`` is the reference (``len(T)`` when none does): ``j`` earlier than
        ``i``, more than ``max_gap_s`` later, or later and at least ``min_displacement`` away.

        Nodes at ``i``'s own time never reset (the run of them after ``i`` is skipped at once).
        In a track whose nodes are in time order (stamps in order: the usual case) the nodes
        within ``max_gap_s`` of ``i`` are a range found by one ``searchsorted``, and only
        distance can reset inside it: the node right after the equal-time run is tried first
        (a walker's next node resets), then a range whose bounding box lies inside the
        ``min_displacement`` circle around ``i`` is passed over at once (a person standing
        still: two lookups in a sparse min/max table), and only the rest is searched node by
        node, in blocks of 1, 2, 4, ... nodes. Tracks out of time order are searched the
        general way, blocks from the equal-time run on."""
        n = len(T)
        nxt = np.full(n + 1, n, np.int64)
        if n == 0:
            return nxt
        # the first node after each node's own time: j > i with T[j] != T[j - 1]
        same = np.flatnonzero(T[1:] == T[:-1])
        start = np.arange(1, n + 1)
        if same.size:
            later = np.full(n, n)
            later[:-1] = np.where(T[1:] != T[:-1], np.arange(1, n), n)
            start = np.minimum.accumulate(later[::-1])[::-1]
        start = np.minimum(start, node_end)
        g_end = g_start + size
        # tracks whose nodes are in time order
        back = np.r_[0, np.cumsum((T[1:] < T[:-1]) & (node_end[1:] == node_end[:-1]))]
        in_order = back[g_end - 1] == back[g_start]
        t_first, t_last = T[g_start], T[g_end - 1]
        stride = int((t_last - t_first)[in_order].max(initial=0)) + self.max_gap_ns + 1
        if len(size) * stride >= 2**62:  # absurd stamp spans: everything the general way
            in_order[:] = False
        ordered = np.repeat(in_order, size)
        rest = np.flatnonzero(~ordered & (start < node_end))
        if rest.size:
            found, j = self._search(T, x, y, rest, start[rest], node_end[rest], general=True)
            nxt[rest[found]] = j[found]
        todo = np.flatnonzero(ordered & (start < node_end))
        # the first node after i's own time (a walker's, or one after a gap, resets)
        a = start[todo]
        gap = T[a] - T[todo] > self.max_gap_ns  # > 0 in a track in time order
        first = gap | (np.hypot(x[a] - x[todo], y[a] - y[todo]) >= self.min_displacement)
        nxt[todo[first]] = a[first]
        todo, a = todo[~first], a[~first] + 1
        if todo.size == 0:
            return nxt
        # the others: the nodes within max_gap_s (a range, by one searchsorted on a key that
        # orders tracks, then time) can only reset by distance; none does: stale at the end
        rel = np.where(ordered, T - np.repeat(np.where(in_order, t_first, 0), size), 0)
        key = np.repeat(np.arange(len(size), dtype=np.int64) * stride, size) + rel
        lim = np.minimum(np.searchsorted(key, key[todo] + self.max_gap_ns, side="right"),
                         node_end[todo])
        nxt[todo] = np.where(lim < node_end[todo], lim, n)
        open_ = a < lim
        todo, a, lim = todo[open_], a[open_], lim[open_]
        if todo.size == 0:
            return nxt
        inside = _inside_circle(x, y, todo, a, lim, self.min_displacement)
        todo, a, lim = todo[~inside], a[~inside], lim[~inside]
        if todo.size:
            found, j = self._search(T, x, y, todo, a, lim, general=False)
            nxt[todo[found]] = j[found]
        return nxt

    def _search(
        self, T: I64, x: F64, y: F64, nodes: I64, pos: I64, end: I64, general: bool
    ) -> tuple[npt.NDArray[np.bool_], I64]:
        """The first reset after each of ``nodes`` among nodes ``pos .. end - 1`` (found,
        index), searched in blocks of 1, 2, 4, ... nodes per still-unresolved node. ``general``
        checks every rule; otherwise the range is known to lie within ``max_gap_s`` after the
        node and only the distance is checked."""
        found = np.zeros(len(nodes), dtype=bool)
        out = np.zeros(len(nodes), np.int64)
        active = np.arange(len(nodes))
        width = 1
        gap, min_d = self.max_gap_ns, self.min_displacement
        while active.size:
            width = max(1, min(width, _SCAN_BUDGET // active.size))
            i = nodes[active]
            j = pos[active][:, None] + np.arange(width)
            stop = end[active]
            valid = j < stop[:, None]
            jc = np.where(valid, j, i[:, None])
            dist = np.hypot(x[jc] - x[i][:, None], y[jc] - y[i][:, None])
            reset = dist >= min_d
            if general:
                dt = T[jc] - T[i][:, None]
                reset = (dt < 0) | (dt > gap) | ((dt > 0) & reset)
            reset &= valid
            hit = reset.any(axis=1)
            if hit.any():
                found[active[hit]] = True
                out[active[hit]] = j[hit, reset[hit].argmax(axis=1)]
            pos[active] += width
            more = ~hit & (pos[active] < stop)
            active = active[more]
            width *= 2
        return found, out


_UNSET = np.iinfo(np.int64).min
#: Largest (unresolved nodes x block width) matrix of one step of the reset search.
_SCAN_BUDGET = 1 << 20
