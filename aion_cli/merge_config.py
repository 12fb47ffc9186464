"""Whether maps can be merged: the same model parameters and time zone (:func:`check_compatible`).

One difference is let through. A map written before robot windows were weighed by their
exposure reads as ``exposure = false`` (it counted them whole), so it would differ from every
newer map in that setting alone. For maps without a robot trajectory, whose windows are a fixed
sensor's and count whole either way, the setting changes nothing: they merge, under the newer
setting. Maps a robot observed are refused, with the way out in the hint.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

from aion_cli.errors import ConfigError
from aion_cli.fixed_sensor import FIXED_SENSOR_OVER
from aion_cli.listing import first_few

if TYPE_CHECKING:
    from aion_cli.engine.config import ModelConfig
    from aion_cli.manifest import Manifest
    from aion_cli.mapquery import MapHead

EXPOSURE_FIELDS = frozenset({"exposure", "exposure_floor"})
"""The parameters of how a robot's windows count (``ModelConfig.exposure``)."""


class MapInput(Protocol):
    """What the check reads of an input map."""

    @property
    def name(self) -> str: ...

    head: MapHead
    manifest: Manifest


def robot_observed(manifest: Manifest) -> bool:
    """Whether a robot's trajectory observed some of the map (its observation is not a
    fixed sensor's alone)."""
    text = manifest.observation
    return not (text.startswith(FIXED_SENSOR_OVER) or text in ("fixed", "none"))


def check_compatible(maps: Sequence[MapInput]) -> ModelConfig | None:
    """Same model parameters and time zone in every map (:class:`ConfigError` naming what
    differs). Returns the config every map is to take when fixed-sensor maps differ only in
    :data:`EXPOSURE_FIELDS` (the first with ``exposure`` on, else the first map's), else None
    (every map has the same)."""
    first = maps[0]
    base = first.head.config.to_dict()
    exposure_only = False
    for m in maps[1:]:
        other = m.head.config.to_dict()
        differ = sorted(k for k in base.keys() | other.keys() if base.get(k) != other.get(k))
        if differ and set(differ) <= EXPOSURE_FIELDS:
            robots = [x.name for x in (first, m) if robot_observed(x.manifest)]
            if not robots:
                exposure_only = True
                differ = []
            else:
                raise ConfigError(
                    f"cannot merge {first.name} and {m.name}: they count a robot's windows "
                    f"differently ({', '.join(_differences(base, other, differ))}), and a "
                    f"robot observed {' and '.join(robots)}",
                    hint="a map built before exposure existed counts them whole: rebuild it, or "
                    "build the other with a --config file that sets exposure = false",
                )
        if differ:
            raise ConfigError(
                f"cannot merge {first.name} and {m.name}: they were built with different "
                f"model parameters ({first_few(_differences(base, other, differ), 3)})",
                hint="rebuild one of them with the other's config (aion info MAP shows it; "
                "aion build --config FILE)",
            )
        if _zone(m.manifest.timezone) != _zone(first.manifest.timezone):
            raise ConfigError(
                f"cannot merge {first.name} ({first.manifest.timezone}) and {m.name} "
                f"({m.manifest.timezone}): their days follow different time zones",
                hint="rebuild one of them with the other's --tz",
            )
    if not exposure_only:
        return None
    weighed = [m.head.config for m in maps if m.head.config.exposure]
    return weighed[0] if weighed else first.head.config


def _zone(name: str | None) -> str | None:
    """A manifest's zone in its one spelling (``+05:30`` of an older map is UTC+05:30)."""
    from aion_cli.engine.temporal.zones import zone_key

    try:
        return None if name is None else zone_key(name)
    except ConfigError:
        return name  # unknown here: compared as written


def _differences(
    base: dict[str, object], other: dict[str, object], keys: list[str]
) -> list[str]:
    """Each differing parameter as ``name base vs other``."""
    return [f"{k} {base.get(k)!r} vs {other.get(k)!r}" for k in keys]
