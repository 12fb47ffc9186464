"""What a TOML mapping (``--detections-mapping``) could read among a log's topics, and what a
log without a usable detection topic is told: the topics whose type holds a field a mapping
reads as a position (:func:`mapping_example`, :func:`detection_candidates`), those whose type
the log does not define (:func:`undefined_topics`: a ROS 2 Humble rosbag2 of sqlite3 storage,
which no mapping reads), the skipped topics' reasons refined with these (:func:`refine_reasons`)
and the build's error (:func:`no_detection_topic`). :mod:`aion_cli.topics` selects the topics.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from aion_cli.errors import InputError, MissingDefinitionError, TopicNotFoundError
from aion_cli.topics import (
    DSG_TYPES,
    GENERIC_TYPES,
    MAPPING_CAN_READ,
    TF_TYPES,
    TopicPlan,
    _is_raw_sensor,
    _mappable,
    _short,
    not_people_kind,
)

if TYPE_CHECKING:
    from aion_cli.formats.raw import TopicInfo


def mapping_example(logset: Any) -> str | None:
    """The first topic of ``logset`` that ``aion info LOG --suggest-mapping`` writes a mapping
    for (a field it reads as a position, in the log's own definition): never TF or a scene
    graph, which the build reads as such, nor a type such as a Twist or a Color; None when no
    topic's type holds a position. Each definition is tried once (``suggest_mapping`` reads
    only the definition, so topics sharing one share the answer): a log of a thousand topics
    of a few types parses a few definitions, and every topic is considered (it said
    ``"TOPIC"``, a placeholder no command takes, when its first 50 topics held no position)."""
    tried: _Tried = {}
    for info in _mappable(logset.topics):
        if info.msgtype in TF_TYPES | DSG_TYPES:
            continue
        if _holds_position(logset, info, tried):
            return info.topic
    return None


_Tried = dict[tuple[str, str, str, bool], bool | None]
""":func:`_holds_position`'s answers per (encoding, type, definition, is IDL)."""


def _holds_position(
    logset: Any, info: TopicInfo, tried: _Tried
) -> bool | None:
    """Whether ``aion info LOG --suggest-mapping`` finds a position field in the topic's
    type (the log's own definition), None when the log carries no definition of the type
    and aion ships none (nothing tells whether it has one); ``tried`` caches the answer per
    definition."""
    from aion_cli.formats.detections.suggest import suggest_mapping

    definition, idl = logset.definition(info.topic, info.msgtype, info.encoding)
    key = (info.encoding, info.msgtype, definition, idl)  # the typestore's own key
    if key not in tried:
        try:
            suggest_mapping(
                info.topic, info.msgtype, logset.typestore(info.topic, info.msgtype, info.encoding)
            )
            tried[key] = True
        except MissingDefinitionError:
            tried[key] = None
        except InputError:  # no position field, or a definition that cannot be parsed
            tried[key] = False
    return tried[key]


NO_DEFINITION_REASON = "the log carries no definition of it for a --detections-mapping to read"
"""The end of the reason of a topic of a type the log does not define (:func:`refine_reasons`)."""


def refine_reasons(logset: Any, plan: TopicPlan) -> None:
    """A skipped topic's reason offers a mapping only where its type has a field a mapping
    could read as a position: ``test_msgs/Strings`` read 'a TOML mapping can read it' beside
    info's note that none of the log's types has one (``--suggest-mapping`` refuses it). A
    type the log does not define (a ROS 2 Humble rosbag2 of sqlite3 storage) says so: no
    mapping reads it, whatever its fields."""
    tried: _Tried = {}
    for info in plan.ignored:
        why = plan.reasons.get(info.topic, "")
        if not why.endswith(MAPPING_CAN_READ):
            continue
        holds = _holds_position(logset, info, tried)
        if holds is None:
            plan.reasons[info.topic] = (
                f"skipped: {_short(info.msgtype)} is not a type aion reads, and "
                + NO_DEFINITION_REASON
            )
        elif not holds:
            plan.reasons[info.topic] = (
                f"skipped: {_short(info.msgtype)} is not a type aion reads, and has no field "
                "a --detections-mapping could read as a position"
            )


def undefined_topics(logset: Any) -> list[str]:
    """The topics (``TOPIC (type)``) a mapping might read but whose type the log does not
    define and aion does not ship: what the error of a log without a usable detection topic
    names, instead of saying their types hold no position."""
    tried: _Tried = {}
    return [
        f"{info.topic} ({info.msgtype})"
        for info in _mappable(logset.topics)
        if info.msgtype not in TF_TYPES | DSG_TYPES
        and _holds_position(logset, info, tried) is None
    ]


def no_detection_topic(logset: Any, plan: TopicPlan) -> TopicNotFoundError:
    """The error for a log with no detection topic to use: what it has, why generic topics
    were skipped, and how to read another type."""
    found = [f"{t.topic} ({t.msgtype})" for t in logset.topics]
    mappable = _mappable(logset.topics)
    example = mapping_example(logset) if mappable and not plan.skipped else None
    from aion_cli.formats.scene_mcap import is_scene_mcap

    if logset.files and all(is_scene_mcap(f.path) for f in logset.files):  # its own markers
        hint = (
            "it is a scene aion exported (aion export --format mcap), to open in Foxglove or "
            "RViz: build a map from the robot's logs"
        )
    elif plan.skipped:
        first = plan.skipped[0]
        hint = (
            f"{plan.reasons[first.topic]}; or map another type with --detections-mapping FILE"
        )
    elif logset.topics and all(_is_raw_sensor(t.msgtype) for t in logset.topics):
        from aion_cli.formats.detections.registry import RAW_SENSOR_HINT

        hint = f"it holds only raw sensor data ({', '.join(found[:4])}): {RAW_SENSOR_HINT}"
    elif logset.topics and not mappable:
        from aion_cli.formats.detections.registry import RAW_SENSOR_HINT

        hint = (
            f"none of its topics holds positions of people ({', '.join(found[:4])}"
            f"{', ...' if len(found) > 4 else ''}: sensor data, logging, parameters, service "
            f"calls or plain values): {RAW_SENSOR_HINT}"
        )
    elif not found:  # channels that are not ROS (other encodings), or none at all
        hint = (
            "it has no ROS topic aion can read (only other encodings, or no channels); "
            "`aion info LOG` lists what was skipped and why"
        )
    elif example is None and (undefined := undefined_topics(logset)):
        from aion_cli.errors import NO_DEFINITION_HINT

        hint = (
            f"no --detections-mapping can read {', '.join(undefined[:4])}"
            f"{', ...' if len(undefined) > 4 else ''}: {NO_DEFINITION_HINT}"
        )
    elif example is None:
        from aion_cli.formats.detections.registry import RAW_SENSOR_HINT

        hint = (
            "the log has: "
            + ", ".join(found[:8] + (["..."] if len(found) > 8 else []))
            + "; none of their types has a field a --detections-mapping could read as a "
            f"position (`aion info LOG` says why each is skipped): {RAW_SENSOR_HINT}"
        )
    else:
        hint = (
            "the log has: "
            + ", ".join(found[:8] + (["..."] if len(found) > 8 else []))
            + "; map a type with --detections-mapping FILE (`aion info LOG --suggest-mapping "
            f"{example}` writes one)"
        )
    return TopicNotFoundError(
        "the log has no people-detection topic of a supported type", candidates=found, hint=hint
    )


def detection_candidates(logset: Any) -> list[TopicInfo]:
    """The topics of ``logset`` that look like detections of people, best first: those of a
    type with a detection adapter (people types, then generic types), then those whose type
    holds a field a mapping reads as a position (:func:`mapping_example`'s test)."""
    from aion_cli.formats.detections import adapter_for

    adapted = [t for t in logset.topics if adapter_for(t.msgtype) is not None]
    adapted.sort(key=lambda t: t.msgtype in GENERIC_TYPES)  # people types first
    tried: _Tried = {}
    mapped = [
        t
        for t in _mappable(logset.topics)
        if t not in adapted
        and not_people_kind(t.msgtype) is None
        and _holds_position(logset, t, tried)
    ]
    return adapted + mapped


def refuse_not_people(logset: Any, info: TopicInfo) -> None:
    """``aion info --suggest-mapping TOPIC`` of a type that holds no people (TF, a scene
    graph, raw sensor data: :func:`not_people_kind`): a :class:`ConfigError` whose hint lists
    the topics that look like detections (:func:`detection_candidates`). A mapping of TF
    read every transform, the robot's own among them, as a person."""
    from aion_cli.errors import ConfigError

    kind = not_people_kind(info.msgtype)
    if kind is None:
        return
    found = [f"{t.topic} ({t.msgtype})" for t in detection_candidates(logset)]
    if found:
        hint = (
            "topics that look like detections of people: "
            + ", ".join(found[:6] + (["..."] if len(found) > 6 else []))
            + " (`aion info LOG` says how aion reads each)"
        )
    else:
        from aion_cli.formats.detections.registry import RAW_SENSOR_HINT

        hint = f"no topic of the log looks like detections of people: {RAW_SENSOR_HINT}"
    raise ConfigError(
        f"{info.topic}: {info.msgtype} holds {kind}, not detections of people: no mapping "
        "reads people from it",
        hint=hint,
    )
