"""The file a map was loaded from, held open for as long as the map: what lets a loaded map
be saved as it was loaded, and refuse to read a file overwritten in place.

A loaded map reads its members from the file as queries need them, through a memory map. A
map file replaced atomically (as every aion writer replaces one) leaves the loaded map's
file, and its memory map, intact; one overwritten in place (``cp other.aion map.aion``) does
not: the map would read the new bytes, or past the file's end (a bus error that kills the
process). :class:`PinnedFile` remembers the size and modification time it was opened with and
refuses both reading and copying once they changed.
"""

from __future__ import annotations

import os
from pathlib import Path

from aion_cli.errors import MapFileError


class PinnedFile:
    """The file a map was loaded from, held open (its bytes stay readable, even once
    replaced or deleted, for :meth:`Map.save`) with its size and modification time then:
    a map file overwritten in place (``cp other.aion map.aion``) would make the memory-mapped
    members read new bytes, or past the file's end (a bus error), so it is refused."""

    def __init__(self, path: Path) -> None:
        import weakref

        self.path = path
        #: where it was opened, whatever folder the process moves to since (a pickled map)
        self.where = Path(os.path.abspath(path))
        self.fd = os.open(path, os.O_RDONLY)
        weakref.finalize(self, os.close, self.fd)
        self.stamp = self._stamp()

    def still_named(self) -> None:
        """:class:`MapFileError` unless the path still names the file held open (it was not
        replaced or deleted since): what a pickled map, read again from its path, needs."""
        self.check()
        try:
            named = os.path.samestat(os.stat(self.where), os.fstat(self.fd))
        except OSError:
            named = False
        if not named:
            raise MapFileError(
                f"{self.path} was replaced or deleted since the map was loaded, so the map "
                "cannot be pickled (another process reads it again from its path)",
                hint="save it first (Map.save(path) copies the map as loaded) and pickle "
                "aion.Map.load(path)",
            )

    @classmethod
    def reopen(cls, path: Path, stamp: tuple[int, int]) -> PinnedFile:
        """``path`` opened again, as it was when another process pinned it with ``stamp``
        (a pickled map); :class:`MapFileError` when it is missing or changed since."""
        from aion_cli.mapquery import check_map_input

        check_map_input(path)
        pinned = cls(path)
        if pinned.stamp != tuple(stamp):
            raise MapFileError(
                f"{path} changed since the map was pickled",
                hint="a pickled map is read again from its file: keep the file as it was, "
                "or load it again (aion.Map.load) and pickle that",
            )
        return pinned

    def _stamp(self) -> tuple[int, int]:
        st = os.fstat(self.fd)
        return st.st_size, st.st_mtime_ns

    def check(self) -> None:
        if self._stamp() != self.stamp:
            raise MapFileError(
                f"{self.path} was overwritten in place since it was loaded",
                hint="load it again (aion.Map.load); aion's own writers replace a map "
                "atomically, which a loaded map survives",
            )

    def copy_to(self, target: Path) -> None:
        """The bytes as loaded into ``target`` (a temporary name; the caller renames it)."""
        self.check()
        with open(target, "wb") as out:
            offset, size = 0, self.stamp[0]
            while offset < size:
                chunk = os.pread(self.fd, min(1 << 24, size - offset), offset)
                if not chunk:
                    break
                out.write(chunk)
                offset += len(chunk)
        self.check()  # not changed while copied
