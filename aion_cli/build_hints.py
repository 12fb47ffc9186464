"""The hint of a build that used no detection, by why the detections read were dropped:
the class filter of the built-in types, a ``--detections-mapping``'s filter (with the values
its field held), arrays shorter than a mapping's paths, or a topic that carries nobody.

Why a module of its own: :func:`aion_cli.build_report.check_usable` decides that the build
fails; the words of what to change, one per cause, are this module's.
"""

from __future__ import annotations

from aion_cli.number_text import counted

__all__ = ["no_detection_hint"]


def _class_hint(topics: list[str]) -> str:
    """The hint of a build whose every detection the class filter dropped: what it keeps, and
    how to read a tracker whose people have another class or none (a mapping, which has no
    class filter unless it gives one)."""
    topic = topics[0] if len(topics) == 1 else "TOPIC"
    return (
        "aion keeps the vision_msgs detections of class 'person' and the ZED objects labelled "
        "'Person' (or unlabelled) only; to read other classes or none, read the topic with a "
        f"mapping (`aion info LOG --suggest-mapping {topic}` writes one, without a class "
        "filter; add filter = { field = ..., equals = [...] } to keep some classes); "
    )


def _filter_hint(topics: list[str], dropped: dict[str, int], seen: dict[str, int]) -> str:
    """The hint of a build whose mapping's filter dropped the items (``dropped["filter"]``):
    how many, the values its field held (``seen``: a few, with their counts), and what to
    change."""
    topic = topics[0] if len(topics) == 1 else "TOPIC"
    n = dropped["filter"]
    alone = {k for k, v in dropped.items() if v} == {"filter"}
    by_count = sorted(seen.items(), key=lambda kv: (-kv[1], kv[0]))
    shown = ", ".join(f"{value} ({k:,})" for value, k in by_count)
    rest = n - sum(seen.values())
    if rest > 0:
        shown += f"{', ' if shown else ''}{rest:,} of other values"
    return (
        f"the --detections-mapping's filter dropped {'all ' if alone and n > 1 else ''}"
        f"{counted(n, 'item')}"
        + (f"; its field held {shown}" if shown else "")
        + "; list the values of the people in its equals (`aion info LOG --suggest-mapping "
        f"{topic}` shows the fields), or leave the filter out; "
    )


def no_detection_hint(
    topics: list[str], dropped: dict[str, int], seen: dict[str, int] | None = None
) -> str:
    """The hint of a build that read no usable person, by why: the class filter dropped them
    (:func:`_class_hint`); a mapping's filter did (:func:`_filter_hint`: the items are there,
    so "the topics carry no detections" misled); every item's arrays were shorter than the
    mapping's paths index (``short_array``: likewise); otherwise the topics carry nobody."""
    if dropped.get("class"):
        return _class_hint(topics)
    if dropped.get("filter"):
        return _filter_hint(topics, dropped, seen or {})
    if {k for k, n in dropped.items() if n} == {"short_array"}:
        topic = topics[0] if len(topics) == 1 else "TOPIC"
        return (
            f"the topics carry {dropped['short_array']:,} items, but each one's array is shorter "
            "than an index in the --detections-mapping's paths (pos[0..1] of an empty "
            "pos[]); check those indices against the messages (`aion info LOG "
            f"--suggest-mapping {topic}` shows their fields); "
        )
    return "the topics carry no detections (choose other topics with --detections-topic); "
