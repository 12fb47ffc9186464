"""TfBuffer: chains, inverses, tf2-style interpolation, statics, extrapolation, errors."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

from aion_cli.errors import TransformError
from aion_cli.formats.tf import TfBuffer

S = 1_000_000_000


def yaw_q(deg: float) -> np.ndarray:
    return Rotation.from_euler("z", deg, degrees=True).as_quat()


def chain_buffer() -> TfBuffer:
    """map -(yaw 90°, (1,2,0))-> odom -(dynamic)-> base_link -((0,0,1))-> sensor."""
    buf = TfBuffer()
    buf.add_transforms("/map", "odom", [0], [[1, 2, 0]], [yaw_q(90)], static=True)
    buf.add_transforms(
        "odom",
        "base_link",
        [0, 10 * S],
        [[0, 0, 0], [10, 4, 0]],
        [yaw_q(0), yaw_q(90)],
    )
    buf.add_transforms("base_link", "sensor", [0], [[0, 0, 1]], [[0, 0, 0, 1]], static=True)
    return buf


def test_composed_chain_hand_computed() -> None:
    buf = TfBuffer()
    buf.add_transforms("map", "odom", [0], [[1, 2, 0]], [yaw_q(90)], static=True)
    buf.add_transforms("odom", "base_link", [0, S], [[3, 0, 0]] * 2, [yaw_q(0)] * 2)
    buf.add_transforms("base_link", "sensor", [0], [[0, 0, 1]], [[0, 0, 0, 1]], static=True)
    # sensor origin: base (0,0,1) -> odom (3,0,1) -> map Rz90(3,0,1) + (1,2,0) = (1,5,1)
    # sensor point (1,0,0) -> odom (4,0,1) -> map (0,4,1) + (1,2,0) = (1,6,1)
    out, ok = buf.transform_points("map", "sensor", [S // 2, S // 2], [[0, 0, 0], [1, 0, 0]])
    assert ok.all()
    np.testing.assert_allclose(out, [[1, 5, 1], [1, 6, 1]], atol=1e-12)
    back, ok = buf.transform_points("sensor", "map", S // 2, [[1, 6, 1]])
    assert ok.all()
    np.testing.assert_allclose(back, [[1, 0, 0]], atol=1e-12)
    R, t, ok = buf.lookup("map", "sensor", [0])
    np.testing.assert_allclose(R[0], Rotation.from_euler("z", 90, degrees=True).as_matrix())
    np.testing.assert_allclose(t[0], [1, 5, 1], atol=1e-12)


def test_random_chain_matches_scipy_composition() -> None:
    rng = np.random.default_rng(3)
    rots = Rotation.random(3, random_state=4)
    trans = rng.normal(size=(3, 3))
    buf = TfBuffer()
    names = ["a", "b", "c", "d"]
    for k in range(3):
        buf.add_transforms(names[k], names[k + 1], [0], [trans[k]], [rots[k].as_quat()], True)
    R_exp = (rots[0] * rots[1] * rots[2]).as_matrix()
    t_exp = trans[0] + rots[0].apply(trans[1] + rots[1].apply(trans[2]))
    R, t, ok = buf.lookup("a", "d", [123])
    assert ok.all()
    np.testing.assert_allclose(R[0], R_exp, atol=1e-12)
    np.testing.assert_allclose(t[0], t_exp, atol=1e-12)
    Ri, ti, _ = buf.lookup("d", "a", [123])
    np.testing.assert_allclose(Ri[0], R_exp.T, atol=1e-12)
    np.testing.assert_allclose(ti[0], -R_exp.T @ t_exp, atol=1e-12)
    Rs, ts, _ = buf.lookup("c", "c", [1, 2])  # same frame: identity
    np.testing.assert_allclose(Rs, np.broadcast_to(np.eye(3), (2, 3, 3)))
    np.testing.assert_allclose(ts, 0)


def test_interpolation_lerp_and_slerp() -> None:
    buf = chain_buffer()
    # midpoint: translation (5, 2, 0), yaw 45°
    R, t, ok = buf.lookup("odom", "base_link", [5 * S])
    assert ok.all()
    np.testing.assert_allclose(t[0], [5, 2, 0], atol=1e-12)
    np.testing.assert_allclose(R[0], Rotation.from_euler("z", 45, degrees=True).as_matrix())
    # any fraction equals scipy's Slerp and a hand lerp
    fr = np.array([0.0, 0.13, 0.37, 0.9, 1.0])
    times = np.round(fr * 10 * S).astype(np.int64)
    R, t, ok = buf.lookup("odom", "base_link", times)
    assert ok.all()
    ref = Slerp([0.0, 1.0], Rotation.from_quat([yaw_q(0), yaw_q(90)]))(fr).as_matrix()
    np.testing.assert_allclose(R, ref, atol=1e-12)
    np.testing.assert_allclose(t, fr[:, None] * np.array([10, 4, 0]), atol=1e-9)


def test_slerp_takes_shortest_arc_across_sign_flip() -> None:
    buf = TfBuffer()
    q1 = yaw_q(170)
    q2 = -yaw_q(-170)  # same rotation as yaw -170°, opposite hemisphere of the quaternion
    buf.add_transforms("a", "b", [0, 2 * S], [[0, 0, 0]] * 2, [q1, q2])
    R, _, _ = buf.lookup("a", "b", [S])
    np.testing.assert_allclose(
        R[0], Rotation.from_euler("z", 180, degrees=True).as_matrix(), atol=1e-12
    )


def test_statics_hold_at_any_time_and_dynamic_edge_limits_ok() -> None:
    buf = chain_buffer()
    _, t, ok = buf.lookup("base_link", "sensor", [-(10**15), 0, 10**15])
    assert ok.all()
    np.testing.assert_allclose(t, [[0, 0, 1]] * 3)
    _, t, ok = buf.lookup("map", "sensor", [10**15])
    assert not ok[0]
    assert np.isnan(t).all()


def test_extrapolation_flagged_with_tolerance() -> None:
    buf = chain_buffer()
    times = np.array([-S // 20, -S // 5, 10 * S + S // 20, 10 * S + S // 5, 3 * S])
    R, t, ok = buf.lookup("map", "base_link", times)
    assert ok.tolist() == [True, False, True, False, True]
    assert np.isnan(R[~ok]).all()
    assert np.isnan(t[~ok]).all()
    assert np.isfinite(t[ok]).all()
    # within tolerance: the nearest sample, not an extrapolation
    _, t_first, _ = buf.lookup("odom", "base_link", [-S // 20, 0])
    np.testing.assert_allclose(t_first[0], t_first[1])
    strict = chain_buffer()
    strict.tolerance_ns = 0
    assert not TfBuffer(tolerance_s=0.0).tolerance_ns
    _, _, ok = strict.lookup("map", "base_link", times)
    assert ok.tolist() == [False, False, False, False, True]
    pts, ok = buf.transform_points("map", "base_link", times, np.zeros((5, 3)))
    assert np.isnan(pts[~ok]).all()


def test_unknown_frame_and_missing_chain() -> None:
    buf = chain_buffer()
    with pytest.raises(TransformError, match=r"unknown frame 'camera'.*base_link.*map"):
        buf.lookup("map", "camera", [0])
    buf.add_transforms("world", "gps", [0], [[0, 0, 0]], [[0, 0, 0, 1]], static=True)
    with pytest.raises(TransformError, match=r"no transform chain between 'map' and 'gps'"):
        buf.transform_points("map", "gps", 0, [[0, 0, 0]])
    with pytest.raises(TransformError, match="unknown frame"):
        buf.trajectory("map", "robot")
    with pytest.raises(TransformError, match=">= 0"):
        TfBuffer(tolerance_s=-1)


def test_leading_slash_and_frames() -> None:
    buf = chain_buffer()
    assert buf.frames == ["base_link", "map", "odom", "sensor"]
    a = buf.lookup("/map", "/sensor", [S])[1]
    b = buf.lookup("map", "sensor", [S])[1]
    np.testing.assert_array_equal(a, b)


def test_out_of_order_and_batched_ingest_equal_in_order() -> None:
    rng = np.random.default_rng(0)
    stamps = np.arange(50, dtype=np.int64) * S // 10
    trans = rng.normal(size=(50, 3))
    quats = Rotation.random(50, random_state=1).as_quat()
    ordered = TfBuffer()
    ordered.add_transforms(["p"] * 50, ["c"] * 50, stamps, trans, quats)
    shuffled = TfBuffer()
    perm = rng.permutation(50)
    for chunk in np.array_split(perm, 7):
        shuffled.add_transforms("p", "c", stamps[chunk], trans[chunk], quats[chunk])
    q = rng.integers(0, int(stamps[-1]), size=200)
    Ra, ta, _ = ordered.lookup("p", "c", q)
    Rb, tb, _ = shuffled.lookup("p", "c", q)
    np.testing.assert_allclose(Ra, Rb)
    np.testing.assert_allclose(ta, tb)
    assert shuffled.time_range("p", "c") == (0, int(stamps[-1]))
    # at a sample stamp the sample itself comes back
    _, t_at, _ = ordered.lookup("p", "c", stamps[[3, 17]])
    np.testing.assert_allclose(t_at, trans[[3, 17]])


def test_mixed_edges_in_one_call_and_invalid_samples() -> None:
    buf = TfBuffer()
    buf.add_transforms(
        ["map", "odom", "odom", "map"],
        ["odom", "base", "base", "odom"],
        [0, 0, S, S],
        [[1, 0, 0], [0, 1, 0], [0, 3, 0], [np.nan, 0, 0]],
        [[0, 0, 0, 1], [0, 0, 0, 2], [0, 0, 0, 1], [0, 0, 0, 1]],
    )
    assert buf.invalid_samples == 1
    assert buf.time_range("map", "odom") == (0, 0)
    _, t, ok = buf.lookup("map", "base", [0, S // 2])
    assert ok[0]
    np.testing.assert_allclose(t[0], [1, 1, 0])  # non-unit quaternion normalised
    assert not ok[1]  # map->odom has one sample at 0: 0.5 s is beyond tolerance
    buf.add_transforms("a", "b", [0], [[0, 0, 0]], [[0, 0, 0, 0]])
    assert buf.invalid_samples == 2
    with pytest.raises(TransformError, match="itself"):
        buf.add_transforms("x", "/x", [0], [[0, 0, 0]], [[0, 0, 0, 1]])


def test_vectors_rotate_only() -> None:
    buf = chain_buffer()
    v, ok = buf.transform_vectors("map", "sensor", [0, 10 * S], [[1, 0, 0], [1, 0, 0]])
    assert ok.all()
    np.testing.assert_allclose(v, [[0, 1, 0], [-1, 0, 0]], atol=1e-12)  # yaw 90° then 180°


def test_trajectory_at_dynamic_sample_times() -> None:
    buf = TfBuffer()
    buf.add_transforms("map", "odom", [0], [[1, 2, 0]], [yaw_q(90)], static=True)
    buf.add_transforms(
        "odom", "base", [0, S, 2 * S], [[0, 0, 0], [1, 0, 0], [2, 0, 0]], [yaw_q(0)] * 3
    )
    traj = buf.trajectory("map", "base")
    assert traj.t_ns.tolist() == [0, S, 2 * S]
    np.testing.assert_allclose(traj.xyz, [[1, 2, 0], [1, 3, 0], [1, 4, 0]], atol=1e-12)
    traj = buf.trajectory("map", "base", [S // 2, 5 * S])
    assert traj.t_ns.tolist() == [S // 2]  # 5 s is not transformable: left out
    np.testing.assert_allclose(traj.xyz, [[1, 2.5, 0]], atol=1e-12)
    assert len(buf.trajectory("map", "odom")) == 0  # all static: no times


def _tf_msg(stamp: object, parent: str, child: str, xyz: tuple[float, ...]) -> SimpleNamespace:
    return SimpleNamespace(
        transforms=[
            SimpleNamespace(
                header=SimpleNamespace(stamp=stamp, frame_id=parent),
                child_frame_id=child,
                transform=SimpleNamespace(
                    translation=SimpleNamespace(x=xyz[0], y=xyz[1], z=xyz[2]),
                    rotation=SimpleNamespace(x=0.0, y=0.0, z=0.0, w=1.0),
                ),
            )
        ]
    )


def test_from_messages_ros1_and_ros2_stamps() -> None:
    msgs = [
        (_tf_msg(SimpleNamespace(sec=1, nanosec=0), "/map", "/odom", (1, 0, 0)), True),
        (_tf_msg(SimpleNamespace(secs=1, nsecs=0), "odom", "base", (0, 0, 0)), False),
        (_tf_msg(SimpleNamespace(secs=3, nsecs=0), "odom", "base", (4, 0, 0)), False),
        (SimpleNamespace(transforms=[]), False),
    ]
    buf = TfBuffer.from_messages(msgs)
    assert buf.time_range("odom", "base") == (S, 3 * S)
    _, t, ok = buf.lookup("map", "base", [2 * S])
    assert ok.all()
    np.testing.assert_allclose(t[0], [3, 0, 0])


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    n_edges=st.integers(1, 4),
    frac=st.lists(st.floats(0, 1), min_size=1, max_size=5),
)
def test_property_lookup_inverse_is_identity(seed: int, n_edges: int, frac: list[float]) -> None:
    rng = np.random.default_rng(seed)
    buf = TfBuffer()
    names = [f"f{k}" for k in range(n_edges + 1)]
    for k in range(n_edges):
        # random orientation of each edge in the tree (parent either side)
        p, c = (names[k], names[k + 1]) if rng.random() < 0.5 else (names[k + 1], names[k])
        quats = Rotation.random(3, random_state=int(rng.integers(0, 2**31))).as_quat()
        buf.add_transforms(p, c, [0, 5 * S, 10 * S], rng.normal(size=(3, 3)) * 5, quats)
    a, b = names[0], names[-1]
    t = (np.array(frac) * 10 * S).astype(np.int64)
    R1, t1, ok1 = buf.lookup(a, b, t)
    R2, t2, ok2 = buf.lookup(b, a, t)
    assert ok1.all()
    assert ok2.all()
    R = R1 @ R2
    tt = np.einsum("nij,nj->ni", R1, t2) + t1
    np.testing.assert_allclose(R, np.broadcast_to(np.eye(3), R.shape), atol=1e-9)
    np.testing.assert_allclose(tt, 0, atol=1e-9)
    # rotations stay orthonormal after slerp and composition
    np.testing.assert_allclose(R1 @ np.transpose(R1, (0, 2, 1)), R, atol=1e-9)


def test_single_edge_call_drops_only_invalid_rows() -> None:
    buf = TfBuffer()
    buf.add_transforms(
        "odom",
        "base",
        [0, S, 2 * S],
        [[0, 0, 0], [np.inf, 0, 0], [2, 0, 0]],
        [[0, 0, 0, 1], [0, 0, 0, 1], [0, 0, 0, 1]],
    )
    assert buf.invalid_samples == 1
    _, t, ok = buf.lookup("odom", "base", [S])
    assert ok.all()
    np.testing.assert_allclose(t[0], [1, 0, 0])  # interpolated across the dropped sample
    buf.add_transforms("a", "b", [0], [[0, 0, 0]], [[np.nan, 0, 0, 1]])
    assert "a" not in buf.frames  # an edge with no usable sample is not created


def test_add_messages_batches_many() -> None:
    msgs = [
        _tf_msg(SimpleNamespace(sec=k, nanosec=0), "odom", "base", (float(k), 0, 0))
        for k in (3, 1, 2)
    ]
    buf = TfBuffer()
    buf.add_messages(msgs)
    assert buf.time_range("odom", "base") == (S, 3 * S)
    _, t, _ = buf.lookup("odom", "base", [S + S // 4, 3 * S])
    np.testing.assert_allclose(t, [[1.25, 0, 0], [3, 0, 0]])


def test_queued_messages_are_visible_to_queries_and_bad_frames_counted() -> None:
    buf = TfBuffer()
    buf.add_message(_tf_msg(SimpleNamespace(sec=0, nanosec=0), "map", "odom", (1, 0, 0)), True)
    for k in (0, 2):
        buf.add_message(_tf_msg(SimpleNamespace(sec=k, nanosec=0), "odom", "base", (k, 0, 0)))
    buf.add_message(_tf_msg(SimpleNamespace(sec=1, nanosec=0), "/base", "base", (0, 0, 0)))
    buf.add_message(_tf_msg(SimpleNamespace(sec=1, nanosec=0), "", "x", (0, 0, 0)))
    assert buf.frames == ["base", "map", "odom"]
    assert buf.invalid_samples == 2
    _, t, ok = buf.lookup("map", "base", [S])
    assert ok.all()
    np.testing.assert_allclose(t[0], [2, 0, 0])
    # a queued static followed by a direct one: arrival order kept, the last one wins
    buf.add_message(_tf_msg(SimpleNamespace(sec=0, nanosec=0), "map", "odom", (5, 0, 0)), True)
    buf.add_transforms("map", "odom", [0], [[7, 0, 0]], [[0, 0, 0, 1]], static=True)
    np.testing.assert_allclose(buf.lookup("map", "odom", [0])[1][0], [7, 0, 0])


def test_connected_frames_are_the_tree_around_a_frame() -> None:
    """``TfBuffer.connected``: map joins odom and base_link (one static, one dynamic edge),
    not the laser of a second tree; an unknown frame is alone."""
    buf = TfBuffer()
    ident = ((0.0, 0.0, 0.0),), ((0.0, 0.0, 0.0, 1.0),)
    buf.add_transforms("map", "odom", [0], *ident, static=True)
    buf.add_transforms("/odom", "base_link", [5], *ident)
    buf.add_transforms("cart", "laser", [5], *ident)
    assert buf.connected("map") == {"map", "odom", "base_link"}
    assert buf.connected("/laser") == {"laser", "cart"}
    assert buf.connected("nowhere") == {"nowhere"}
    with pytest.raises(TransformError, match="no transform chain"):
        buf.lookup("map", "laser", [5])


def test_no_interpolation_across_a_long_gap() -> None:
    """An edge silent for an hour (localisation lost) is not made up across the gap: only
    within the tolerance of a sample, or across gaps up to max_gap_s (10 s), is it ok."""
    s = 1_000_000_000
    stamps = np.array([0, 1, 2, 3602, 3603], np.int64) * s
    xs = np.array([0.0, 1.0, 2.0, 50.0, 51.0])
    buf = TfBuffer()
    trans = np.column_stack([xs, np.zeros(5), np.zeros(5)])
    buf.add_transforms("map", "odom", stamps, trans, np.tile([0.0, 0.0, 0.0, 1.0], (5, 1)))
    t = np.array([1.5 * s, 2 * s + s // 20, 1800 * s, 3602 * s - s // 20, 3602 * s])
    _, tr, ok = buf.lookup("map", "odom", t)
    assert ok.tolist() == [True, True, False, True, True]
    assert tr[0, 0] == pytest.approx(1.5)
    assert np.isnan(tr[2]).all()
    # a gap within the limit is interpolated; max_gap_s=inf interpolates across any
    wide = TfBuffer(max_gap_s=float("inf"))
    wide.add_transforms("map", "odom", stamps, trans, np.tile([0.0, 0.0, 0.0, 1.0], (5, 1)))
    _, tr_w, ok_w = wide.lookup("map", "odom", t[2:3])
    assert ok_w.all()
    assert tr_w[0, 0] == pytest.approx(2.0 + 48.0 * 1798 / 3600)
    with pytest.raises(TransformError):
        TfBuffer(max_gap_s=0)


@pytest.mark.parametrize("first", [16, 5])
def test_a_late_sample_after_a_full_buffer_is_sorted_in(first: int) -> None:
    """Samples at 1..first s (x = t), then one at 4.5 s (x = 100): a lookup at 4.5 s is that
    sample, between its neighbours the line to it — also when the late sample arrives just as
    the edge's first buffer (16 samples) is full and grows."""
    buf = TfBuffer()
    t = np.arange(1, first + 1) * S
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (first, 1))
    buf.add_transforms("odom", "base", t, np.c_[t / S, np.zeros((first, 2))], quat)
    buf.add_transforms("odom", "base", [4 * S + S // 2], [[100.0, 0, 0]], [[0, 0, 0, 1.0]])
    _, tr, ok = buf.lookup("odom", "base", [4 * S + S // 2, 4 * S + S // 4, 5 * S])
    assert ok.all()
    np.testing.assert_allclose(tr[:, 0], [100.0, 52.0, 5.0])


def test_the_tolerance_and_the_gap_limit_are_inclusive() -> None:
    """Samples at 10 s and 30 s, tolerance 0.5 s, gaps up to 20 s interpolated: lookups at
    9.5 s and 30.5 s (exactly the tolerance outside) hold the end samples, 1 ns farther they
    fail; the 20 s gap itself (exactly max_gap_s) is interpolated, a longer one only within
    the tolerance of its samples, and there it is that sample (as at the ends of the range),
    not a step along the gap."""
    buf = TfBuffer(0.5, max_gap_s=20.0)
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (2, 1))
    buf.add_transforms("odom", "base", [10 * S, 30 * S], [[1.0, 0, 0], [3.0, 0, 0]], quat)
    times = [9 * S + S // 2, 30 * S + S // 2, 9 * S + S // 2 - 1, 30 * S + S // 2 + 1, 20 * S]
    _, tr, ok = buf.lookup("odom", "base", times)
    np.testing.assert_array_equal(ok, [True, True, False, False, True])
    np.testing.assert_allclose(tr[ok, 0], [1.0, 3.0, 2.0])
    # a 30 s gap (longer than 20 s): only within the tolerance of its two samples, held
    buf.add_transforms("odom", "base", [60 * S], [[6.0, 0, 0]], quat[:1])
    inside = [30 * S + S // 2, 59 * S + S // 2, 30 * S + S // 2 + 1, 45 * S]
    _, tr, ok = buf.lookup("odom", "base", inside)
    np.testing.assert_array_equal(ok, [True, True, False, False])
    np.testing.assert_allclose(tr[ok, 0], [3.0, 6.0])


def test_a_static_transform_that_changed_holds_from_its_stamp_on() -> None:
    """base_link -> laser at (1, 0, 0) from t = 10 s, remounted at (0, 2, 0) from t = 20 s;
    re-sent unchanged at 30 s. A time before 10 s takes the first mount."""
    buf = TfBuffer()
    ident = [[0, 0, 0, 1]]
    buf.add_transforms("base_link", "laser", [10 * S], [[1, 0, 0]], ident, static=True)
    buf.add_transforms("base_link", "laser", [20 * S], [[0, 2, 0]], ident, static=True)
    buf.add_transforms("base_link", "laser", [30 * S], [[0, 2, 0]], ident, static=True)
    times = [0, 15 * S, 20 * S - 1, 20 * S, 25 * S, 40 * S]
    _, t, ok = buf.lookup("base_link", "laser", times)
    assert ok.all()
    np.testing.assert_array_equal(t[:, :2], [[1, 0], [1, 0], [1, 0], [0, 2], [0, 2], [0, 2]])
    _, t, _ = buf.lookup("laser", "base_link", [15 * S, 25 * S])  # inverted: per time too
    np.testing.assert_array_equal(t[:, :2], [[-1, 0], [0, -2]])
    assert [s for _, _, s, _, _ in buf.static_transforms()] == [10 * S, 20 * S]  # changes
