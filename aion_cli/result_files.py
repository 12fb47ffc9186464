"""Handing a built shard from a worker process to the parent through a file, not the pipe.

A shard's map state is mostly a few large arrays (tens of MB for a few thousand entries, GB
for 10^5). Put on a ``multiprocessing`` queue it is pickled into one bytes object in the
worker, pushed through a 64 KB pipe and copied again into arrays in the parent: on the
4-log benchmark the first shard's 32 MB took 0.2 s on the critical path, and a large map
needs twice its size in both processes. Here the worker pickles with protocol 5, whose
numpy arrays hand their memory over out of band, writes those buffers to a file in a
folder the parent made (in ``/dev/shm`` where it has room: memory, no disk), and queues only
the small pickle and the buffers' sizes; the parent reads each buffer straight into its own
memory (``readinto``), unpickles around them and deletes the file. Where a file cannot be
written (no room), the result goes through the queue as before. The parent removes the
folder when the build ends, however it ends.
"""

from __future__ import annotations

import os
import pickle
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

MIN_FILE_BYTES = 1 << 20
"""Results whose arrays hold less than this go through the queue (a file costs more)."""
SHM_ROOM = 256 << 20
"""``/dev/shm`` is used when it has this much room (a container's is often 64 MB)."""
_SHM = Path("/dev/shm")


@contextmanager
def result_folder() -> Iterator[Path]:
    """A private folder for the workers' result files, removed on exit: in ``/dev/shm``
    when it has :data:`SHM_ROOM` free, else in the temporary folder (a file that finds no
    room goes through the queue instead)."""
    parent: str | None = None
    try:
        if _SHM.is_dir() and os.access(_SHM, os.W_OK):
            stat = os.statvfs(_SHM)
            if stat.f_bavail * stat.f_frsize >= SHM_ROOM:
                parent = str(_SHM)
    except OSError:
        parent = None
    folder = Path(tempfile.mkdtemp(prefix="aion-shards-", dir=parent))
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def send(out: Any, index: int, result: Any, folder: Path | None) -> None:
    """Queue shard ``index``'s ``result`` on ``out``: its large buffers in a file of
    ``folder`` (``("result-file", index, pickle, sizes, path)``), else whole (``("result",
    index, result)``)."""
    buffers: list[pickle.PickleBuffer] = []
    payload = pickle.dumps(result, protocol=5, buffer_callback=buffers.append)
    views = [b.raw() for b in buffers]
    sizes = [v.nbytes for v in views]
    if folder is None or sum(sizes) < MIN_FILE_BYTES:
        out.put(("result", index, result))
        return
    path = folder / f"shard-{index}-{os.getpid()}.bin"
    try:
        with open(path, "wb") as file:
            for view in views:
                file.write(view)
    except OSError:  # no room: the queue takes it
        path.unlink(missing_ok=True)
        out.put(("result", index, result))
        return
    out.put(("result-file", index, payload, sizes, str(path)))


def receive(item: tuple[Any, ...]) -> Any:
    """The result of a ``"result-file"`` item: its buffers read from the file (deleted
    then), the pickle loaded around them."""
    _, _, payload, sizes, name = item
    path = Path(name)
    buffers = []
    try:
        with open(path, "rb") as file:
            for size in sizes:
                buffer = bytearray(size)
                if file.readinto(buffer) != size:
                    raise OSError(f"{path} ended early")
                buffers.append(buffer)
    finally:
        path.unlink(missing_ok=True)
    return pickle.loads(payload, buffers=buffers)
