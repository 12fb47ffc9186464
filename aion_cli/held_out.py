"""Held-out logs read as a build reads them, for judging a map's forecast on them.

``aion evaluate holdout MAP LOG...`` needs the test logs' detections exactly as ``aion build``
would take them into a map — in the map frame, with the headings the build estimates (id-less
detections linked into tracks), after the same time and topic rules — and the windows the logs
observed. :func:`read_held_out` runs the build's own reading (:class:`aion_cli.pipeline._Build`
with the map's model config) into a Mapper whose state records instead of learning: every
batch the map accepted, every window it recorded with whether a fixed sensor covered it, and,
in a window only a moving robot observed, which of the map's own places (``watch``: their
positions) were within its sensor range then — the build's own observation rule, applied to
the map being judged. Nothing is written and no day is scored.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from aion_cli.engine.state import MapState
from aion_cli.engine.types import F64, I64, DetectionBatch
from aion_cli.pipeline import _Build

if TYPE_CHECKING:
    from aion_cli.build_options import BuildOptions
    from aion_cli.build_report import BuildReport, ProgressSink
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.mapper import Mapper


@dataclass
class HeldOut:
    """What the test logs hold for a map: the detections it would accept (``batch``), the
    windows they recorded (``windows``, sorted window indices, and ``fixed``, whether a fixed
    sensor covered each: then every place was observed in it) and the build's report (its
    observation, notes, topics)."""

    batch: DetectionBatch
    windows: I64
    fixed: np.ndarray
    report: BuildReport
    notes: list[str] = field(default_factory=list)
    #: per window only a robot observed: the indices (into ``watch``) of the map's places
    #: within its sensor range then
    seen: dict[int, I64] = field(default_factory=dict)
    #: per such window: the share of it each of those places was in range (their exposure,
    #: ``ModelConfig.exposure``; 1 each without it)
    seen_exposure: dict[int, F64] = field(default_factory=dict)
    #: per window of ``windows``: the share of a fixed sensor's window the logs recorded (a
    #: log that starts or ends inside it), 1 for the others; None: every window whole
    fixed_share: F64 | None = None


class _RecordingState(MapState):
    """A map state that keeps the windows it records and forgets each day instead of
    scoring it (the held-out logs teach nothing)."""

    recorded: list[tuple[int, bool]]
    watch: F64 | None
    seen: dict[int, I64]
    seen_exposure: dict[int, F64]

    def record_window(
        self,
        window: int,
        fixed: bool,
        observed: I64,
        count_rows: I64,
        counts: Any,
        exposure: Any = None,
        fixed_share: float = 1.0,
    ) -> None:
        self.recorded.append((int(window), bool(fixed)))
        if not fixed:
            self.note_seen(int(window))
        super().record_window(window, fixed, observed, count_rows, counts, exposure, fixed_share)

    def note_seen(self, window: int) -> None:
        """The watched places within the robot's range in ``window`` (its poses are still
        held: they are pruned only once the window is recorded)."""
        if self.watch is None or window in self.seen:
            return
        cover = self.observation.coverage(self.watch, window, self.window_ns, self.config)
        self.seen[window] = np.flatnonzero(cover > 0).astype(np.int64)
        self.seen_exposure[window] = cover[cover > 0]

    def close_day(self, rows: I64 | None = None) -> None:
        self.pending.clear()


class _Reading(_Build):
    """The build's reading into a recording Mapper (no previous map, no shards)."""

    batches: list[DetectionBatch]
    state: _RecordingState
    watch: F64 | None = None
    unusable_outcome = "the test logs hold nothing to score the map on"
    sim_clock_subject = ("the test logs' data", False)

    def _mapper(self, config: ModelConfig) -> Mapper:
        from aion_cli.engine.mapper import ACCEPTED, Mapper

        state = cast(_RecordingState, _RecordingState.empty(config))  # cls(...): a recorder
        state.recorded = []
        state.watch = self.watch
        state.seen, state.seen_exposure = {}, {}
        self.state = state
        batches = self.batches = []

        class Recorder(Mapper):
            def add_detections(
                self, batch: DetectionBatch, codes: np.ndarray | None = None
            ) -> dict[str, int]:
                if codes is None:
                    codes = np.empty(len(batch), dtype=np.int8)
                drops = super().add_detections(batch, codes)
                kept = codes == ACCEPTED
                if kept.any():
                    batches.append(batch if kept.all() else batch.select(kept))
                return drops

        return Recorder(config, state)


def read_held_out(
    opts: BuildOptions,
    config: ModelConfig,
    progress: ProgressSink | None = None,
    watch: F64 | None = None,
) -> HeldOut:
    """The logs of ``opts`` read as a build of a map with ``config`` would read them (see the
    module docstring); ``watch``: the map's places (x, y), whose robot coverage is noted per
    window. :class:`~aion_cli.errors.InputError` as a build raises it (no log, no detection
    topic, nothing readable)."""
    from dataclasses import replace

    from aion_cli.build_report import NoProgress
    from aion_cli.errors import InputError

    if not opts.logs:
        raise InputError("no test log given", hint="aion evaluate holdout MAP LOG...")
    reading = _Reading(replace(opts, config=config, workers=1), progress or NoProgress())
    reading.watch = watch
    reading._distinct_logs()  # the distinct logs (a copy given twice is read once)
    reading.learn(reading.config())
    state = reading.state
    batch = DetectionBatch.concat(reading.batches)
    recorded = sorted(set(state.recorded))
    last = state.open_window  # still open at the logs' end: recorded as a query would
    if last is not None:
        at = np.array([last], np.int64)
        fixed_last = bool(state.observation.fixed_mask(at, state.window_ns)[0])
        if not fixed_last:  # the robot's places in range then, as for every other window
            state.note_seen(int(last))
        robot_saw = int(last) in state.seen and state.seen[int(last)].size > 0
        if fixed_last or robot_saw or bool(np.any(batch.t_ns // state.window_ns == last)):
            recorded.append((int(last), fixed_last))
    windows = np.array([w for w, _ in recorded], dtype=np.int64)
    fixed = np.array([f for _, f in recorded], dtype=bool)
    if windows.size and np.any(np.diff(windows) == 0):  # a window recorded twice: keep one
        keep = np.concatenate([[True], np.diff(windows) != 0])
        windows, fixed = windows[keep], fixed[keep]
    seen = {w: state.seen[w] for w in windows[~fixed].tolist() if w in state.seen}
    exposure = {w: state.seen_exposure[w] for w in seen}
    share = np.where(fixed, state.observation.fixed_share(windows, state.window_ns, config), 1.0)
    # every declared window counts (a new map's fill, from the spans' start to their end:
    # log_observed.fill_start, fill_end), so no note of declared windows left out
    notes = list(reading.report.notes)
    return HeldOut(batch, windows, fixed, reading.report, notes, seen, exposure, share)
