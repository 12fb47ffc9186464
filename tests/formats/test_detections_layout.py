"""The log's own definitions decide the decoder: ``msg_layouts.same_layout`` (normalised
definitions), the detection adapters (numpy fast path only for the layout it was written for)
and the TF fast path. Forks whose bytes the fast decoders would misread without an error are
decoded right through the log's definition."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aion_cli.formats import msg_layouts, msgdefs
from aion_cli.formats.detections import hash_id
from aion_cli.formats.detections.registry import fast_layout_matches, log_adapter
from aion_cli.formats.raw import RawMessage
from aion_cli.formats.tf_fast import layout_matches
from tests.cli.own_definitions import FOXY_VISION_MSGS, OwnTypes, foxy_detection3d_array

POSE_ARRAY = "geometry_msgs/msg/PoseArray"
TF = "tf2_msgs/msg/TFMessage"


@pytest.mark.parametrize("ros", [1, 2])
@pytest.mark.parametrize("msgtype", [POSE_ARRAY, TF, "vision_msgs/msg/Detection3DArray",
                                     "spencer_tracking_msgs/msg/TrackedPersons"])
def test_shipped_definition_text_matches_itself(ros: int, msgtype: str) -> None:
    text = msgdefs.definition(msgtype, ros)
    assert msg_layouts.same_layout(text, msgtype, ros)


def test_comments_whitespace_constants_and_separators_do_not_matter() -> None:
    text = (
        "# An array of poses with a header for global reference.\n\n"
        "Header header   # stamp and frame\n\n"
        "Pose[] poses\n"
        "int32 SOME_CONSTANT = 7\n"
        "=====\n"  # ROS tools accept any run of "="
        "MSG: geometry_msgs/Pose\n"
        "# A representation of pose in free space\n"
        "Point  position\n"
        "Quaternion orientation\n"
    )  # sub-messages left out (Point, Quaternion, Header) come from the base store
    assert msg_layouts.same_layout(text, POSE_ARRAY, 1)
    assert msg_layouts.same_layout(text, POSE_ARRAY, 2)


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("std_msgs/Header header\ngeometry_msgs/Pose[] poses\nstring source\n", "extra field"),
        ("std_msgs/Header header\ngeometry_msgs/Pose[4] poses\n", "fixed array"),
        ("std_msgs/Header header\ngeometry_msgs/Pose[] people\n", "field renamed"),
        (
            "std_msgs/Header header\nmy_geometry/Pose[] poses\n"
            "===\nMSG: my_geometry/Pose\n"
            "geometry_msgs/Quaternion orientation\ngeometry_msgs/Point position\n",
            "sub-message fields reordered",
        ),
        (
            "std_msgs/Header header\nmy_geometry/Pose[] poses\n"
            "===\nMSG: my_geometry/Pose\nfloat32 x\nfloat32 y\n",
            "sub-message of another layout",
        ),
        ("std_msgs/Header header\nmy_geometry/Pose[] poses\n", "sub-message undefined"),
        ("std_msgs/Header header\ngeometry_msgs/Pose[ poses\n", "unparsable"),
    ],
)
def test_a_different_layout_does_not_match(text: str, why: str) -> None:
    assert not msg_layouts.same_layout(text, POSE_ARRAY, 2), why


def test_no_definition_counts_as_the_shipped_layout() -> None:
    assert msg_layouts.same_layout("", POSE_ARRAY, 2)
    assert msg_layouts.same_layout("  \n", POSE_ARRAY, 1)
    assert fast_layout_matches(POSE_ARRAY, "cdr", "")


def test_tf_layouts() -> None:
    ros1_text = msgdefs.definition(TF, 1)
    assert layout_matches("tf/msg/tfMessage", "ros1", ros1_text)  # the old tf, same layout
    assert layout_matches(TF, "cdr", msgdefs.definition(TF, 2))
    assert layout_matches(TF, "cdr", "")
    assert not layout_matches("geometry_msgs/msg/PoseArray", "cdr", "")
    swapped = _swapped_tf_types()
    assert not layout_matches(TF, "cdr", swapped.definition(TF))


def test_foxy_detection3d_keeps_off_the_fast_path_and_decodes_with_its_definition() -> None:
    own = OwnTypes(FOXY_VISION_MSGS)
    name = "vision_msgs/msg/Detection3DArray"
    text = own.definition(name)
    assert not fast_layout_matches(name, "cdr", text)
    adapter = log_adapter(name, "cdr", text, False, own.store)
    assert adapter is not None
    assert adapter.fast is None
    assert adapter.layout_differs
    assert adapter.kind == "generic"
    msg = foxy_detection3d_array(own, 5_000_000_000, "cam", [("person", "a", 1.0, 2.0),
                                                             ("car", "b", 3.0, 4.0)])
    got = adapter.decode([RawMessage("/d", name, 0, own.cdr(msg, name), "cdr")])
    np.testing.assert_array_equal(got.xyz, [[1.0, 2.0, 0.0]])  # the car is filtered out
    np.testing.assert_array_equal(got.track_id, [hash_id("a")])
    assert got.filtered == {"class": 1}
    assert got.frame_names() == ["cam"]


def test_shipped_layout_keeps_the_fast_path() -> None:
    adapter = log_adapter(POSE_ARRAY, "ros1", msgdefs.definition(POSE_ARRAY, 1), False, None)
    assert adapter is not None
    assert adapter.kind == "fast"
    assert not adapter.layout_differs


def _swapped_pose_types() -> OwnTypes:
    """A PoseArray fork whose pose holds the orientation first: same byte size as the
    shipped layout, so numpy over the bytes would read it without any error."""
    return OwnTypes(
        {
            "my_geometry/msg/Pose": "geometry_msgs/Quaternion orientation\n"
            "geometry_msgs/Point position\n",
            POSE_ARRAY: "std_msgs/Header header\nmy_geometry/Pose[] poses\n",
        }
    )


def _swapped_tf_types() -> OwnTypes:
    """A TFMessage fork whose transform holds the rotation first (same byte size)."""
    return OwnTypes(
        {
            "my_geometry/msg/Transform": "geometry_msgs/Quaternion rotation\n"
            "geometry_msgs/Vector3 translation\n",
            "my_geometry/msg/TransformStamped": "std_msgs/Header header\n"
            "string child_frame_id\nmy_geometry/Transform transform\n",
            TF: "my_geometry/TransformStamped[] transforms\n",
        }
    )


def test_a_pose_array_fork_is_read_by_field_name_not_by_offset() -> None:
    own = _swapped_pose_types()
    T = own.T
    q = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))
    pose = T["my_geometry/msg/Pose"](
        orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
        position=T["geometry_msgs/msg/Point"](x=1.0, y=2.0, z=3.0),
    )
    msg = T[POSE_ARRAY](header=own.header(7_000_000_000, "map"), poses=[pose])
    raw = RawMessage("/people/poses", POSE_ARRAY, 0, own.cdr(msg, POSE_ARRAY), "cdr")
    text = own.definition(POSE_ARRAY)
    adapter = log_adapter(POSE_ARRAY, "cdr", text, False, own.store)
    assert adapter is not None
    assert adapter.fast is None
    got = adapter.decode([raw])
    np.testing.assert_array_equal(got.xyz, [[1.0, 2.0, 3.0]])
    assert got.yaw[0] == pytest.approx(math.pi / 2)
    # the fast decoder alone reads the quaternion as the position, without complaint:
    # that is what the layout check prevents
    shipped = log_adapter(POSE_ARRAY, "cdr", "", False, None)
    assert shipped is not None
    assert shipped.fast is not None
    wrong = shipped.decode([raw])
    assert not np.allclose(wrong.xyz, [[1.0, 2.0, 3.0]])
