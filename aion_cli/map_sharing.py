"""One :class:`aion_cli.api.Map` shared between threads and processes.

Threads: a loaded map's first query folds its pending day and open window into its
accumulators, in place (``MapState.query_temporal``), and queries fill caches as they go; two
threads querying one map at once folded the day twice, answered wrongly and left the map
wrong for every later query. :func:`one_at_a_time` makes a map's queries take turns (each
map has its own lock: maps loaded separately still answer in parallel).

Processes: a map loaded from a file holds that file open (:mod:`aion_cli.pinned_file`); the
open file does not cross a process, so such a map is pickled as its file and loaded again
where it is unpickled (:func:`pickled`, :func:`unpickled`); an in-memory map is pickled
whole.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Concatenate, ParamSpec, TypeVar

from aion_cli.pinned_file import PinnedFile

if TYPE_CHECKING:
    from aion_cli.api import Map

P = ParamSpec("P")
R = TypeVar("R")
M = TypeVar("M", bound="Map[Any]")


def one_at_a_time(query: Callable[Concatenate[M, P], R]) -> Callable[Concatenate[M, P], R]:
    """``query`` run holding its map's lock (queries of one map take turns)."""

    @functools.wraps(query)
    def run(self: M, *args: P.args, **kwargs: P.kwargs) -> R:
        with self._lock:
            return query(self, *args, **kwargs)

    return run


def new_lock() -> threading.RLock:
    return threading.RLock()


def pickled(fields: dict[str, Any], file: PinnedFile | None) -> dict[str, Any]:
    """What a map pickles as: its fields but its lock; for one loaded from a file, that
    file (absolute path, size and modification time) instead of the state read from it."""
    if file is None:
        return {k: v for k, v in fields.items() if k != "_lock"}
    file.still_named()
    return {
        "path": fields["path"], "file": file.where, "stamp": file.stamp, "report": fields["_report"]
    }


def unpickled(state: dict[str, Any]) -> dict[str, Any]:
    """A map's fields from what :func:`pickled` made: a map's file loaded again as
    :meth:`aion_cli.api.Map.load` reads it (without the per-entry Fourier sums only learning
    reads; ``MapFileError`` when it changed since), with a new lock."""
    if "stamp" not in state:
        return {**state, "_lock": new_lock()}
    from aion_cli.map_source import MapSource

    file = PinnedFile.reopen(state["file"], state["stamp"])
    source = MapSource.of_file(file.path)  # its state read on first use, as Map.load's
    file.check()  # not changed while read
    fields = {"path": state["path"], "_report": state["report"], "_file": file}
    return {**fields, "_source": source, "_lock": new_lock()}
