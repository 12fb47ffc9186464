"""Silencing what native libraries print: spark_dsg's C++ logger writes warnings on stdout for
every load of an older encoding (which would corrupt ``--format json`` output), and open3d's
PLY writer prints one ``RPly: Failed writing`` line per element on a full disk. aion reports
those conditions itself, in one line."""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator


@contextlib.contextmanager
def native_output_silenced(fds: tuple[int, ...] = (1, 2)) -> Iterator[None]:
    """Send the file descriptors ``fds`` (stdout and stderr by default) to /dev/null for the
    block. Python's and C's stdio buffers are flushed first and at the end, so nothing printed
    before the block is lost and nothing printed inside it leaks out afterwards."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:
        yield
        return
    saved: list[tuple[int, int]] = []
    try:
        for fd in fds:
            with contextlib.suppress(OSError):
                saved.append((fd, os.dup(fd)))
                os.dup2(devnull, fd)
        yield
    finally:
        with contextlib.suppress(Exception):
            ctypes.CDLL(None).fflush(None)  # C stdio buffers still hold the native output
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)
