"""Which topics of a log ``aion build`` reads: people detections, scene graphs and TF, by type.

People detections are taken automatically when their type is a people type (spencer
``TrackedPersons``, ``people_msgs/People``, ``leg_tracker/PersonArray``, ...). Generic types
that robots publish for many other things (:data:`GENERIC_TYPES`: ``PoseStamped`` navigation
goals, ``PoseArray`` particle clouds, ``Marker(Array)`` visualisations) are taken only when the
topic's name suggests people (:func:`name_suggests_people`) or the user names the topic with
``--detections-topic``. A TOML mapping (``--detections-mapping``) adds topics of any type.
:class:`TopicPlan` says why each topic is taken or skipped, for ``aion info``.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from aion_cli.errors import InputError, TopicNotFoundError

if TYPE_CHECKING:
    from aion_cli.formats.detections.mapping import TopicMapping
    from aion_cli.formats.raw import TopicInfo

DSG_TYPES = frozenset({"hydra_msgs/msg/DsgUpdate"})
TF_TYPES = frozenset({"tf2_msgs/msg/TFMessage", "tf/msg/tfMessage"})

#: Types with a detection adapter that are not specific to people: used only from topics whose
#: name suggests people, or that the user names.
GENERIC_TYPES = frozenset(
    {
        "geometry_msgs/msg/PoseStamped",
        "geometry_msgs/msg/PoseArray",
        "geometry_msgs/msg/PoseWithCovarianceStamped",
        "geometry_msgs/msg/PointStamped",
        "visualization_msgs/msg/Marker",
        "visualization_msgs/msg/MarkerArray",
    }
)

#: Words of a topic name that suggest people (singular, plural and tracker forms).
PEOPLE_WORDS = frozenset(
    {
        "person", "persons", "people", "peoples", "human", "humans", "pedestrian",
        "pedestrians", "ped", "peds", "agent", "agents", "track", "tracks", "tracked",
        "tracker", "trackers", "tracking", "tracklet", "tracklets", "leg", "legs", "crowd",
        "crowds",
    }
)  # fmt: skip

_WORD = re.compile(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])|\d+")


def name_suggests_people(topic: str) -> bool:
    """Whether a word of ``topic`` (split at ``/``, ``_``, ``-``, digits and camelCase) is one
    of :data:`PEOPLE_WORDS`: ``/leg_cluster_positions``, ``/people_tracker/poses`` and
    ``/humanTracks`` do, ``/move_base_simple/goal`` and ``/legacy/poses`` do not."""
    return any(w.lower() in PEOPLE_WORDS for w in _WORD.findall(topic))


def _short(msgtype: str) -> str:
    return msgtype.rsplit("/", 1)[-1]


@dataclass
class TopicPlan:
    """The topics a build reads, by role, and why.

    ``reasons``: per topic taken or skipped, one line saying why; ``skipped``: detection-type
    topics that are not used (generic types on topics whose name does not suggest people, or
    topics left out by ``--detections-topic``); ``mappings``: the TOML mapping of each mapped
    detection topic."""

    detections: list[TopicInfo] = field(default_factory=list)
    graph: list[TopicInfo] = field(default_factory=list)
    tf: list[TopicInfo] = field(default_factory=list)
    ignored: list[TopicInfo] = field(default_factory=list)
    skipped: list[TopicInfo] = field(default_factory=list)
    reasons: dict[str, str] = field(default_factory=dict)
    mappings: dict[str, TopicMapping] = field(default_factory=dict)

    def names(self, role: str) -> set[str]:
        return {t.topic for t in getattr(self, role)}


def _why_automatic(info: TopicInfo) -> tuple[bool, str]:
    """Whether a topic with a built-in adapter is taken without being named, and why."""
    if info.msgtype not in GENERIC_TYPES:
        return True, "people type"
    kind = _short(info.msgtype)
    if name_suggests_people(info.topic):
        return True, f"generic {kind}, the name suggests people"
    return False, (
        f"skipped: generic {kind} on {info.topic} (name does not suggest people; "
        "name it with --detections-topic)"
    )


def select_topics(
    topics: Iterable[TopicInfo],
    detection_topics: tuple[str, ...] = (),
    graph_topic: str | None = None,
    mappings: Sequence[TopicMapping] = (),
    unreadable: Mapping[str, str] | None = None,
) -> TopicPlan:
    """Pick topics by message type (see the module docstring); named and mapped topics must
    exist and have a usable type.

    Several detection topics are all used unless ``detection_topics`` names some: people
    trackers often publish the same people on more than one topic, so the report lists them
    and ``--detections-topic`` narrows the choice. ``unreadable``: topics the log holds in
    encodings aion cannot decode, and why (a named one is said to be there, unreadable).
    """
    from aion_cli.formats.detections import adapter_for

    topics = list(topics)
    by_name = {t.topic: t for t in topics}
    plan = TopicPlan()
    mapped = _mapped_topics(by_name, mappings, plan)
    supported = [t for t in topics if t.topic in mapped or adapter_for(t.msgtype) is not None]
    if detection_topics:
        for name in detection_topics:
            info = by_name.get(name)
            why = (unreadable or {}).get(name)
            if info is None and why is not None:
                from aion_cli.formats.logs import unreadable_topic_error

                raise unreadable_topic_error(
                    name, why, [f"--detections-topic {t.topic}" for t in supported]
                )
            if info is None or (name not in mapped and adapter_for(info.msgtype) is None):
                raise TopicNotFoundError(
                    f"no people-detection topic {name!r} in the log"
                    + (f" (it has type {info.msgtype})" if info else ""),
                    candidates=[f"--detections-topic {t.topic}" for t in supported],
                    hint=_named_hint(name, info, supported),
                )
            if info not in plan.detections:
                plan.detections.append(info)
                plan.reasons[name] = "named with --detections-topic" + (
                    " (--detections-mapping)" if name in mapped else ""
                )
        for info in supported:
            if info not in plan.detections:
                plan.skipped.append(info)
                plan.reasons[info.topic] = "skipped: not named with --detections-topic"
    else:
        for info in supported:
            if info.topic in mapped:
                take, why = True, "--detections-mapping"
            else:
                take, why = _why_automatic(info)
            (plan.detections if take else plan.skipped).append(info)
            plan.reasons[info.topic] = why
    dsg = [t for t in topics if t.msgtype in DSG_TYPES]
    if graph_topic is not None:
        info = by_name.get(graph_topic)
        if info is None or info.msgtype not in DSG_TYPES:
            raise TopicNotFoundError(
                f"no scene-graph topic {graph_topic!r} in the log"
                + (f" (it has type {info.msgtype})" if info else ""),
                candidates=[f"--graph-topic {t.topic}" for t in dsg],
                hint=_candidate_hint("--graph-topic", dsg, "hydra_msgs/DsgUpdate scene graphs"),
            )
        dsg = [info]
    elif len(dsg) > 1:  # Hydra's frontend graph beside the backend's: the backend's
        backend = [t for t in dsg if not _hydra_frontend(t.topic)]
        if backend:
            for info in dsg:
                if _hydra_frontend(info.topic):
                    plan.reasons[info.topic] = FRONTEND_REASON
            dsg = backend
    plan.graph = dsg
    plan.tf = [t for t in topics if t.msgtype in TF_TYPES]
    for info in plan.graph:
        plan.reasons.setdefault(info.topic, "hydra_msgs/DsgUpdate")
    used = plan.names("detections") | plan.names("graph") | plan.names("tf")
    plan.ignored = [t for t in topics if t.topic not in used]
    for info in plan.ignored:
        plan.reasons.setdefault(info.topic, _zone_topic(info) or _skipped_type(info.msgtype))
    return plan


FRONTEND_REASON = (
    "Hydra's frontend scene graph (odom frame, not optimized): the backend's is used "
    "(--graph-topic to choose)"
)
"""The reason of a frontend DsgUpdate topic left out beside a backend one."""


def _hydra_frontend(topic: str) -> bool:
    """Whether ``topic`` is Hydra's frontend DsgUpdate topic (``/hydra/frontend/dsg``,
    ``/hydra_ros_node/frontend/dsg``, a robot's ``/<robot>/hydra/frontend/dsg``), which
    Hydra publishes beside the backend's by default (``enable_frontend_output``)."""
    return "frontend" in topic.split("/")


def _zone_topic(info: TopicInfo) -> str | None:
    """The reason of a ROS 1 bag's time-zone or observed-spans topic
    (:mod:`formats.log_zone`), None else."""
    from aion_cli.formats.log_zone import KEY, OBSERVED_KEY, RECORD, STRING, metadata_topic

    if info.msgtype != STRING:
        return None
    if info.topic == metadata_topic(RECORD, KEY):
        return "the log's time zone (aion simulate or convert --tz): build follows it without --tz"
    if info.topic == metadata_topic(RECORD, OBSERVED_KEY):
        return (
            "the spans the sensor was observing (aion convert --observed): build takes them "
            "without --observed"
        )
    return None


RAW_SENSOR_REASON = "is raw sensor data, not detected people"
"""The end of a skipped raw-sensor topic's reason (``aion info`` checks for it)."""


def _is_raw_sensor(msgtype: str) -> bool:
    from aion_cli.formats.detections.registry import unreadable_kind

    return unreadable_kind(msgtype) == "raw sensor data"


def _skipped_type(msgtype: str) -> str:
    """Why a topic of a type aion has no adapter for is skipped, and what would read it:
    raw sensor data, ROS plumbing and service events hold no people (a detector's output
    would); other types a TOML mapping may read."""
    from aion_cli.formats.detections.registry import SERVICE_EVENTS, unreadable_kind

    kind = unreadable_kind(msgtype)
    if kind == "raw sensor data":
        return f"skipped: {_short(msgtype)} {RAW_SENSOR_REASON}"
    if kind == SERVICE_EVENTS:
        return f"skipped: {_short(msgtype)} records the calls of a service, not people"
    if kind is not None:
        package = msgtype.split("/", 1)[0]
        return f"skipped: {_short(msgtype)} ({package}) holds no positions of people"
    return f"skipped: {_short(msgtype)} is not a type aion reads {MAPPING_CAN_READ}"


MAPPING_CAN_READ = "(a TOML mapping can read it: --detections-mapping)"
"""The end of the reason of a topic whose type a mapping may read
(:func:`aion_cli.topic_mappable.refine_reasons`)."""


def _mapped_topics(
    by_name: dict[str, TopicInfo], mappings: Sequence[TopicMapping], plan: TopicPlan
) -> set[str]:
    """Topics of ``mappings`` (each must be in the log, with the mapping's type)."""
    for m in mappings:
        info = by_name.get(m.topic)
        if info is None:
            from aion_cli.formats.raw import topic_spelling_hint

            near = topic_spelling_hint(m.topic, by_name)
            raise TopicNotFoundError(
                f"the detections mapping names topic {m.topic!r}, which is not in the log",
                candidates=[f"{t.topic} ({t.msgtype})" for t in by_name.values()],
                hint="fix `topic = ...` in the mapping; "
                + (near or "`aion info LOG` lists the topics"),
            )
        if info.msgtype != m.msgtype:
            raise TopicNotFoundError(
                f"the detections mapping reads {m.topic!r} as {m.msgtype}, but the log's "
                f"{m.topic} carries {info.msgtype}",
                hint=f"set msgtype = \"{info.msgtype}\" and check the paths, or write a new "
                f"mapping with `aion info LOG --suggest-mapping {m.topic}`",
            )
        if m.topic in plan.mappings:
            raise TopicNotFoundError(
                f"the detections mapping has two [[topic]] tables for {m.topic!r}",
                hint="keep one table per topic",
            )
        plan.mappings[m.topic] = m
    return set(plan.mappings)


def _named_hint(name: str, info: TopicInfo | None, supported: list[TopicInfo]) -> str:
    hint = _candidate_hint("--detections-topic", supported, "people detections")
    if info is None:
        return hint
    if info.msgtype in TF_TYPES or info.msgtype in DSG_TYPES:
        role = "TF" if info.msgtype in TF_TYPES else "the scene graph"
        return f"{hint}; the build reads {name} as {role}, never as people"
    reason = _skipped_type(info.msgtype)
    if not reason.endswith("--detections-mapping)"):  # raw sensor data, plumbing, services
        return f"{hint}; {name}: {reason.removeprefix('skipped: ')}"
    return (
        f"{hint}; or map {info.msgtype} with --detections-mapping FILE (`aion info LOG "
        f"--suggest-mapping {name}` writes one)"
    )


def _candidate_hint(option: str, infos: list[TopicInfo], what: str) -> str:
    if not infos:
        return f"the log has no {what}; run `aion info LOG` to see its topics"
    return "use one of: " + "  ".join(f"{option} {t.topic}" for t in infos)


def _mappable(topics: Sequence[TopicInfo]) -> list[TopicInfo]:
    """The topics whose types a TOML mapping might read people from (not raw sensor data,
    not ROS plumbing such as std_msgs or rcl_interfaces, not service events)."""
    from aion_cli.formats.detections.registry import unreadable_kind

    return [t for t in topics if unreadable_kind(t.msgtype) is None]


def not_people_kind(msgtype: str) -> str | None:
    """What a type that clearly holds no detections of people is, or None: TF, a scene
    graph (both read by the build as such), raw sensor data (images, point clouds, scans)."""
    from aion_cli.formats.raw import normalize_msgtype

    name = normalize_msgtype(msgtype)
    if name in TF_TYPES:
        return "TF transforms (aion build reads them as the frames and the robot's trajectory)"
    if name in DSG_TYPES or name.endswith("/DsgUpdate"):
        return "a scene graph (aion build reads it as the map's graph)"
    if _is_raw_sensor(name):
        return "raw sensor data"
    return None


def several_graph_topics(names: list[str]) -> InputError:
    """The refusal of logs with several scene-graph streams at the same time and no
    ``--graph-topic``: their graphs would take turns as the map's graph (another place set,
    frame or session with every message), and the map would keep whichever came last."""
    return InputError(
        f"the logs carry {len(names)} scene-graph topics at the same time "
        f"({', '.join(names)}): their graphs would take turns as the map's graph; nothing "
        "was built",
        hint=f"name the one to build on with --graph-topic (e.g. --graph-topic {names[0]})",
    )
