"""The map a build continues (``aion build --map MAP``): loading it on the clock it goes on
with (:func:`load_continued`), the warning when the new logs are read into another frame than
the one its positions are in (:func:`frame_warning`), and what ``--part`` may continue
(:func:`check_part`).

Why apart from :mod:`aion_cli.pipeline`: these are the rules for the map that was there before
the build, each a plain function of the options and the loaded map; the pipeline only orders
them (its ``_Build`` calls them when the build starts and again when a stale index makes it
start over). Whether the continued map's scene-graph session goes on is
:mod:`aion_cli.build_lineage`'s.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from aion_cli.errors import InputError

if TYPE_CHECKING:
    from pathlib import Path

    from aion_cli.build_options import BuildOptions
    from aion_cli.mapquery import LoadedMap

__all__ = ["check_part", "frame_warning", "load_continued"]


def load_continued(path: Path, opts: BuildOptions, notes: list[str]) -> LoadedMap:
    """The continued map, on the FreMEn clock it goes on with
    (:func:`aion_cli.merge_config.continued_config`); a graph file of another session is
    refused or the map released (:func:`aion_cli.build_lineage.continue_on_graph`). What it
    says goes to ``notes`` (a note given once, also when the build loads the map again)."""
    from aion_cli.build_lineage import continue_on_graph
    from aion_cli.manifest import Manifest
    from aion_cli.mapquery import load_map
    from aion_cli.merge_config import adopt_config, continued_config

    loaded = load_map(path, writable=True)
    continue_on_graph(loaded, path.name, opts.graph_file, opts.nav_layer, opts.lineage, notes)
    config = continued_config(loaded.config, Manifest.from_dict(loaded.manifest))
    if config != loaded.config:
        adopt_config(loaded.state, config)
        note = (
            f"{path.name} was built before FreMEn followed daylight saving; its time held "
            f"none in {config.timezone}, so it goes on with FreMEn on the local clock "
            "(exactly: its sums are the same on either clock)"
        )
        if note not in notes:
            notes.append(note)
    return loaded


def frame_warning(name: str, recorded: str | None, map_frame: str) -> str | None:
    """The warning when the continued map ``name`` records its positions in frame
    ``recorded`` and ``--map-frame`` reads the new logs into another, ``map_frame``: both are
    joined as if one frame. None when they agree or the map records no frame."""
    if recorded is None or recorded == map_frame:
        return None
    return (
        f"{name} holds positions in frame {recorded!r}, and "
        f"--map-frame reads these logs into {map_frame!r}: their positions "
        "join the map's as if both were one frame (and the map then records "
        f"{map_frame!r}); unless they are, give the logs the TF to "
        f"{recorded!r} instead, or build them into a map of their own"
    )


def check_part(previous: LoadedMap | None, opts: BuildOptions, notes: list[str]) -> None:
    """``--part`` starts a part map or continues one (``previous``), never an ordinary map;
    it builds in this process (a note when ``--workers`` asked otherwise)."""
    if previous is not None and previous.state.deferred is None:
        raise InputError(
            "--part cannot continue an ordinary map",
            hint="build the part into a new file (aion build LOG --part -o PART.aion)",
        )
    if opts.workers not in (0, 1) or opts.scheduler is not None:
        notes.append("--part builds in this process (--workers ignored)")
