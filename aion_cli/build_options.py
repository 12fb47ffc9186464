"""What ``aion build`` can be told (:class:`BuildOptions`), apart from how a build runs
(:mod:`aion_cli.pipeline`): the CLI, the Python API and parallel shards all fill it in."""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aion_cli.engine.config import ModelConfig
from aion_cli.errors import ConfigError, InputError, LogFormatError, path_word
from aion_cli.graph_schedule import DEFAULT_GRAPH_PERIOD_NS

if TYPE_CHECKING:
    from aion_cli.tf_feed import StaticTf

__all__ = [
    "DEFAULT_MAP_FRAME",
    "MAP_SUFFIX",
    "BuildOptions",
    "build_topics",
    "load_mappings",
    "map_frame_of",
    "resolve_config",
]

MAP_SUFFIX = ".aion"
DEFAULT_MAP_FRAME = "map"


def map_frame_of(given: str | None, map_path: Path | None) -> str:
    """The map frame to read logs into: ``given`` (``--map-frame``), else the frame the map
    at ``map_path`` records (the continued map of ``aion build --map``, the map ``aion
    evaluate holdout`` judges), else ``map``. A map that cannot be read here falls back to
    ``map``: its own reader reports what is wrong with it. ``given`` is spelt as the logs'
    frame ids are compared (:func:`formats.raw.normalize_frame`: ``/map`` is ``map``)."""
    if given is not None:
        from aion_cli.formats.raw import normalize_frame

        return normalize_frame(given) or given
    if map_path is not None:
        from aion_cli.errors import AionError
        from aion_cli.formats.mapfile import read_manifest

        try:
            frame = read_manifest(map_path).get("map_frame")
        except (AionError, OSError):
            frame = None
        if isinstance(frame, str) and frame:
            return frame
    return DEFAULT_MAP_FRAME


MAX_WORKERS = 4096
"""The most worker processes a build asks for (``--workers``; more would only fail to start)."""


@dataclass(frozen=True)
class BuildOptions:
    """Everything ``aion build`` can be told. Empty / None fields mean "choose for me"."""

    logs: tuple[Path, ...]
    output: Path | None = None
    config: ModelConfig | None = None
    log_format: str | None = None
    detection_topics: tuple[str, ...] = ()
    graph_topic: str | None = None
    map_frame: str = "map"
    base_frame: str = "base_link"
    graph_file: Path | None = None
    nav_layer: str | None = None  # --nav-layer NAME|KEY (None: MESH_PLACES if any, else PLACES)
    derive_graph: bool = False
    continue_from: Path | None = None
    #: ``--lineage``: whether ``graph_file`` is of ``continue_from``'s scene-graph session
    #: (:mod:`aion_cli.build_lineage`)
    lineage: str = "auto"
    dsg_version: str | None = None
    batch_size: int = 4000
    timezone: str | None = None
    detections_mapping: Path | None = None
    #: ``--graph-period``: log time between the scene graphs a build uses (0: every one);
    #: see :func:`aion_cli.graph_schedule.graph_schedule`
    graph_period_ns: int = DEFAULT_GRAPH_PERIOD_NS
    #: internal switch (tests): a payload identical to the last decoded one reuses its graph
    #: instead of being decoded again (same map either way)
    skip_identical_graphs: bool = True
    #: ``--workers``: processes building independent groups of logs at once (1: in this
    #: process; 0: one per core), see :mod:`aion_cli.parallel_build`
    workers: int = 1
    #: ``--scheduler``: a Dask scheduler's address; the shards run on its cluster
    scheduler: str | None = None
    #: ``--part``: write a part map, its days held unscored for an exact ``aion merge``
    part: bool = False
    #: ``--observed``: spans ``[lo, hi)`` of log time (ns) a fixed sensor was recording,
    #: beside the windows with messages (a tracker that publishes only when it sees someone)
    observed: tuple[tuple[int, int], ...] = ()
    #: the spans of ``observed`` the logs record with empty marker messages (``aion convert
    #: --observed``; :mod:`aion_cli.log_observed`): a window only markers hold has no message
    observed_marked: tuple[tuple[int, int], ...] = ()
    #: the ``--observed`` spans as the user typed them and as read, ``(text, (lo, hi))``:
    #: those apart from the logs' messages are warned of (:mod:`aion_cli.times_apart`)
    observed_typed: tuple[tuple[str, tuple[int, int]], ...] = ()
    #: internal (a parallel build's shards): the first and last window the ``--observed``
    #: spans may fill beyond the shard's own logs, its share of the time between the groups
    #: of logs (:func:`aion_cli.observed_spans.declared_windows`); None: the logs' own
    observed_fill: tuple[int | None, int | None] = (None, None)

    def __post_init__(self) -> None:
        from aion_cli.merge_lineage import check_lineage

        check_lineage(self.lineage)
        if self.scheduler is not None:  # a typo is refused even where no cluster is used
            check_scheduler_address(self.scheduler)

    def output_path(self) -> Path:
        """``-o``, else the continued map, else the first log's name with ``.aion``."""
        if self.output is not None:
            return self.output
        if self.continue_from is not None:
            return self.continue_from
        first = self.logs[0]
        if first.name in ("", ".."):  # `aion build .` in a bag's folder: named as the folder
            first = Path(os.path.abspath(first))
        if not first.name:
            raise InputError(f"no map name follows from the log {first}", hint="give -o MAP.aion")
        base = first.parent / (first.name.rstrip("/") if first.is_dir() else first.stem)
        return base.with_name(base.name + MAP_SUFFIX)


#: the schemes of Dask's comm layer (distributed.comm): tcp without one (``host:port``)
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx", "inproc")
#: a host name, an IPv4 address, or an IPv6 address in brackets
_HOST = re.compile(r"[A-Za-z0-9_.-]+|\[[0-9A-Fa-f:.%A-Za-z]+\]")


def check_scheduler_address(address: str) -> None:
    """Refuse a ``--scheduler`` address that is not one (:class:`InputError`): an unknown
    scheme, no host, no port or one that is no port number. Only its form is checked, with
    or without Dask installed; whether a scheduler answers there is asked when a build uses
    it (:mod:`aion_cli.dask_build`)."""
    scheme, sep, where = address.partition("://")
    if not sep:
        scheme, where = "tcp", address
    why = None
    host, colon, port = where.rpartition(":")
    if scheme not in SCHEDULER_SCHEMES:
        why = f"unknown scheme {scheme!r} (one of {', '.join(SCHEDULER_SCHEMES)})"
    elif scheme == "inproc":
        why = None if where else "no address after inproc://"
    elif not colon:
        why = "no port"
    elif not host:
        why = "no host"
    elif not _HOST.fullmatch(host):
        why = f"host {host!r} is not a host name or IP address"
    elif not port.isdigit():
        why = f"port {port!r} is not a number"
    elif not 1 <= int(port) <= 65535:
        why = f"port {int(port)} is not in 1..65535"
    if why is not None:
        raise InputError(
            f"--scheduler {address} is not a Dask scheduler address: {why}",
            hint="give the scheduler's address as Dask prints it, e.g. --scheduler "
            "tcp://10.0.0.5:8786",
        )


def check_not_an_input(out: Path, logs: tuple[Path, ...]) -> None:
    """The map ``out`` is none of the ``logs`` (:class:`InputError`); a map given as a log,
    which without ``-o`` is its own output (``aion build office.aion``), is named as such."""
    resolved = out.resolve()
    if not any(resolved == p.resolve() for p in logs):
        return
    from aion_cli.formats.input_kind import input_kind

    if input_kind(out) == "map":
        raise LogFormatError(
            f"{out} is an aion map, not a log",
            hint=f"extend it with `aion build LOG --map {path_word(out)}`, query it with "
            f"`aion predict {path_word(out)}`",
        )
    raise InputError(
        f"the map would overwrite the log {out}",
        hint="choose another output for the map (maps end in .aion)",
    )

def resolve_config(opts: BuildOptions, previous: ModelConfig | None) -> ModelConfig:
    """The model config of a build: ``--config`` (or the defaults) with ``--tz`` as its time
    zone for a new map; for a continued one the map's own, ``previous`` (which neither may
    change: a mismatch is a :class:`~aion_cli.errors.ConfigError`)."""
    given = opts.config
    zone = opts.timezone
    if previous is None:
        config = given or ModelConfig()
        if zone is None or zone == config.timezone:
            return config
        if given is not None and given.timezone != ModelConfig().timezone:
            raise ConfigError(
                f"--tz {zone} differs from the config's timezone {given.timezone}",
                hint="give the zone once, with --tz or in the config file",
            )
        return config.replace(timezone=zone)
    from aion_cli.engine.temporal.zones import same_zone

    old = previous
    if given is not None and (
        given.timezone == ModelConfig().timezone or same_zone(given.timezone, old.timezone)
    ):
        # the file's zone is the default, which --tz replaced when the map was made (the
        # map's zone is compared with --tz below, the file's other parameters here), or the
        # map's under another name (Etc/UTC for UTC)
        given = given.replace(timezone=old.timezone)
    if given is not None and given.fremen_clock != old.fremen_clock:
        # the clock is the map's, not a parameter to choose: an older map keeps its own
        given = given.replace(fremen_clock=old.fremen_clock)
    if given is not None and given != old:
        from aion_cli.listing import first_few
        from aion_cli.merge_config import parameter_differences

        differ = parameter_differences(old.to_dict(), given.to_dict())
        raise ConfigError(
            "--config differs from the config the map was built with (map vs --config: "
            f"{first_few(differ, 3)})",
            hint="a map keeps its model parameters; build a new map to change them (or leave "
            "out --config: a continued map keeps its own)",
        )
    if zone is not None and not same_zone(zone, old.timezone):  # GB is Europe/London
        raise ConfigError(
            f"the map's days and profiles follow the time zone {old.timezone}; "
            f"--tz {zone} differs",
            hint="a map keeps its time zone; build a new map to change it",
        )
    return old


def build_topics(logset: Any, opts: BuildOptions) -> Any:
    """The :class:`~aion_cli.topics.TopicPlan` of a build with ``opts`` among the topics of
    ``logset``: :func:`aion_cli.topics.select_topics` with its topic options and
    ``--detections-mapping`` (one choice for the build and for a parallel build's planning)."""
    from aion_cli.topics import select_topics

    return select_topics(
        logset.topics,
        opts.detection_topics,
        opts.graph_topic,
        load_mappings(opts.detections_mapping),
        unreadable=logset.unreadable_topics,
    )


def load_mappings(path: Path | None) -> list[Any]:
    """The [[topic]] tables of ``--detections-mapping`` (none without it)."""
    if path is None:
        return []
    from aion_cli.formats.detections.mapping import load_mapping

    return load_mapping(Path(path))


@dataclass(frozen=True)
class ShardStart:
    """Where a shard of a parallel build (:mod:`aion_cli.parallel_build`) starts in the
    stream of one pass: ``part``, a time shard's log time ``[lo, hi)`` (:mod:`aion_cli.
    time_shards`; None: its logs whole); ``first_part``, whether it is its logs' first part,
    whose report carries what the whole-log reads counted; and, for a shard learnt in sequence
    onto the shards before it, what their stream left: the pose-orientation rule's state per
    detection topic (``yaw_seen``) and the scene graphs' pinned version and layer
    (``graph_pins``, :attr:`aion_cli.graph_feed.GraphFeed.pins`); and the static transforms
    of all the build's logs (``static_tf``, :func:`aion_cli.tf_feed.read_static_tf`), which
    one pass would apply to every log whichever recorded them; ``opens_map``: no map and no
    logs come before the shard's logs, so a time shard of them starts the map where one pass
    starts it (:func:`aion_cli.build_observation.observe`)."""

    part: tuple[int, int] | None = None
    first_part: bool = True
    yaw_seen: Mapping[str, float] | None = None
    graph_pins: tuple[str | None, str | None] = (None, None)
    static_tf: StaticTf = ()
    opens_map: bool = False
