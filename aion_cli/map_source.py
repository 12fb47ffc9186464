"""Where an :class:`aion_cli.api.Map`'s model comes from: a state in memory, or a map file
whose state is read on first use.

``aion.Map.load(path)`` reads the file's manifest (checked: a map, of a version aion reads,
with a model state) and holds the file open (:mod:`aion_cli.pinned_file`); the state, most
of the file, is read when something first needs it (a query, ``Map.state``), as the query
commands read it (``load_map(..., forecast_only=True)``). So what ``aion info MAP`` shows
from the manifest (``Map.manifest``, ``Map.timezone``, ``Map.config``, and ``repr(m)``: its
entry count) reads no member of the state, where it read all of them (78 members of a
sample map, against the 13 ``aion info`` reads).

The state is read from the file the map was loaded from, also once its path names another
file (aion's writers replace maps atomically) or none: through the descriptor held open.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aion_cli.errors import MapFileError

if TYPE_CHECKING:
    from aion_cli.mapquery import LoadedMap
    from aion_cli.pinned_file import PinnedFile


class MapSource:
    """A map's model: ``loaded`` (a state in memory, or a file's once read) and the
    ``manifest`` it says of itself; a file's state is read by :meth:`get`."""

    def __init__(self, loaded: LoadedMap | None, manifest: dict[str, Any]) -> None:
        self.loaded = loaded
        self.manifest = manifest

    @classmethod
    def ready(cls, loaded: LoadedMap) -> MapSource:
        """A model already read (or built in memory)."""
        return cls(loaded, loaded.manifest)

    @classmethod
    def of_file(cls, path: Path) -> MapSource:
        """The map file ``path``: its manifest read and checked now (``MapFileError`` when
        it is no map, ``MapVersionError`` for another major version), its state on first
        use."""
        from aion_cli.engine.state_checks import parse_state_meta
        from aion_cli.formats.mapfile import open_map
        from aion_cli.mapquery import _state_meta, check_map_input

        check_map_input(path)
        with open_map(path) as members:
            manifest = members.manifest
        # refused when loaded, as before: no model state, one an older or a newer aion wrote
        parse_state_meta(_state_meta(path, manifest))
        return cls(None, manifest)

    def get(self, file: PinnedFile | None) -> LoadedMap:
        """The model, a file's state read now if not yet (from ``file``, the file the map
        was loaded from, held open); the caller holds the map's lock."""
        if self.loaded is None:
            if file is None:
                raise MapFileError("a map file's state cannot be read without its file")
            self.loaded = _read(file)
        return self.loaded

    def kind(self) -> str:
        """What the map cannot do, for its repr, from the manifest: a part map (``aion build
        --part``) answers no query until merged, a query-only map (``aion compact``) is
        neither continued nor merged; "" for any other map."""
        state = self.manifest.get("state")
        if isinstance(state, dict) and isinstance(state.get("deferred"), dict):
            return ", a part map (answers no query: aion.merge it)"
        if isinstance(self.manifest.get("query_only"), dict):
            return ", query-only (aion.compact: not continued or merged)"
        return ""

    def entry_count(self) -> int | None:
        """How many entries (cells and nodes) the map holds: the state's live rows once read,
        else the length of the file's ``entry_kind`` member as its manifest records it (a map
        file stores its live rows only, :meth:`MapState.to_arrays`); None when it records
        none."""
        if self.loaded is not None:  # not the entry table's reserved capacity
            return len(self.loaded.state.entries.live_rows())
        members = self.manifest.get("members")
        record = members.get("entry_kind") if isinstance(members, dict) else None
        shape = record.get("shape") if isinstance(record, dict) else None
        if isinstance(shape, list) and len(shape) == 1 and isinstance(shape[0], int):
            return shape[0]
        return None


def _read(file: PinnedFile) -> LoadedMap:
    """``file``'s state as queries read it; ``MapFileError`` when it was overwritten in
    place since it was loaded. Through its path while that names the file held open, else
    through the descriptor itself (``/proc/self/fd``, ``/dev/fd``)."""
    from aion_cli.mapquery import load_map

    file.check()
    source = file.where
    try:
        named = os.path.samestat(os.stat(source), os.fstat(file.fd))
    except OSError:
        named = False
    if not named:
        held = [Path(f"{root}/{file.fd}") for root in ("/proc/self/fd", "/dev/fd")]
        found = [p for p in held if p.exists()]
        if not found:
            raise MapFileError(
                f"{file.path} was replaced or deleted before the map was first used",
                hint="load it again (aion.Map.load)",
            )
        source = found[0]
    loaded = load_map(source, forecast_only=True)
    file.check()  # not changed while read
    return loaded
