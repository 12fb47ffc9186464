"""Marker ids: track ids or a count of the markers? A namespace's ids over a sample of the
topic decide it (``markers.ids_verdict``), where a message alone cannot: one marker of id 0
is a count of one (leg_tracker's ``m.id = i``) or a person whose track id is 0."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from aion_cli.formats.detections import adapter_for, hash_id
from aion_cli.formats.detections.markers import ids_verdict, learn_ids
from aion_cli.formats.raw import RawMessage
from tests.formats.ros_messages import raw

ARRAY = "visualization_msgs/msg/MarkerArray"
ROS = pytest.mark.parametrize("ros", [1, 2])


@pytest.mark.parametrize(
    ("groups", "verdict"),
    [
        ([[0], [0], [1, 0], [0]], "counts"),  # positive_1_extracted.bag's first messages
        ([[0], [0, 1], [1]], "names"),  # person 0 left, person 1 stayed
        ([[0, 2]], "names"),
        ([[0]] * 5, "one"),  # one person, id 0, throughout
        ([[0]], None),  # one message cannot tell
        ([[0, 1, 2], [0, 1]], "counts"),
    ],
)
def test_ids_verdict(groups: list[list[int]], verdict: str | None) -> None:
    assert ids_verdict(groups) == verdict


def _array(ids: list[int], ns: str = "people") -> dict[str, Any]:
    return {"markers": [
        {"header": {"stamp": {"sec": 4}, "frame_id": "map"}, "ns": ns, "id": i, "type": 2,
         "pose": {"position": {"x": float(i), "y": float(k)}}}
        for k, i in enumerate(ids)
    ]}  # fmt: skip


def _decode(ids_per_message: list[list[int]], ros: int, learn: bool = True) -> np.ndarray:
    """Track ids of MarkerArrays of ``ids_per_message``, with the rule learnt from them
    (as a build learns it from the topic's first messages) or not."""
    messages = [raw(ARRAY, _array(ids), ros, log_time_ns=10 + k)
                for k, ids in enumerate(ids_per_message)]  # fmt: skip
    adapter = adapter_for(ARRAY)
    assert adapter is not None
    if learn:
        learn_ids(adapter, messages, messages[0].encoding)
    return np.asarray(adapter.decode(messages).track_id)


P0, P1 = hash_id("people/0"), hash_id("people/1")


@ROS
def test_a_single_person_with_id_0_keeps_it(ros: int) -> None:
    """One person whose track id is 0, message after message: id 0 alone read message by
    message was a count (no track id); the sample shows only that id, a person's. A later
    message with ids 0, 1 is still read as a count."""
    np.testing.assert_array_equal(_decode([[0]] * 4, ros, learn=False), [-1] * 4)
    np.testing.assert_array_equal(_decode([[0]] * 4, ros), [P0] * 4)
    np.testing.assert_array_equal(_decode([[0]] * 4 + [[0, 1]], ros)[4:], [-1, -1])


@ROS
def test_a_count_stays_a_count_in_messages_of_one_marker(ros: int) -> None:
    """leg_tracker's clusters numbered 0..k-1 per message (positive_1_extracted.bag starts
    with five messages of one leg): every message is a count, id 0 alone too."""
    np.testing.assert_array_equal(_decode([[0], [0], [0, 1], [0]], ros), [-1] * 5)


@ROS
def test_ids_that_name_people_somewhere_name_them_everywhere(ros: int) -> None:
    """Person 0, then 0 and 1, then 1 alone: the gap shows the ids are people's, so the
    message with 0 and 1 keeps them too (message by message it read them as a count)."""
    ids = [[0], [0, 1], [1]]
    np.testing.assert_array_equal(_decode(ids, ros, learn=False), [-1, -1, -1, P1])
    np.testing.assert_array_equal(_decode(ids, ros), [P0, P0, P1, P1])


def test_learning_leaves_out_other_encodings_and_damaged_messages() -> None:
    """The sample is the topic's messages in the adapter's encoding that decode: a damaged
    one and one in the other ROS version are left out (here they would have shown a gap)."""
    good = [raw(ARRAY, _array([0]), 2, log_time_ns=k) for k in range(3)]
    gap = raw(ARRAY, _array([3]), 1)  # ROS 1
    bad = raw(ARRAY, _array([5]), 2)
    bad = RawMessage(bad.topic, bad.msgtype, bad.log_time_ns, bad.data[:12], bad.encoding)
    adapter = adapter_for(ARRAY)
    assert adapter is not None
    learn_ids(adapter, [good[0], gap, bad, *good[1:]], "cdr")
    assert adapter.extract.verdicts == {"people": "one"}  # type: ignore[attr-defined]
    assert "the ids of 'people' are only 0" in adapter.extract.describe()  # type: ignore[attr-defined]
