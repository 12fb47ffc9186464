"""Unit-quaternion math for transform chains: rotation matrices and tf2's interpolation.

Quaternions are float64[n, 4] in ROS order (x, y, z, w), processed row by row in one numpy
pass (:class:`~aion_cli.formats.tf.TfBuffer` composes chains over thousands of query times
at once).
"""

from __future__ import annotations

import numpy as np

from aion_cli.engine.types import F64

_DOT_NLERP = 0.9995  # above this cosine, slerp's sin(θ) is ill-conditioned: normalised lerp


#: Each rotation-matrix entry of a unit quaternion (x, y, z, w) as a quadratic form: "+xy" is
#: +q_x q_y. Diagonals use x² + y² + z² + w² = 1, so no constant terms are needed.
_R_TERMS = (
    "+xx -yy -zz +ww", "+xy -zw +yx -wz", "+xz +yw +zx +wy",
    "+xy +zw +yx +wz", "-xx +yy -zz +ww", "+yz -xw +zy -wx",
    "+xz -yw +zx -wy", "+yz +xw +zy +wx", "-xx -yy +zz +ww",
)  # fmt: skip


def _quadratic_form() -> F64:
    """(16, 9) matrix T with ``R.ravel() = outer(q, q).ravel() @ T`` for a unit quaternion."""
    axis = {"x": 0, "y": 1, "z": 2, "w": 3}
    T = np.zeros((16, 9))
    for k, entry in enumerate(_R_TERMS):
        for term in entry.split():
            T[4 * axis[term[1]] + axis[term[2]], k] += 1.0 if term[0] == "+" else -1.0
    return T


_QT = _quadratic_form()


def quat_to_matrix(q: F64) -> F64:
    """Rotation matrices float64[n,3,3] of unit quaternions float64[n,4] (x, y, z, w)."""
    outer = (q[:, :, None] * q[:, None, :]).reshape(-1, 16)
    return (outer @ _QT).reshape(-1, 3, 3)


def slerp(q0: F64, q1: F64, alpha: F64) -> F64:
    """Shortest-arc spherical interpolation of unit quaternions, row by row (tf2 semantics)."""
    dot = np.einsum("ij,ij->i", q0, q1)
    q1 = np.where((dot < 0)[:, None], -q1, q1)
    dot = np.abs(dot)
    theta = np.arccos(np.minimum(dot, 1.0))
    sin_t = np.sin(theta)
    near = dot > _DOT_NLERP
    safe = np.where(near, 1.0, sin_t)
    w0 = np.where(near, 1 - alpha, np.sin((1 - alpha) * theta) / safe)
    w1 = np.where(near, alpha, np.sin(alpha * theta) / safe)
    out = w0[:, None] * q0 + w1[:, None] * q1
    return out / np.sqrt(np.einsum("ij,ij->i", out, out))[:, None]


#: A heading turned this close to vertical (the horizontal length of its unit direction) has no
#: walking direction left in the target frame's xy plane.
_VERTICAL = 1e-6


def rotated_yaw(R: F64, yaw: F64) -> F64:
    """Headings ``yaw`` (rad, about the source frame's z) in the frame that rotations ``R``
    (float64[n,3,3], ``target_R_source``) turn them into: the direction (cos, sin, 0) rotated
    and projected onto the target's xy plane, as a velocity is. Where ``R`` turns about z only
    its yaw is added, as before; a tilted or upside-down source (roll, pitch) foreshortens or
    mirrors the heading. NaN where the direction ends up vertical (or ``R`` / ``yaw`` is NaN)."""
    c, s = np.cos(yaw), np.sin(yaw)
    dx = R[:, 0, 0] * c + R[:, 0, 1] * s
    dy = R[:, 1, 0] * c + R[:, 1, 1] * s
    level = (R[:, 2, 0] == 0) & (R[:, 2, 1] == 0) & (R[:, 2, 2] > 0)
    turned = np.where(np.hypot(dx, dy) >= _VERTICAL, np.arctan2(dy, dx), np.nan)
    return np.where(level, yaw + np.arctan2(R[:, 1, 0], R[:, 0, 0]), turned)
