"""The time zone a log declares: an MCAP file's ``aion`` metadata record ``timezone``.

``aion simulate --tz Europe/London`` writes it into the MCAP logs it makes (a ROS 1 bag or a
rosbag2 folder has no such record), so ``aion build`` without ``--tz`` can take the zone the
scene's hours follow, and warn when ``--tz`` names another (:mod:`aion_cli.log_zone`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

#: The metadata record and its key.
RECORD = "aion"
KEY = "timezone"


def declared_zones(paths: Sequence[Path]) -> dict[str, str]:
    """Per MCAP file among ``paths`` (by its path text), the zone its ``aion`` metadata record
    declares; files without one, other kinds of log and files that cannot be read are left
    out (the build reads them and says what is wrong)."""
    from mcap.reader import make_reader

    out: dict[str, str] = {}
    for path in paths:
        if path.suffix.lower() != ".mcap" or not path.is_file():
            continue
        try:
            with path.open("rb") as f:
                for record in make_reader(f).iter_metadata():
                    zone = record.metadata.get(KEY) if record.name == RECORD else None
                    if isinstance(zone, str) and zone:
                        out[str(path)] = zone
        except Exception:  # a damaged file declares nothing: the build reads it and says why
            continue
    return out
