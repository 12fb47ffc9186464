"""Running a parallel build on a Dask cluster (``aion build ... --scheduler ADDRESS``).

The same plan as ``--workers`` (:mod:`aion_cli.parallel_build`): one task per shard reads its
logs *by path* (every worker must see them at the same absolute paths, e.g. on a shared file
system; :func:`cluster_paths` makes the client's relative ones absolute)
and returns its map state (pickled bytes, Dask's own serialisation); the fold runs on the
cluster too, as a chain of tasks in time order (each joins one shard onto the map before it,
or learns the shard's logs onto it in sequence where a join would not be exact), so the
shards' maps never travel to the client: only the finished map and the shards' summaries do.
After a fold whose scene graph changed, the later shards are learnt in sequence as one task
and their builds cancelled, as the local pool stops its workers.
Needs the ``dask`` extra (``pip install 'aion[dask]'``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import uuid
from typing import TYPE_CHECKING, Any

from aion_cli.errors import InputError, MissingPackageError
from aion_cli.shard_fold import (
    Folded,
    ShardResult,
    ShardTask,
    build_shard,
    fold,
    learn_rest,
)

if TYPE_CHECKING:
    from aion_cli.build_report import ProgressSink
    from aion_cli.engine.state import MapState


def _client(address: str) -> Any:
    try:
        from distributed import Client
    except ImportError as exc:
        raise MissingPackageError(
            "--scheduler needs Dask's distributed package",
            hint="pip install 'aion[dask]'",
        ) from exc
    try:
        # An address that is malformed (no port, an unknown scheme) or that no scheduler
        # answers at is refused before a Client is made: one that fails after it started
        # leaves a half-made client whose clean-up prints a traceback 10 s later, at exit.
        _probe(address)
        return Client(address, timeout="5s", set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(
            f"cannot reach the Dask scheduler at {address}: {exc}",
            hint="give the scheduler's address, e.g. --scheduler tcp://10.0.0.5:8786",
        ) from exc


def _probe(address: str) -> None:
    """Connect to ``address`` and hang up (raises OSError or ValueError where no Dask
    scheduler answers), on an event loop of its own thread: the caller's may be running."""
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm import connect

    async def probe() -> None:
        comm = await connect(address, timeout=5)
        await comm.close()

    with ThreadPoolExecutor(1) as pool:
        pool.submit(asyncio.run, probe()).result()


WORKER_WAIT_S = 60.0
"""How long a scheduler without any worker is given for one to join."""


def _check_workers(client: Any, address: str) -> None:
    """Refuse a cluster whose workers cannot import aion: a worker that cannot unpickle a
    shard's task dies, the scheduler hands it on until none is left, and the build waited
    for ever. (``importlib.util.find_spec`` runs there without aion's code.)"""
    import importlib.util

    if not client.scheduler_info().get("workers"):  # an adaptive cluster may start some
        try:
            client.wait_for_workers(1, timeout=WORKER_WAIT_S)
        except TimeoutError as exc:
            raise InputError(
                f"the Dask scheduler at {address} has no workers (none joined within "
                f"{WORKER_WAIT_S:g} s): the shards would wait for ever",
                hint="start workers (dask worker ADDRESS), or build with --workers N here",
            ) from exc
    found = client.run(importlib.util.find_spec, "aion_cli.shard_fold", on_error="return")
    lacking = {w: r for w, r in found.items() if r is None or isinstance(r, BaseException)}
    if lacking:
        worker, why = next(iter(lacking.items()))
        more = f" and {len(lacking) - 1} more" if len(lacking) > 1 else ""
        raise MissingPackageError(
            f"{len(lacking)} of the {len(found)} Dask workers at {address} cannot import "
            f"aion ({worker}: {why or 'not found'}{more}): each shard runs aion's code on a "
            "worker",
            hint="install the same aion in the workers' environment (pip install "
            "'aion[dask]'), or build with --workers N on this machine",
        )


def _summary(result: ShardResult) -> ShardResult:
    return result.without_state()


def _fallbacks(folded: Folded) -> int:
    """The fold's count of shards learnt again because their scene graph changed (a small
    result the client waits for after each fold)."""
    return folded.graph_fallbacks


def cluster_paths(task: ShardTask) -> ShardTask:
    """``task`` with its logs and the files its options name (``--graph``,
    ``--detections-mapping``) made absolute: a Dask worker runs in a working directory of its
    own, where a path relative to the client's (``aion build run1.mcap --scheduler ...`` in
    the logs' folder) named no file, and the build failed with "no such file or folder:
    run1.mcap" although every worker saw the logs at the same absolute paths."""
    opts = task.opts
    files = {
        name: path.absolute()
        for name in ("graph_file", "detections_mapping")
        if (path := getattr(opts, name)) is not None
    }
    opts = dataclasses.replace(opts, logs=tuple(p.absolute() for p in opts.logs), **files)
    return dataclasses.replace(task, logs=tuple(p.absolute() for p in task.logs), opts=opts)


def run_on_cluster(
    address: str, tasks: list[ShardTask], previous: MapState | None, progress: ProgressSink
) -> tuple[Folded, list[ShardResult]]:
    """Build the shards as tasks on the cluster at ``address`` and fold them there. The
    folds are submitted one after the other (each needs the one before): when one had to
    learn its shard again because the scene graph changed (a Hydra graph that grows or is
    corrected), the later shards' graphs change too, so, as the local pool stops its
    workers, their builds are cancelled and the rest is learnt in sequence as one task
    (``shard_fold.learn_rest``) instead of being built apart and then again."""
    tag = uuid.uuid4().hex[:8]
    tasks = [cluster_paths(task) for task in tasks]
    client = _client(address)
    futures: list[Any] = []
    try:
        _check_workers(client, address)
        progress.start(f"building {len(tasks)} shards on {address}", len(tasks), "shards")
        shards = [
            client.submit(build_shard, task, key=f"aion-shard-{tag}-{task.index}", pure=False)
            for task in tasks
        ]
        summaries = [
            client.submit(_summary, s, key=f"aion-summary-{tag}-{i}") for i, s in enumerate(shards)
        ]
        futures = [*shards, *summaries]
        acc: Any = Folded(previous)
        fallbacks, shown = 0, 0
        for k, (task, shard) in enumerate(zip(tasks, shards, strict=True)):
            acc = client.submit(fold, acc, shard, task, key=f"aion-fold-{tag}-{task.index}")
            count = client.submit(_fallbacks, acc, key=f"aion-fallbacks-{tag}-{task.index}")
            futures += [acc, count]
            shown = _wait(count, summaries, shown, progress)
            now = int(count.result())  # raises a shard's or the fold's error
            changed, fallbacks = now > fallbacks, now
            if changed and k + 1 < len(tasks):
                client.cancel([*shards[k + 1 :], *summaries[k + 1 :]], force=True)
                summaries = summaries[: k + 1]
                acc = client.submit(
                    learn_rest, acc, tasks[k + 1 :], len(tasks), key=f"aion-rest-{tag}"
                )
                futures.append(acc)
                break
        folded: Folded = acc.result()
        results: list[ShardResult] = client.gather(summaries)
        return folded, results
    except BaseException:
        if futures:
            client.cancel(futures, force=True)
        raise
    finally:
        client.close()


def _wait(future: Any, summaries: list[Any], shown: int, progress: ProgressSink) -> int:
    """Wait for ``future`` (returning as soon as it is done), advancing the progress as the
    shards' summaries finish; returns the summaries shown."""
    while not future.done():
        done = sum(f.done() for f in summaries)
        if done > shown:
            progress.advance(done - shown)
            shown = done
        with contextlib.suppress(TimeoutError):  # progress every 0.2 s meanwhile
            future.result(timeout=0.2)  # (a failed task raises its error here)
    done = sum(f.done() for f in summaries)
    if done > shown:
        progress.advance(done - shown)
    return max(done, shown)
