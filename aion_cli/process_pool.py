"""Running a parallel build's shards in worker processes on this machine (``--workers N``).

Workers are forked from the parent (``fork`` on Linux when it runs no other thread; else from a
server process that has imported the build once, ``forkserver``), so starting one costs
milliseconds, not a fresh interpreter's imports. Each reports its
progress through a queue; the parent shows one bar per worker and folds finished shards in
time order while the others are still running (:func:`aion_cli.parallel_build.fold`). Ctrl-C
or an error in any shard terminates every worker before the error reaches the caller.
"""

from __future__ import annotations

import sys
import time
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import TYPE_CHECKING, Any

from aion_cli.parallel_build import Folded, ShardResult, ShardTask, build_shard, fold

if TYPE_CHECKING:
    from aion_cli.build_report import ProgressSink
    from aion_cli.engine.state import MapState

_QUEUE: Any = None  # the worker's progress queue (set by the pool's initializer)


class QueueProgress:
    """A worker's :class:`~aion_cli.build_report.ProgressSink`: phases and progress go to
    the parent through a queue, at most every 0.1 s per worker."""

    def __init__(self, queue: Any, key: int) -> None:
        self.queue, self.key = queue, key
        self._unsent = 0
        self._last = 0.0

    def start(self, description: str, total: int, unit: str = "msgs") -> None:
        self._flush()
        self.queue.put((self.key, "start", description, int(total), unit))

    def advance(self, n: int) -> None:
        self._unsent += int(n)
        now = time.monotonic()
        if now - self._last >= 0.1:
            self._flush()
            self._last = now

    def _flush(self) -> None:
        if self._unsent:
            self.queue.put((self.key, "advance", self._unsent))
            self._unsent = 0

    def close(self) -> None:
        self._flush()


def _init_worker(queue: Any) -> None:
    import signal

    global _QUEUE
    _QUEUE = queue
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent stops the workers on Ctrl-C


def _run_task(task: ShardTask) -> ShardResult:
    sink = QueueProgress(_QUEUE, task.index)
    try:
        return build_shard(task, sink)
    finally:
        sink.close()


def run_in_processes(
    tasks: list[ShardTask], workers: int, previous: MapState | None, progress: ProgressSink
) -> tuple[Folded, list[ShardResult]]:
    """Build the shards in ``workers`` processes and fold them onto ``previous``."""
    ctx = _context()
    queue = ctx.Queue()
    executor = ProcessPoolExecutor(
        workers, mp_context=ctx, initializer=_init_worker, initargs=(queue,)
    )
    bars = _Bars(progress, tasks)
    futures: list[Future[ShardResult]] = []
    try:
        futures = [executor.submit(_run_task, task) for task in tasks]
        done_results: dict[int, ShardResult] = {}
        summaries: list[ShardResult] = []
        folded = Folded(previous)
        next_index = 0
        waiting: set[Future[ShardResult]] = set(futures)
        while waiting:
            finished, waiting = wait(waiting, timeout=0.2, return_when=FIRST_COMPLETED)
            bars.drain(queue)
            for future in finished:
                result = _result(future)  # a worker's error is raised here
                done_results[result.index] = result
            while next_index in done_results:  # in time order, as soon as possible
                result = done_results.pop(next_index)
                begin = time.perf_counter()
                folded = fold(folded, result, tasks[next_index])
                folded.seconds += time.perf_counter() - begin
                summaries.append(result.without_state())
                bars.folded(next_index)
                next_index += 1
        bars.drain(queue)
        return folded, summaries
    except BaseException:
        _stop(executor, futures)
        raise
    else:
        executor.shutdown(wait=True)
    finally:
        queue.close()
        queue.join_thread()


def _result(future: Future[ShardResult]) -> ShardResult:
    """A shard's result; a worker that died (killed, out of memory) is an :class:`AionError`
    with what to do about it, not a bare ``BrokenProcessPool``."""
    from concurrent.futures.process import BrokenProcessPool

    from aion_cli.errors import AionError

    try:
        return future.result()
    except BrokenProcessPool as exc:
        raise AionError(
            f"a worker process of the parallel build died ({exc})",
            hint="rerun with --workers 1 to build in one process (nothing was written)",
        ) from exc


def _stop(executor: ProcessPoolExecutor, futures: list[Future[ShardResult]]) -> None:
    """An error or Ctrl-C: cancel what has not started and stop the workers still busy (idle
    ones leave with the pool's shutdown)."""
    for future in futures:
        future.cancel()
    busy = any(f.running() for f in futures)
    processes = list(getattr(executor, "_processes", {}).values())
    executor.shutdown(wait=not busy, cancel_futures=True)
    if busy:
        for process in processes:
            process.terminate()
        for process in processes:
            process.join(timeout=10)


def _context() -> Any:
    """``fork`` on Linux while this process runs no other thread: the workers start with
    everything the parent imported, in milliseconds. With other threads (a progress bar's
    refresh, an event loop) a fork could copy a lock one of them holds, so the workers fork
    from a single-threaded server process instead (``forkserver``, the build's modules
    preloaded once), as on every other platform."""
    import multiprocessing as mp
    import threading

    single = threading.active_count() == 1
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

    def drain(self, queue: Any) -> None:
        import queue as queues

        while True:
            try:
                item = queue.get_nowait()
            except queues.Empty:
                return
            key = item[0]
            if item[1] == "start" and self.part is not None:
                self.part(key, f"shard {key + 1} ({self.names[key]}): {item[2]}", item[3], item[4])
            elif item[1] == "advance" and self.part_advance is not None:
                self.part_advance(key, item[2])

    def folded(self, index: int) -> None:
        self.progress.advance(1)
