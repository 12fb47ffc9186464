"""Whether maps can be merged: the same model parameters and time zone (:func:`check_compatible`).

One difference is let through. A map written before robot windows were weighed by their
exposure reads as ``exposure = false`` (it counted them whole), so it would differ from every
newer map in that setting alone. For maps without a robot trajectory, whose windows are a fixed
sensor's and count whole either way, the setting changes nothing: they merge, under the newer
setting. Maps a robot observed are refused, with the way out in the hint.

Maps whose FreMEn clocks differ (``fremen_clock``: one built before FreMEn followed the local
clock across daylight saving) merge on the newer clock when the older map's time held no
daylight-saving time (its sums are the same on either clock), and are refused with a message
of their own when it did. In UTC or a fixed offset the clocks are one and not recorded. A
continued older map moves to the newer clock on the same condition (:func:`continued_config`).

Two names of one zone are one zone: a robot set up with ``--tz Etc/UTC`` beside one on the
default UTC, or ``Asia/Calcutta`` beside ``Asia/Kolkata`` (a link in the tz database), merge
under the first map's spelling (:func:`~aion_cli.engine.temporal.zones.same_zone`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

from aion_cli.engine.temporal.zones import same_zone
from aion_cli.errors import ConfigError
from aion_cli.fixed_sensor import FIXED_SENSOR_OVER
from aion_cli.listing import first_few

if TYPE_CHECKING:
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.state import MapState
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


def check_compatible(
    maps: Sequence[MapInput], notes: list[str] | None = None
) -> ModelConfig | None:
    """Same model parameters and time zone in every map (:class:`ConfigError` naming what
    differs). Returns the config every map is to take when fixed-sensor maps differ only in
    :data:`EXPOSURE_FIELDS` (the first with ``exposure`` on, else the first map's), when their
    FreMEn clocks differ, when they name one zone in two ways (``Etc/UTC`` and ``UTC``: the
    first map's spelling), or when they differ in :func:`planning` parameters (the first
    map's, with a note in ``notes``), else None (every map has the same)."""
    first = maps[0]
    configs = _one_spelling(maps)
    base = configs[0].to_dict()
    exposure_only = False
    clock_only = _clocks_differ(maps, configs)
    planned: dict[str, list[str]] = {}  # a differing planning parameter: each map's value
    for m, config in zip(maps[1:], configs[1:], strict=True):
        _check_zone(first, m)
        other = config.to_dict()
        differ = sorted(k for k in base.keys() | other.keys() if base.get(k) != other.get(k))
        if clock_only:
            differ = [k for k in differ if k != "fremen_clock"]
        for k in filter(planning, differ):
            planned.setdefault(k, []).append(f"{other.get(k)!r} in {m.name}")
        differ = [k for k in differ if not planning(k)]
        if differ and set(differ) <= EXPOSURE_FIELDS:
            robots = [x.name for x in (first, m) if robot_observed(x.manifest)]
            if not robots:
                exposure_only = True
                differ = []
            else:
                raise ConfigError(
                    f"cannot merge {first.name} and {m.name}: they count a robot's windows "
                    "differently ("
                    + ", ".join(parameter_differences(base, other, differ))
                    + f"), and a robot observed {' and '.join(robots)}",
                    hint="a map built before exposure existed counts them whole: rebuild it, or "
                    "build the other with a --config file that sets exposure = false",
                )
        if differ:
            raise ConfigError(
                f"cannot merge {first.name} and {m.name}: they were built with different "
                f"model parameters ({first_few(parameter_differences(base, other, differ), 3)})",
                hint="rebuild one of them with the other's config (aion info MAP shows it; "
                "aion build --config FILE)",
            )
    respelt = any(c is not m.head.config for m, c in zip(maps, configs, strict=True))
    if not (exposure_only or clock_only or respelt or planned):
        return None
    weighed = [c for c in configs if c.exposure]
    config = weighed[0] if weighed and exposure_only else configs[0]
    if planned:
        config = config.replace(**{k: base[k] for k in planned})
        if notes is not None:
            notes.append(_planning_note(first.name, base, planned))
    return config.replace(fremen_clock="standard") if clock_only else config


def planning(parameter: str) -> bool:
    """Whether ``parameter`` only sets how ``aion plan`` plans on a map (``plan_speed``, the
    ``plan_w_*`` weights, ...): read at query time, never by a build, so maps that differ in
    it hold the same counts and merge, the merged map planning as the first map given."""
    return parameter.startswith("plan_")


def _planning_note(first: str, base: dict[str, object], planned: dict[str, list[str]]) -> str:
    """The note for maps that plan with other parameters than the first map ``first``."""
    listed = "; ".join(
        f"{k} {base.get(k)!r} in {first}, {', '.join(v)}" for k, v in planned.items()
    )
    return (
        f"the maps plan with different parameters ({listed}): the merged map plans with "
        f"{first}'s (its counts are the same either way; aion plan --speed sets a plan's speed)"
    )


def _check_zone(first: MapInput, m: MapInput) -> None:
    """Maps whose days follow different time zones (their manifests', else their configs'):
    :class:`ConfigError` naming the zones, checked before the other parameters (a map of
    another zone differs in ``fremen_clock`` too, which UTC does not record: listed among
    them, the difference read as 'fremen_clock None vs 'standard'')."""
    zones = [_zone(x.manifest.timezone or x.head.config.timezone) for x in (first, m)]
    a, b = zones
    if a != b and not (a is not None and b is not None and same_zone(a, b)):
        raise ConfigError(
            f"cannot merge {first.name} ({zones[0]}) and {m.name} ({zones[1]}): their days "
            "follow different time zones",
            hint="rebuild one of them with the other's --tz",
        )


def _one_spelling(maps: Sequence[MapInput]) -> list[ModelConfig]:
    """Each map's config, its zone spelt as the first map's where the two names are one zone
    (``Asia/Calcutta`` beside ``Asia/Kolkata``: :func:`~aion_cli.engine.temporal.zones.same_zone`),
    so that they compare equal and the maps merge under one config."""
    zone = maps[0].head.config.timezone
    return [
        m.head.config.replace(timezone=zone)
        if m.head.config.timezone != zone and same_zone(m.head.config.timezone, zone)
        else m.head.config
        for m in maps
    ]


def _clocks_differ(maps: Sequence[MapInput], configs: Sequence[ModelConfig]) -> bool:
    """Whether maps of one zone are on different FreMEn clocks (``fremen_clock``: some built
    before FreMEn followed daylight saving). They merge on the newer clock when no map on UTC
    held daylight-saving time (its sums are the same on either clock); otherwise
    :class:`ConfigError`. Maps of different zones are left to the checks that name that.
    ``configs``: the maps' configs, their zones in one spelling (:func:`_one_spelling`)."""
    if len({c.fremen_clock for c in configs}) < 2 or len({c.timezone for c in configs}) > 1:
        return False
    stale = [
        m.name
        for m, c in zip(maps, configs, strict=True)
        if c.fremen_clock == "utc" and _saved_daylight(c, m.manifest)
    ]
    if stale:
        its, it = ("their", "they were") if len(stale) > 1 else ("its", "it was")
        raise ConfigError(
            f"cannot merge {first_few(stale, 3)} with the other maps: {its} FreMEn phases "
            f"follow UTC across a daylight-saving shift ({it} built before FreMEn followed "
            f"daylight saving in {configs[0].timezone}; the others follow the local clock)",
            hint="rebuild the older map from its logs, or continue it (aion build --map) "
            "with the newer one's logs",
        )
    return True


def continued_config(config: ModelConfig, manifest: Manifest) -> ModelConfig:
    """The config a continued map (``aion build --map``) goes on with: its own, except that a
    map built before FreMEn followed daylight saving (``fremen_clock = "utc"``) moves to the
    local clock when its time span held no daylight-saving time. Its sums are then the same on
    either clock, so the move is exact, and the days it learns next keep their local hours."""
    if config.fremen_clock != "utc" or _saved_daylight(config, manifest):
        return config
    return config.replace(fremen_clock="standard")


def adopt_config(state: MapState, config: ModelConfig) -> None:
    """``state`` goes on under ``config``, one that differs from its own only where its arrays
    are the same under either (:func:`check_compatible`, :func:`continued_config`)."""
    from aion_cli.engine.temporal.params import TemporalParams

    state.config = config
    state.params = TemporalParams.from_config(config)  # FreMEn's clock among them


def _saved_daylight(config: ModelConfig, manifest: Manifest) -> bool:
    """Whether daylight saving was in force in the map's zone at any time of its time span
    (checked hourly and at both ends: a daylight-saving period lasts more than an hour); true
    for a map without a span."""
    import numpy as np

    from aion_cli.engine.temporal.calendar import HOUR_NS, Calendar

    start, end = manifest.start_ns, manifest.end_ns
    if start is None or end is None:
        return True
    times = np.append(np.arange(start, end, HOUR_NS, dtype=np.int64), np.int64(end))
    calendar = Calendar(config.timezone)
    return bool(np.any(calendar.standard_ns(times) != times))


def _zone(name: str | None) -> str | None:
    """A manifest's zone in its one spelling (``+05:30`` of an older map is UTC+05:30)."""
    from aion_cli.engine.temporal.zones import zone_key

    try:
        return None if name is None else zone_key(name)
    except ConfigError:
        return name  # unknown here: compared as written


def parameter_differences(
    base: dict[str, object], other: dict[str, object], keys: list[str] | None = None
) -> list[str]:
    """Each differing parameter (of ``keys``; default: every one that differs) as ``name base
    vs other``."""
    if keys is None:
        keys = sorted(k for k in base.keys() | other.keys() if base.get(k) != other.get(k))
    return [f"{k} {base.get(k)!r} vs {other.get(k)!r}" for k in keys]
