"""How ``aion merge`` names its input maps (:mod:`aion_cli.merging`): a fleet's maps often
share a file name (robot1/map.aion, robot2/map.aion), and of forty maps a message has to
say which one it is about."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def naming_map(path: Path) -> Iterator[None]:
    """A map file that cannot be read (a newer format, an older state, a damaged member)
    reported with its path: of the maps of a merge, the message said which (it read 'map
    format 3.0 is newer than this aion supports' of one of forty maps)."""
    from aion_cli.errors import MapFileError

    try:
        yield
    except MapFileError as exc:
        if path.name not in exc.message:
            exc.message = f"{path}: {exc.message}"
            exc.args = (exc.message, *exc.args[1:])
        raise


def shared_names(paths: list[Path]) -> set[str]:
    """The file names that more than one input has (those maps are named by path)."""
    from collections import Counter

    return {name for name, n in Counter(p.name for p in paths).items() if n > 1}
