"""The simulated scenes of the office comparison (``aion evaluate office``): their simulator
settings, the files each writes into the work folder (``--keep``), and the checks made before
the first scene runs."""

from __future__ import annotations

from pathlib import Path
from typing import Any


def scene_config(scene_days: float, agents: int, seed: int) -> Any:
    """The simulator settings of the comparison (map-frame detections: see
    :mod:`aion_cli.evaluation.office`)."""
    from aion_cli.sim.scenario import ScenarioConfig

    return ScenarioConfig(days=scene_days, agents=agents, seed=seed, frame="map")


def check_scenes(days: float, agents: int, seed: int) -> None:
    """The simulator's own checks of the scenes (``aion simulate``'s), before any is run: a
    scene longer than the simulator holds (its robot per tick in memory) ran for hours."""
    from aion_cli.errors import InputError
    from aion_cli.sim.scenario import MAX_TICKS

    sim = scene_config(days, agents, seed)
    most = MAX_TICKS / (sim.rate_hz * 86400.0)
    if days > most:
        raise InputError(
            f"--days {days:g} is more than a simulated scene holds ({most:.1f} days)",
            hint="give fewer --days; more --scenes give more data",
        )
    try:
        sim.validate()
    except InputError as exc:  # simulate's words, with a hint of this command (--seed)
        raise InputError(exc.message, hint="see aion evaluate office --help") from exc


def scene_files(work: Path, scene: int) -> list[Path]:
    """The files a scene writes into the work folder: its log, the log's truth files and
    its map."""
    from aion_cli.sim.ground_truth import truth_paths

    log = work / f"scene_{scene:02d}.mcap"
    return [log, *truth_paths(log), work / f"scene_{scene:02d}.aion"]


def check_kept_files(work: Path, scenes: int) -> None:
    """:class:`~aion_cli.formats.outputs.OutputPathError` when the ``--keep`` folder holds a
    file the run would write (an earlier run's scenes): said before anything is simulated,
    naming the option it has (``evaluate office`` has no ``--force``)."""
    from aion_cli.formats.outputs import OutputPathError

    there = [
        p for s in range(scenes) for p in scene_files(work, s) if p.exists() or p.is_symlink()
    ]
    if there:
        more = f" and {len(there) - 1:,} more of the files this run writes" * (len(there) > 1)
        raise OutputPathError(
            f"--keep {work} holds {there[0].name}{more} (an earlier run's scenes?)",
            hint="give --keep a new or empty folder, or remove its scene_* files first",
        )
