"""Hypothesis strategies for the four detection message types the numpy fast decoders read
(PoseArray, spencer TrackedPersons, people_msgs People, vision_msgs Detection3DArray), as the
message dicts :func:`tests.formats.ros_messages.raw` serializes: random counts, floats, frame_id
lengths that shift the CDR alignment and random strings."""

from __future__ import annotations

from typing import Any

import numpy as np
from hypothesis import strategies as st

from tests.formats.ros_messages import header, pose

floats = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False, width=64)
unit = st.floats(min_value=-1.0, max_value=1.0, allow_nan=False)
frames = st.text(alphabet="abcdefghijklmnopqrstuvwxyz_/0123456789", max_size=17)
texts = st.text(
    alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
    max_size=12,
)
stamps = st.one_of(
    st.just((0, 0)),
    st.tuples(st.integers(0, 2**31 - 1), st.integers(0, 999_999_999)),
)


@st.composite
def headers(draw: st.DrawFn) -> dict[str, Any]:
    """A header with a random stamp (or zero) and frame_id."""
    sec, nsec = draw(stamps)
    return header(sec, nsec, draw(frames))


@st.composite
def poses(draw: st.DrawFn) -> dict[str, Any]:
    """A pose with random coordinates and a random (not normalised) quaternion."""
    return pose(draw(floats), draw(floats), draw(floats), tuple(draw(unit) for _ in range(4)))


# --- PoseArray ----------------------------------------------------------------------------------

POSE_ARRAY = "geometry_msgs/msg/PoseArray"


# --- spencer TrackedPersons ---------------------------------------------------------------------

TRACKED = "spencer_tracking_msgs/msg/TrackedPersons"
variances = st.sampled_from([0.0, 0.5, 99999.0, 1e6])


@st.composite
def tracked(draw: st.DrawFn) -> dict[str, Any]:
    """A TrackedPerson whose covariances are sometimes above the 99999 "unknown" mark."""
    pcov = np.zeros(36)
    pcov[35] = draw(variances)
    tcov = np.zeros(36)
    for k in (0, 7, 14):
        tcov[k] = draw(variances)
    return {
        "track_id": draw(st.integers(0, 2**64 - 1)),
        "is_occluded": draw(st.booleans()),
        "is_matched": draw(st.booleans()),
        "detection_id": draw(st.integers(0, 2**64 - 1)),
        "age": {"sec": draw(st.integers(0, 1000)), "nanosec": draw(st.integers(0, 10**9 - 1))},
        "pose": {"pose": draw(poses()), "covariance": pcov},
        "twist": {
            "twist": {
                "linear": {"x": draw(floats), "y": draw(floats), "z": draw(floats)},
                "angular": {"x": draw(floats), "y": 0.0, "z": draw(floats)},
            },
            "covariance": tcov,
        },
    }


# --- people_msgs/People -------------------------------------------------------------------------

PEOPLE = "people_msgs/msg/People"


@st.composite
def persons(draw: st.DrawFn) -> dict[str, Any]:
    """A people_msgs Person with random name, position, velocity and tags."""
    ntags = draw(st.integers(0, 3))
    return {
        "name": draw(texts),
        "position": {"x": draw(floats), "y": draw(floats), "z": draw(floats)},
        "velocity": {"x": draw(floats), "y": draw(floats), "z": draw(floats)},
        "reliability": draw(floats),
        "tagnames": draw(st.lists(texts, min_size=ntags, max_size=ntags)),
        "tags": draw(st.lists(texts, max_size=3)),
    }


# --- vision_msgs/Detection3DArray ---------------------------------------------------------------

DET3D = "vision_msgs/msg/Detection3DArray"


@st.composite
def detections(draw: st.DrawFn, ros: int) -> dict[str, Any]:
    """A Detection3D of ROS ``ros``'s vision_msgs (ROS 1: results with integer ids and a
    source cloud; ROS 2: class hypotheses, some of them "person", and a string id)."""
    cov = np.arange(36.0) * draw(floats)
    results = []
    for _ in range(draw(st.integers(0, 3))):
        if ros == 1:
            hyp: dict[str, Any] = {"id": draw(st.integers(-(2**63), 2**63 - 1))}
        else:
            cls = draw(st.one_of(st.sampled_from(["person", "car", "persons", ""]), texts))
            hyp = {"hypothesis": {"class_id": cls, "score": draw(floats)}}
        results.append({**hyp, "pose": {"pose": draw(poses()), "covariance": cov}})
    det: dict[str, Any] = {
        "header": draw(headers()),
        "results": results,
        "bbox": {"center": draw(poses()), "size": {"x": draw(floats), "y": 1.0, "z": 2.0}},
    }
    if ros == 1:
        nfields = draw(st.integers(0, 3))
        det["source_cloud"] = {
            "header": draw(headers()),
            "height": 1,
            "width": draw(st.integers(0, 9)),
            "fields": [
                {"name": draw(frames), "offset": k * 4, "datatype": 7, "count": 1}
                for k in range(nfields)
            ],
            "point_step": 12,
            "row_step": 12,
            "data": bytes(draw(st.binary(max_size=40))),
            "is_dense": draw(st.booleans()),
        }
    else:
        det["id"] = draw(st.one_of(st.just(""), texts))
    return det
