"""Which topics of a log ``aion build`` reads: people detections, scene graphs and TF, by type."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from aion_cli.engine.errors import TopicNotFoundError

if TYPE_CHECKING:
    from formats.raw import TopicInfo

DSG_TYPES = frozenset({"hydra_msgs/msg/DsgUpdate"})
TF_TYPES = frozenset({"tf2_msgs/msg/TFMessage", "tf/msg/tfMessage"})


@dataclass
class TopicPlan:
    """The topics a build reads, by role."""

    detections: list[TopicInfo] = field(default_factory=list)
    graph: list[TopicInfo] = field(default_factory=list)
    tf: list[TopicInfo] = field(default_factory=list)
    ignored: list[TopicInfo] = field(default_factory=list)

    def names(self, role: str) -> set[str]:
        return {t.topic for t in getattr(self, role)}


def select_topics(
    topics: Iterable[TopicInfo],
    detection_topics: tuple[str, ...] = (),
    graph_topic: str | None = None,
) -> TopicPlan:
    """Pick topics by message type; named topics must exist and have a usable type.

    Several detection topics are all used unless ``detection_topics`` names some: people
    trackers often publish the same people on more than one topic, so the report lists them
    and ``--detections-topic`` narrows the choice.
    """
    from formats.detections import adapter_for

    topics = list(topics)
    by_name = {t.topic: t for t in topics}
    plan = TopicPlan()
    supported = [t for t in topics if adapter_for(t.msgtype) is not None]
    if detection_topics:
        for name in detection_topics:
            info = by_name.get(name)
            if info is None or adapter_for(info.msgtype) is None:
                raise TopicNotFoundError(
                    f"no people-detection topic {name!r} in the log"
                    + (f" (it has type {info.msgtype})" if info else ""),
                    candidates=[f"--detections-topic {t.topic}" for t in supported],
                    hint=_candidate_hint("--detections-topic", supported, "people detections"),
                )
            plan.detections.append(info)
    else:
        plan.detections = supported
    dsg = [t for t in topics if t.msgtype in DSG_TYPES]
    if graph_topic is not None:
        info = by_name.get(graph_topic)
        if info is None or info.msgtype not in DSG_TYPES:
            raise TopicNotFoundError(
                f"no scene-graph topic {graph_topic!r} in the log",
                candidates=[f"--graph-topic {t.topic}" for t in dsg],
                hint=_candidate_hint("--graph-topic", dsg, "hydra_msgs/DsgUpdate scene graphs"),
            )
        dsg = [info]
    plan.graph = dsg
    plan.tf = [t for t in topics if t.msgtype in TF_TYPES]
    used = plan.names("detections") | plan.names("graph") | plan.names("tf")
    plan.ignored = [t for t in topics if t.topic not in used]
    return plan


def _candidate_hint(option: str, infos: list[TopicInfo], what: str) -> str:
    if not infos:
        return f"the log has no {what}; run `aion info LOG` to see its topics"
    return "use one of: " + "  ".join(f"{option} {t.topic}" for t in infos)
