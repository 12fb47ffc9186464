"""The Python API's :func:`info`: what is in logs and what :func:`aion_cli.build` will use from
them, before a map is made -- the report ``aion info LOG --format json`` prints
(:func:`aion_cli.log_report.describe`, which the command calls too).

Why a module of its own: :mod:`aion_cli.api` holds maps and their queries,
:mod:`aion_cli.api_make` makes maps; this reads logs only.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from aion_cli.api_checks import ZoneLike
from aion_cli.api_keywords import keywords_checked
from aion_cli.api_make import PathLike
from aion_cli.errors import InputError


@keywords_checked
def info(
    logs: Iterable[PathLike] | PathLike,
    *,
    log_format: str | None = None,
    detections_mapping: PathLike | None = None,
    tz: ZoneLike | None = None,
    verify: bool = False,
) -> dict[str, Any]:
    """What is in ``logs`` (a log file, a rosbag2 folder, or a list of them) and what
    :func:`~aion_cli.api_make.build` will use from them, as ``aion info LOG --format json``:
    a dict of its keys (``files``, ``topics`` with each one's type, count, rate in Hz, role,
    whether a build uses it and why, ``will_use``, ``start_ns`` / ``end_ns`` in UNIX
    nanoseconds, ``duration_s`` in seconds, ``warnings``, ...; ``aion info --help`` lists
    them), to choose ``detection_topics``, ``map_frame`` or a ``detections_mapping`` before
    building. Its times of day (a fixed sensor's ``hours_with_messages``) are in ``tz``, else
    the zone the logs declare (as ``aion.build`` follows it), else UTC. ``verify=True`` reads
    every message first, as a build does: a damaged chunk is a warning with the messages it
    loses. The warnings are also issued as :class:`~aion_cli.errors.AionWarning`, in the
    API's words (``map_frame="odom"``, not ``--map-frame odom``). A map file is refused:
    ``aion.Map.load(path).manifest`` says what a map holds."""
    from aion_cli.api_checks import flag, path_list, text, zone_name
    from aion_cli.api_make import as_path, warn_of
    from aion_cli.formats.input_kind import input_kind
    from aion_cli.log_report import describe, report_zone

    paths = [as_path(p, "log") for p in path_list(logs, "logs")]  # type: ignore[arg-type]
    if not paths:
        raise InputError("no log given", hint="pass at least one log file or folder")
    for path in paths:
        if not path.exists():
            raise InputError(f"log not found: {path}", hint="check the path")
        if path.suffix == ".aion" or (path.is_file() and input_kind(path) == "map"):
            raise InputError(
                f"{path} is a map, not a log",
                hint=f"aion.Map.load({str(path)!r}).manifest says what the map holds",
            )
    mapping = None if detections_mapping is None else as_path(detections_mapping, "mapping")
    read_all = flag(verify, "verify")
    zone = report_zone(zone_name(tz), paths)
    report = describe(paths, text(log_format, "log_format"), mapping, zone, read_all)
    warn_of(report["warnings"], [])
    return report
