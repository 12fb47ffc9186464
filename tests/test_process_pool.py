"""``aion_cli.process_pool``: how the shards of a parallel build reach the worker processes.

A month of daily logs is a shard per day, and the parent wrote every task into a pipe before it
started a worker to read them: past a pipe's 64 KiB (about 26 days' tasks) the write blocked
for ever, so ``aion build days/*.mcap`` with the default ``--workers`` (one per core) hung on
its 28th daily log.
"""

from __future__ import annotations

import signal
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

import aion_cli.process_pool as pool
from aion_cli.build_report import NoProgress


@dataclass(frozen=True)
class _Task:
    """As much of a ShardTask as the pool reads, 4 KiB large as a real one is 2.6 KiB."""

    index: int
    logs: tuple[Path, ...]
    padding: bytes = field(default=b"x" * 4096)


class _BuiltError(Exception):
    """What the fake shard build raises: the worker got its task."""


def _build(task: Any, sink: Any) -> Any:
    raise _BuiltError(f"shard {task.index}")


def _stuck(signum: int, frame: Any) -> None:
    raise TimeoutError("the parent blocked handing out the shards")


@pytest.mark.skipif(sys.platform != "linux", reason="workers fork only on Linux")
def test_more_tasks_than_a_pipe_holds_reach_the_workers(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import multiprocessing as mp

    monkeypatch.setattr(pool, "build_shard", _build)
    monkeypatch.setattr(pool, "_context", lambda: mp.get_context("fork"))
    tasks = [_Task(k, (Path(f"day{k}.mcap"),)) for k in range(40)]  # 160 KiB of tasks
    previous = signal.signal(signal.SIGALRM, _stuck)
    signal.alarm(20)
    try:
        # a worker built a shard, the parent was not blocked: which shard's error comes first
        # is the workers' race (under load one worker ran through shards 0-21 while its
        # queue's feeder thread waited for the GIL, and the other's shard 22 arrived first)
        with pytest.raises(_BuiltError, match=r"^shard \d+$"):
            pool.run_in_processes(tasks, 2, None, NoProgress())  # type: ignore[arg-type]
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def test_the_workers_take_every_shard_once_in_order() -> None:
    import multiprocessing as mp

    tasks = [_Task(k, ()) for k in range(5)]
    counter = mp.get_context().Value("q", 0)
    taken = [pool._take(tasks, counter) for _ in range(7)]  # type: ignore[arg-type]
    assert [t.index if t else None for t in taken] == [0, 1, 2, 3, 4, None, None]
