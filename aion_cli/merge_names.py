"""How ``aion merge`` names its input maps (:mod:`aion_cli.merging`): a fleet's maps often
share a file name (robot1/map.aion, robot2/map.aion), and of forty maps a message has to
say which one it is about."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any


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


def shared_names(names: Iterable[str]) -> set[str]:
    """The file names that more than one input has (those inputs are named by path)."""
    from collections import Counter

    return {name for name, n in Counter(names).items() if n > 1}


def shown_names(entries: Sequence[Mapping[str, Any]]) -> list[str]:
    """Each input's ``name`` as a table shows it: its ``path`` where another input has the same
    file name (robot1/map.aion, robot2/map.aion: a merge's maps, or a map's logs), else the
    name."""
    shared = shared_names(str(e["name"]) for e in entries)
    return [str(e.get("path") or e["name"]) if e["name"] in shared else str(e["name"])
            for e in entries]


LINEAGES = {
    "same": "one scene-graph session: nodes joined by id",
    "different": "different scene-graph sessions: re-bound by position",
}
"""How ``aion merge`` joined its maps (the manifest's ``lineage``), in words."""


def merged_from_text(count: int, lineage: object) -> str:
    """How a merged map was made, as ``aion info`` and ``aion report`` say it: ``2 maps by
    aion merge (one scene-graph session: nodes joined by id)``."""
    how = LINEAGES.get(str(lineage), f"lineage {lineage}")
    return f"{count:,} map{'' if count == 1 else 's'} by aion merge ({how})"
