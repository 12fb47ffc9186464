"""Running a parallel build's shards in worker processes on this machine (``--workers N``).

Workers are forked from the parent (``fork`` on Linux when it runs no other thread; else from a
server process that has imported the build once, ``forkserver``), so starting one costs
milliseconds, not a fresh interpreter's imports. The workers take the shards in order by a
counter they share (:func:`_take`), not from a pipe: the tasks of a month of daily logs outgrow
a pipe's 64 KiB, and a parent that wrote them all before starting the workers blocked forever.
Each reports its progress through a queue
and hands its result's large arrays over in a file (:mod:`aion_cli.result_files`: half the
time of the pipe, no second copy); the parent shows one bar per worker and folds finished
shards in time order while the others are still running (:func:`aion_cli.shard_fold.fold`).
Ctrl-C or an error in any shard terminates every worker before the error reaches the caller.
"""

from __future__ import annotations

import sys
import time
from typing import TYPE_CHECKING, Any

from aion_cli.shard_fold import (
    Folded,
    ShardResult,
    ShardTask,
    build_shard,
    fold,
    learn_rest,
)

if TYPE_CHECKING:
    from pathlib import Path

    from aion_cli.build_report import ProgressSink
    from aion_cli.engine.state import MapState


class QueueProgress:
    """A worker's :class:`~aion_cli.build_report.ProgressSink`: phases and progress go to
    the parent through a queue, at most every 0.1 s per worker."""

    def __init__(self, queue: Any, key: int) -> None:
        self.queue, self.key = queue, key
        self._unsent = 0
        self._last = 0.0

    def start(self, description: str, total: int, unit: str = "msgs") -> None:
        self._flush()
        self.queue.put(("start", self.key, description, int(total), unit))

    def advance(self, n: int) -> None:
        self._unsent += int(n)
        now = time.monotonic()
        if now - self._last >= 0.1:
            self._flush()
            self._last = now

    def _flush(self) -> None:
        if self._unsent:
            self.queue.put(("advance", self.key, self._unsent))
            self._unsent = 0

    def close(self) -> None:
        self._flush()


def _take(tasks: list[ShardTask], next_task: Any) -> ShardTask | None:
    """The next shard no worker has taken yet (None when every one is taken): ``next_task``
    is a shared counter (``multiprocessing.Value``) of the shards handed out, in order."""
    with next_task.get_lock():
        index = int(next_task.value)
        if index >= len(tasks):
            return None
        next_task.value = index + 1
    return tasks[index]


def _worker(
    tasks: list[ShardTask], next_task: Any, out: Any, folder: Path | None = None
) -> None:
    """A worker process: the shards of ``tasks`` it takes (:func:`_take`) until none is
    left; each result (or error) and the progress go to ``out`` as ``(kind, shard,
    payload)``, a result's large arrays through a file in ``folder``
    (:mod:`aion_cli.result_files`). The tasks come with the process (a forked worker shares
    the parent's list; a forkserver's reads it as it starts), never through a pipe the
    parent would have to fill before any worker reads it."""
    import signal

    from aion_cli.formats.interrupts import release_held_signals

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent stops the workers on Ctrl-C
    # and it stops them with SIGTERM: a forked worker inherits the CLI's handler, which
    # unwinds like Ctrl-C (for the parent's map file) and would print a worker's traceback
    # under the parent's one-line error; a worker writes no file, so it ends at once
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "SIGHUP"):  # a closed terminal hangs the parent up, which stops them
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
    # a forked worker starts with the three blocked (the parent starts the workers inside
    # interrupts_held(forks=True)): one sent before this line (Ctrl-C at once, the parent's
    # SIGTERM) is pending, and acts now, by the handlers above
    release_held_signals()
    from aion_cli.result_files import send
    while (task := _take(tasks, next_task)) is not None:
        sink = QueueProgress(out, task.index)
        try:
            result = build_shard(task, sink)
        except BaseException as exc:
            sink.close()
            out.put(("error", task.index, _picklable(exc)))
            continue
        sink.close()
        send(out, task.index, result, folder)


def _picklable(exc: BaseException) -> BaseException:
    """``exc`` if it survives pickling, else a RuntimeError with its text."""
    import pickle

    try:
        pickle.loads(pickle.dumps(exc))
    except Exception:
        return RuntimeError(f"{type(exc).__name__}: {exc}")
    return exc


def run_in_processes(
    tasks: list[ShardTask], workers: int, previous: MapState | None, progress: ProgressSink
) -> tuple[Folded, list[ShardResult]]:
    """Build the shards in ``workers`` processes and fold them onto ``previous``."""
    from aion_cli.result_files import result_folder

    with result_folder() as folder:
        return _run(tasks, workers, previous, progress, folder)


def _run(
    tasks: list[ShardTask],
    workers: int,
    previous: MapState | None,
    progress: ProgressSink,
    folder: Path,
) -> tuple[Folded, list[ShardResult]]:
    from aion_cli.errors import AionError
    from aion_cli.formats.interrupts import interrupts_held
    from aion_cli.result_files import receive

    ctx = _context()
    out = ctx.Queue()
    next_task = ctx.Value("q", 0)  # shards handed out so far (_take)
    procs = [
        ctx.Process(target=_worker, args=(tasks, next_task, out, folder), daemon=True)
        for _ in range(workers)
    ]
    bars = _Bars(progress, tasks)
    try:
        # Ctrl-C (or SIGTERM) while they start is held back until every worker has: one
        # forked but not yet known to its Process (a KeyboardInterrupt between the fork and
        # its return) would not be stopped below and would build on, an orphan; a worker
        # starts with the signals blocked until it has its own handlers (_worker)
        with interrupts_held(forks=True):
            for proc in procs:
                proc.start()
        done: dict[int, ShardResult] = {}
        summaries: list[ShardResult] = []
        folded = Folded(previous)
        next_index = 0
        stopped: list[bool] = []  # the workers, after a scene-graph change

        def stop() -> None:
            # the shard being folded is learnt again in sequence, and the later shards'
            # graphs change too: stop the workers before they cost the fold their cores
            _stop(procs)
            stopped.append(True)

        while next_index < len(tasks):
            item = _next(out, procs)
            if item is None:
                raise AionError(
                    "a worker process of the parallel build died",
                    hint="rerun with --workers 1 to build in one process (nothing was written)",
                )
            kind, index = item[0], item[1]
            if kind == "error":
                raise item[2]
            if kind not in ("result", "result-file"):
                bars.show(item)
                continue
            done[index] = item[2] if kind == "result" else receive(item)
            while next_index in done:  # in time order, as soon as possible
                result = done.pop(next_index)
                begin = time.perf_counter()
                folded = fold(folded, result, tasks[next_index], None if stopped else stop)
                folded.seconds += time.perf_counter() - begin
                summaries.append(result.without_state())
                bars.folded(next_index)
                next_index += 1
            if stopped and next_index < len(tasks):
                rest = learn_rest(folded, tasks[next_index:], len(tasks), done, bars.folded)
                return rest, summaries
        return folded, summaries
    finally:
        _stop(procs)  # done, failed or interrupted: no worker outlives the build
        out.close()
        out.cancel_join_thread()


def _stop(procs: list[Any]) -> None:
    """End every worker still running and wait for them."""
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        if proc.pid is not None:  # started (a fork that failed leaves the rest unstarted)
            proc.join(timeout=10)


def _next(out: Any, procs: list[Any]) -> Any:
    """The next item from the workers; None when they have all ended without sending one."""
    import queue as queues

    while True:
        try:
            return out.get(timeout=0.2)
        except queues.Empty:
            if not any(p.is_alive() for p in procs):
                try:
                    return out.get(timeout=0.5)
                except queues.Empty:
                    return None


FORK_SAFE_THREADS = frozenset({"aion-hash-logs"})
"""aion's own threads that a worker may be forked beside: the build's log hashing
(:class:`aion_cli.provenance.DistinctLogs`) only reads its files and updates its sha256
objects, which a worker never touches, so no lock a worker needs can be held by it."""


def _context() -> Any:
    """``fork`` on Linux while this process runs no other thread (but those of
    :data:`FORK_SAFE_THREADS`): the workers start with everything the parent imported, in
    milliseconds. With other threads (a progress bar's refresh, an event loop) a fork could
    copy a lock one of them holds, so the workers fork from a single-threaded server process
    instead (``forkserver``, the build's modules preloaded once), as on every other
    platform."""
    import multiprocessing as mp
    import threading

    main = threading.main_thread()
    single = all(t is main or t.name in FORK_SAFE_THREADS for t in threading.enumerate())
    if single and "fork" in mp.get_all_start_methods() and sys.platform.startswith("linux"):
        return mp.get_context("fork")
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(
        [
            "aion_cli.pipeline",
            "aion_cli.parallel_build",
            "aion_cli.detection_feed",
            "aion_cli.formats.logs",
            "aion_cli.engine.mapper",
            "scipy.spatial",
        ]
    )
    return ctx


class _Bars:
    """One progress bar per shard's worker phase, plus the fold's."""

    def __init__(self, progress: ProgressSink, tasks: list[ShardTask]) -> None:
        self.progress = progress
        self.part = getattr(progress, "part", None)
        self.part_advance = getattr(progress, "part_advance", None)
        self.names = {t.index: t.logs[0].name + (" ..." if len(t.logs) > 1 else "") for t in tasks}
        progress.start(f"joining {len(tasks)} shards", len(tasks), "shards")

    def show(self, item: tuple[Any, ...]) -> None:
        """A worker's progress message (``start`` or ``advance``)."""
        kind, key = item[0], item[1]
        if kind == "start" and self.part is not None:
            self.part(key, f"shard {key + 1} ({self.names[key]}): {item[2]}", item[3], item[4])
        elif kind == "advance" and self.part_advance is not None:
            self.part_advance(key, item[2])

    def folded(self, index: int) -> None:
        self.progress.advance(1)
