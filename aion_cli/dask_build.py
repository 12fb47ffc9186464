"""Running a parallel build on a Dask cluster (``aion build ... --scheduler ADDRESS``).

The same plan as ``--workers`` (:mod:`aion_cli.parallel_build`): one task per shard reads its
logs *by path* (every worker must see them at the same paths, e.g. on a shared file system)
and returns its map state (pickled bytes, Dask's own serialisation); the fold runs on the
cluster too, as a chain of tasks in time order (each joins one shard onto the map before it,
or learns the shard's logs onto it in sequence where a join would not be exact), so the
shards' maps never travel to the client: only the finished map and the shards' summaries do.
Needs the ``dask`` extra (``pip install 'aion[dask]'``).
"""

from __future__ import annotations

import time
import uuid
from typing import TYPE_CHECKING, Any

from aion_cli.errors import InputError, MissingPackageError
from aion_cli.parallel_build import Folded, ShardResult, ShardTask, build_shard, fold

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
        return Client(address, timeout="5s", set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(
            f"cannot reach the Dask scheduler at {address}: {exc}",
            hint="give the scheduler's address, e.g. --scheduler tcp://10.0.0.5:8786",
        ) from exc


def _summary(result: ShardResult) -> ShardResult:
    return result.without_state()


def run_on_cluster(
    address: str, tasks: list[ShardTask], previous: MapState | None, progress: ProgressSink
) -> tuple[Folded, list[ShardResult]]:
    """Build the shards as tasks on the cluster at ``address`` and fold them there."""
    tag = uuid.uuid4().hex[:8]
    client = _client(address)
    futures: list[Any] = []
    try:
        progress.start(f"building {len(tasks)} shards on {address}", len(tasks), "shards")
        shards = [
            client.submit(build_shard, task, key=f"aion-shard-{tag}-{task.index}", pure=False)
            for task in tasks
        ]
        summaries = [
            client.submit(_summary, s, key=f"aion-summary-{tag}-{i}") for i, s in enumerate(shards)
        ]
        acc: Any = Folded(previous)
        for task, shard in zip(tasks, shards, strict=True):
            acc = client.submit(fold, acc, shard, task, key=f"aion-fold-{tag}-{task.index}")
        futures = [*shards, *summaries, acc]
        shown = 0
        while shown < len(summaries):  # the client is not the default one: poll the futures
            done = sum(f.done() for f in summaries)
            if done > shown:
                progress.advance(done - shown)
                shown = done
            elif any(f.status == "error" for f in summaries):
                break  # result() below raises the task's error
            else:
                time.sleep(0.2)
        folded: Folded = acc.result()
        results: list[ShardResult] = client.gather(summaries)
        return folded, results
    except BaseException:
        if futures:
            client.cancel(futures, force=True)
        raise
    finally:
        client.close()
