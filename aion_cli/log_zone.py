"""Which time zone a build follows when its logs declare one (:mod:`formats.log_zone`: the
zone ``aion simulate --tz`` writes into its logs: MCAP, ROS 1 bag, rosbag2).

Without ``--tz`` a new map takes the zone its logs declare (a note says so); ``--tz`` or a
continued map's zone that differs from it is kept, with a warning: a scene simulated in
Europe/London and built in UTC has its summer hours an hour off. Two names of one zone (GB and
Europe/London, Etc/UTC and UTC) do not differ.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path


def continued_zone(continue_from: Path | None) -> str | None:
    """The zone of the continued map (None: a new map, or one the build will report)."""
    if continue_from is None:
        return None
    from aion_cli.errors import AionError
    from aion_cli.formats.mapfile import read_manifest

    try:
        return str(read_manifest(continue_from).get("timezone") or "UTC")
    except (AionError, OSError):
        return None


def build_zone(
    given: str | None, map_zone: str | None, logs: Sequence[Path]
) -> tuple[str | None, list[str], list[str]]:
    """The zone a build follows (``given``: ``--tz`` as resolved, None for the default; the
    declared zone when neither it nor a continued map's zone, ``map_zone``, is set), and the
    notes and warnings to give about the zones ``logs`` declare."""
    from aion_cli.engine.temporal.zones import same_zone
    from aion_cli.errors import AionError
    from aion_cli.formats.log_zone import declared_zones
    from aion_cli.timeparse import resolve_zone

    declared: dict[str, str] = {}
    for path, text in declared_zones(logs).items():
        try:
            declared[path] = resolve_zone(text).name
        except AionError:
            continue  # a zone this machine does not know: as if none were declared
    zones = sorted(set(declared.values()))
    if not zones:
        return given, [], []
    files = ", ".join(Path(p).name for p in declared)
    if len(zones) > 1:
        named = ", ".join(f"{Path(p).name} {z}" for p, z in declared.items())
        return given, [], [
            f"the logs declare different time zones ({named}): the map follows "
            f"{given or map_zone or 'UTC'}; give --tz to choose"
        ]
    (zone,) = zones
    if given is not None or map_zone is not None:
        follows = given if given is not None else map_zone
        if follows == zone or (follows is not None and same_zone(follows, zone)):  # GB, London
            return given, [], []
        whose = f"--tz {given}" if given is not None else f"the continued map's zone {map_zone}"
        return given, [], [
            f"{files} declare{'s' if len(declared) == 1 else ''} the time zone {zone} (written "
            f"by aion simulate or convert --tz), but the map follows {whose}: its local hours "
            "are off wherever the two zones' clocks differ"
        ]
    if zone == "UTC":
        return given, [], []
    return zone, [
        f"{files} declare{'s' if len(declared) == 1 else ''} the time zone {zone} (written by "
        "aion simulate or convert --tz): the map's days and hours follow it (give --tz to choose "
        "another)"
    ], []


def held_out_zone_warnings(map_zone: str, logs: Sequence[Path]) -> list[str]:
    """A warning per zone the held-out ``logs`` declare that is not the map's (``aion
    evaluate holdout``): the people in them keep another zone's hours than the map learnt,
    so its daily rhythm and hour-of-day profile are judged hours off."""
    from aion_cli.engine.temporal.zones import same_zone
    from aion_cli.errors import AionError
    from aion_cli.formats.log_zone import declared_zones
    from aion_cli.timeparse import resolve_zone

    try:
        ours = resolve_zone(map_zone).name
    except AionError:
        return []
    others: dict[str, list[str]] = {}
    for path, text in declared_zones(logs).items():
        try:
            zone = resolve_zone(text).name
        except AionError:
            continue  # a zone this machine does not know: as if none were declared
        if zone != ours and not same_zone(zone, ours):
            others.setdefault(zone, []).append(Path(path).name)
    return [
        f"{', '.join(files)} declare{'s' if len(files) == 1 else ''} the time zone {zone} "
        f"(written by aion simulate or convert --tz), but the map follows {ours}: the scene's "
        "hours are judged against the map's, off wherever the two zones' clocks differ"
        for zone, files in sorted(others.items())
    ]
