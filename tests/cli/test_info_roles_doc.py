"""``aion info --help`` on the detections role: its example picks the topics the build takes.

leg_tracker's bag carries ``/visualization_marker_array`` (a generic MarkerArray whose name
does not suggest people): its role is detections, by type, but the build skips it (``used``
false). The help had said the role is "used by build" and its ``jq select(.role ==
"detections")`` example listed that topic too."""

from __future__ import annotations

import re

from aion_cli.cli.info import EPILOG
from tests.cli.conftest import run_json
from tests.shared_data import real


def _select(expression: str, topic: dict[str, object]) -> bool:
    """The help's jq ``select(...)`` condition on one topic: ``.key == "text"``, ``.key``
    (true), joined by ``and``, the forms the example uses."""
    terms = [term.strip() for term in expression.split(" and ")]
    for term in terms:
        equal = re.fullmatch(r'\.(\w+) == "([^"]*)"', term)
        if equal is not None:
            if topic[equal[1]] != equal[2]:
                return False
        else:
            key = re.fullmatch(r"\.(\w+)", term)
            assert key is not None, f"a jq form this test does not read: {term}"
            if topic[key[1]] is not True:
                return False
    return True


def test_the_helps_detections_example_lists_the_topics_the_build_uses() -> None:
    bag = real("logs", "leg_tracker", "positive_2_extracted.bag")
    doc = run_json("info", bag, "--format", "json")
    (example,) = [line for line in EPILOG.splitlines() if "select(.role" in line]
    (expression,) = re.findall(r"select\((.*?)\)'", example)
    picked = sorted(t["topic"] for t in doc["topics"] if _select(expression, t))
    assert picked == doc["will_use"]["detections"] == ["/leg_cluster_positions"]
    # the role is the type's: the skipped topic is still listed there, and says it is skipped
    assert "/visualization_marker_array" in doc["roles"]["detections"]
    (skipped,) = [t for t in doc["topics"] if t["topic"] == "/visualization_marker_array"]
    assert skipped["used"] is False
    assert skipped["why"].startswith("skipped:")
