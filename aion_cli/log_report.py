"""``aion info LOG`` and ``aion.info``: the report of logs -- what is in them and what
``aion build`` will use from them (:func:`describe`), in the zone :func:`report_zone` chooses,
with what the log's TF says of the detections' frames (:func:`add_frames`) -- and
``--suggest-mapping`` (:func:`suggest`).

No click or rich here: the command (:mod:`aion_cli.cli.info`) prints the report, the Python
API (:mod:`aion_cli.api_info`) returns it; both call these (moved from ``aion_cli/cli/`` so
the API need not import the command line).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any


def describe(
    paths: list[Path],
    log_format: str | None,
    mapping: Path | None = None,
    tz: str = "UTC",
    verify: bool = False,
) -> dict[str, Any]:
    """The info report of ``paths`` as a plain dict (also the JSON document):
    ``formats.summary`` plus what ``aion build`` will use (with ``mapping``, a
    ``--detections-mapping`` file), why each topic is used or skipped, the scene-graph
    payload version, and a fixed sensor's hours with messages in the zone ``tz``. With
    ``verify``, every message is read first, as a build reads them: chunks that cannot be
    read (damaged, CRC failures) are warnings with the messages lost, as a build's are, and
    ``verified.messages_read`` counts the messages read."""
    from aion_cli.build_report import NoProgress
    from aion_cli.engine.time_text import utc_text
    from aion_cli.formats.log_zone import declared_zones
    from aion_cli.formats.logs import open_logs
    from aion_cli.formats.summary import summarize
    from aion_cli.message_hours import fixed_sensor_windows
    from aion_cli.provenance import distinct_logs
    from aion_cli.stamp_warnings import sim_time_warning
    from aion_cli.topic_mappable import refine_reasons
    from aion_cli.topics import select_topics

    mappings = _mappings(mapping)
    example: str | None = None
    distinct = distinct_logs(tuple(paths), NoProgress(), {})  # a copy is read once, as build
    with open_logs(distinct.logs, log_format, allow_empty=True) as logset:
        read = sum(1 for _ in logset.messages(None)) if verify else None  # warns as it reads
        summary = summarize(logset, [m.msgtype for m in mappings])
        _leave_out_strays(summary, logset)
        plan = select_topics(logset.topics, mappings=mappings)
        _check_mappings(logset, plan)
        refine_reasons(logset, plan)  # no mapping offered for a type without a position
        firsts = {
            info.topic: _first_graph(logset, info.topic, distinct.logs, log_format)
            for info in plan.graph
        }
        for topic, first in firsts.items():
            summary.dsg_versions[topic] = first.versions
            if first.passed:
                summary.warnings.append(
                    f"{topic}: described by the first scene graph aion build uses, logged "
                    f"{utc_text(first.t_ns or 0)}; {first.passed:,} graph message(s) before it "
                    "left out (stray log time, damaged or partial update)"
                )
        report = summary.to_dict()
        not_ros = logset.unreadable_topics  # why a topic in another encoding is not read
        report["warnings"] = distinct.notes + report["warnings"]
        sim = sim_time_warning(logset.start_ns if logset.total() else None, "the log's time")
        report["warnings"] += [sim] if sim is not None else []
        if read is not None:
            report["verified"] = {"messages_read": read}
        if plan.detections and not plan.tf and _no_graph_robot(firsts):
            report["fixed_sensor"] = fixed_sensor_windows(logset, tz)
        report["observed_spans"] = _recorded_spans(distinct.logs)
        report["declared_zones"] = declared_zones(list(distinct.logs))
        if plan.detections:
            add_frames(report, logset, plan, mappings, not _no_graph_robot(firsts))
            report["warnings"] += _overlaps(logset, plan)
        else:
            from aion_cli.topic_mappable import mapping_example

            example = mapping_example(logset)
    used = plan.names("detections") | plan.names("graph") | plan.names("tf")
    for topic in report["topics"]:
        topic["used"] = topic["topic"] in used
        topic["why"] = plan.reasons.get(topic["topic"], topic["role"])
        if not topic["readable"]:
            topic["why"] = not_ros.get(topic["topic"], topic["why"])
    report["format"] = ", ".join(report["formats"]) or None
    report["will_use"] = {
        "detections": sorted(plan.names("detections")),
        "scene_graph": sorted(plan.names("graph")),
        "tf": sorted(plan.names("tf")),
    }
    report["cannot_read"] = [f"{t.topic} ({t.msgtype})" for t in plan.ignored]
    if not plan.detections:
        report["mapping_example"] = example
    _own_scene(report)
    return report


def report_zone(tz: str | None, paths: list[Path]) -> str:
    """The zone the report of ``paths`` gives its times in: ``tz`` (checked before any log
    is read), else the zone the logs declare (as ``aion build`` follows it), else UTC."""
    from aion_cli.timeparse import resolve_zone

    if tz is not None:
        return resolve_zone(tz).name
    from aion_cli.log_zone import build_zone

    return build_zone(None, None, paths)[0] or "UTC"


def add_frames(
    report: dict[str, Any], logset: Any, plan: Any, mappings: list[Any], robot_poses_elsewhere: bool
) -> None:
    """``frames_without_tf``, ``tf_roots`` and the TF warnings into ``report`` (and, for a fixed
    sensor, how many of the detection messages sampled held nobody; how a Marker topic is
    read, into ``plan``'s reasons: the topic's ``why``); the warning on
    a robot without ``base_link`` only when no scene graph gives robot poses
    (``robot_poses_elsewhere``: the build would observe with those)."""
    from aion_cli.frame_check import unconnected_frames

    frames = unconnected_frames(logset, plan, mappings)
    for topic, text in frames.read_as.items():  # how a Marker topic is read: in its `why`
        plan.reasons[topic] = f"{plan.reasons.get(topic, 'detections')}; {text}"
    report["frames_without_tf"] = frames.apart
    report["tf_roots"] = frames.roots
    report["warnings"].extend(frames.warnings)
    if report.get("fixed_sensor") is not None:  # a silent tracker publishes no empty message
        report["fixed_sensor"]["empty_in_first_messages"] = frames.empty_messages
    if frames.no_robot is not None and not robot_poses_elsewhere:
        report["warnings"].append(frames.no_robot)


def _own_scene(report: dict[str, Any]) -> None:
    """An MCAP file ``aion export --format mcap`` wrote is a scene, not a log with a topic aion
    cannot read: its ``/aion/scene`` (protobuf, for Foxglove) and ``/aion/markers`` (for RViz)
    say what they hold rather than be warned of as "not ROS" or skipped as generic markers
    (listed in ``cannot_read``, offered as the ``mapping_example``)."""
    from aion_cli.formats.scene_mcap import MARKER_TOPIC, SCENE_TOPIC, is_scene_mcap

    if not report["files"] or not all(is_scene_mcap(Path(f["path"])) for f in report["files"]):
        return
    said = {
        SCENE_TOPIC: "the scene at each step, for Foxglove (aion export --format mcap)",
        MARKER_TOPIC: "the scene at each step as markers, for RViz (aion export --format mcap)",
    }
    for topic in report["topics"]:
        topic["why"] = said.get(topic["topic"], topic["why"])
    report["cannot_read"] = [t for t in report["cannot_read"] if t.split(" (")[0] not in said]
    if report.get("mapping_example") in said:
        report["mapping_example"] = None
    skipped = f": topic {SCENE_TOPIC} skipped ("
    report["warnings"] = [w for w in report["warnings"] if skipped not in w]


def _leave_out_strays(summary: Any, logset: Any) -> None:
    """``summary``'s span without the stray log times ``aion build`` drops, and one warning
    naming them (:func:`aion_cli.log_span.span_without_strays`)."""
    from aion_cli.log_span import span_without_strays

    check = span_without_strays(logset)
    if check is None:
        return
    summary.start_ns, summary.end_ns = check.start_ns, check.end_ns
    summary.recorded_ns = check.recorded_ns
    summary.topics = [_rate_over(t, check.topic_recorded_ns.get(t.topic)) for t in summary.topics]
    summary.warnings += check.warnings()


def _rate_over(topic: Any, recorded_ns: int | None) -> Any:
    """``topic``'s summary with its rate over ``recorded_ns`` (the time its recordings
    recorded without the log times left out of the span), unchanged when that is None."""
    from dataclasses import replace

    if recorded_ns is None or not topic.readable:
        return topic
    seconds = recorded_ns / 1e9
    rate = topic.count / seconds if seconds > 0 and topic.count > 1 else None
    return replace(topic, rate_hz=rate)


def _overlaps(logset: Any, plan: Any) -> list[str]:
    """The warnings ``aion build`` gives of logs that hold a detection topic over the same
    time with the same people (they count twice), over the default model's windows, and of
    detection topics that hold the same people, the detections compared with the adapters
    the build would use."""
    from aion_cli.detection_adapters import log_adapters
    from aion_cli.engine.config import ModelConfig
    from aion_cli.engine.windows import window_ns
    from aion_cli.errors import AionError
    from aion_cli.log_order import overlap_warnings

    try:
        adapters, factory, _ = log_adapters(logset, plan.detections, plan.mappings)
    except AionError:  # the build will stop on it; the shared time alone warns, as it did
        return overlap_warnings(logset, plan.names("detections"), window_ns(ModelConfig().window_s))
    from aion_cli.log_twins import topic_twin_warnings

    adapter_of = lambda *key: adapters.get(key) or factory(*key)  # noqa: E731
    return overlap_warnings(
        logset, plan.names("detections"), window_ns(ModelConfig().window_s), adapter_of
    ) + topic_twin_warnings(logset, sorted(plan.names("detections")), adapter_of)


def _recorded_spans(logs: Any) -> dict[str, list[dict[str, Any]]]:
    """Per log (its path), the observed spans it records (``aion convert --observed``,
    :func:`formats.log_zone.declared_spans`), which ``aion build`` takes without
    ``--observed``: start and end in ns and as UTC times."""
    from aion_cli.engine.time_text import utc_text
    from aion_cli.formats.log_zone import declared_spans

    return {
        path: [
            {"start_ns": a, "end_ns": b, "start": utc_text(a), "end": utc_text(b)}
            for a, b in spans
        ]
        for path, spans in declared_spans(list(logs)).items()
    }


def _mappings(path: Path | None) -> list[Any]:
    if path is None:
        return []
    from aion_cli.formats.detections.mapping import load_mapping

    return load_mapping(path)


def _check_mappings(logset: Any, plan: Any) -> None:
    """Every mapping's paths against the log's own definition of its topic's type (a
    ConfigError naming the path and the fields that exist)."""
    for info in plan.detections:
        mapping = plan.mappings.get(info.topic)
        if mapping is not None:
            mapping.check(logset.typestore(info.topic, info.msgtype, info.encoding))


def suggest(paths: list[Path], log_format: str | None, topic: str) -> str:
    """``--suggest-mapping TOPIC``: a TOML mapping from the log's own definition of the
    topic's type (:func:`formats.detections.suggest.suggest_mapping`)."""
    from aion_cli.formats.detections.suggest import refuse_service_events, suggest_mapping
    from aion_cli.formats.logs import open_logs
    from aion_cli.frame_check import tf_root
    from aion_cli.topic_mappable import refuse_not_people

    with open_logs(paths, log_format) as logset:
        info = logset.topic(topic)
        refuse_service_events(info.topic, info.msgtype)
        refuse_not_people(logset, info)  # TF, a scene graph, images, point clouds
        store = logset.typestore(info.topic, info.msgtype, info.encoding)
        top, has_map = tf_root(logset)
        frame = top or "map"  # the frame a frame_override would name
        sample = _sample(logset, info.topic)
        # a root TF joins to no frame 'map': the build must be told the map is in the root
        map_frame = top if top is not None and not has_map else None
        return suggest_mapping(info.topic, info.msgtype, store, sample, frame, map_frame)


#: messages ``--suggest-mapping`` decodes to tell ids that number a message's items
_SAMPLE = 20


def _sample(logset: Any, topic: str) -> list[Any]:
    """The topic's first few decoded messages (fewer when some do not decode)."""
    from itertools import islice

    from aion_cli.errors import InputError

    out = []
    for raw in islice(logset.messages({topic}), _SAMPLE):
        try:
            out.append(logset.decode(raw))
        except (InputError, ValueError):
            continue
    return out


@dataclass(frozen=True)
class _FirstGraph:
    """The first scene graph of a topic that ``aion build`` uses: its payload version (or why
    it is unreadable), its log time, whether its agent layer holds robot poses (None:
    unreadable) and how many of the topic's messages before it the build leaves out."""

    versions: list[str]
    t_ns: int | None = None
    agents: bool | None = None
    passed: int = 0


def _first_graph(
    logset: Any, topic: str, logs: tuple[Path, ...], log_format: str | None
) -> _FirstGraph:
    """The topic's first scene graph the build uses (:func:`aion_cli.build_lineage.
    first_used_graph`: stray log times, damaged messages and partial updates are passed
    over, as the build passes them over); where none is, the topic's first message, and why
    it is unreadable."""
    import numpy as np

    from aion_cli.build_lineage import first_used_graph
    from aion_cli.build_report import BuildReport
    from aion_cli.errors import InputError
    from aion_cli.formats.dsg import decode_dsg
    from aion_cli.formats.dsg_payload import DecodedGraph
    from aion_cli.graph_feed import GraphFeed

    feed = GraphFeed(BuildReport(Path()), None, None, 0)

    def peek(msg: Any) -> DecodedGraph | None:
        try:
            payload, _ = feed.payload(logset, msg)
            return decode_dsg(np.asarray(payload, dtype=np.uint8), msg.log_time_ns)
        except InputError:
            return None

    used = first_used_graph(logs, log_format, logset, {topic}, peek)
    if used is not None:
        agents = used.value.snapshot.agents
        has = agents is not None and len(agents) > 0
        return _FirstGraph([used.value.version], used.msg.log_time_ns, has, used.passed)
    first = next(iter(logset.messages({topic})), None)
    if first is None:
        return _FirstGraph([])
    try:
        payload = np.asarray(logset.decode(first).layer_contents, dtype=np.uint8)
        decoded = decode_dsg(payload, first.log_time_ns)
    except InputError as exc:
        return _FirstGraph([f"unreadable: {exc.message}"], first.log_time_ns)
    agents = decoded.snapshot.agents
    has = agents is not None and len(agents) > 0
    return _FirstGraph([decoded.version], first.log_time_ns, has)


def _no_graph_robot(firsts: dict[str, _FirstGraph]) -> bool:
    """Whether the build finds no robot trajectory in the scene graph: no graph at all, or
    the logs' first graph carries no robot poses (the build asks that one only:
    ``graph_feed.GraphFeed.first_has_agents``). An unreadable first graph says nothing."""
    timed = [f for f in firsts.values() if f.t_ns is not None]
    if not timed:
        return True
    return min(timed, key=lambda f: f.t_ns or 0).agents is False
