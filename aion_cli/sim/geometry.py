"""Planar geometry for the simulator: wall occlusion and SE(2) transforms as arrays.

Walls are 2D segments ``float64[w, 4]`` (x0, y0, x1, y1). SE(2) transforms are ``float64[..., 3]``
rows (x, y, yaw) meaning "rotate by yaw, then translate by (x, y)"; they act on the x/y of 3D
points and leave z alone, which is all a wheeled robot's odometry drift does.
"""

from __future__ import annotations

import numpy as np

from aion_cli.engine.types import F64, BoolA

_CHUNK = 65536


def _cross(ax: F64, ay: F64, bx: F64, by: F64) -> F64:
    return ax * by - ay * bx


def segments_blocked(p: F64, q: F64, walls: F64) -> BoolA:
    """True where the segment p[i]→q[i] properly crosses any wall (touching does not count).

    A strict crossing test keeps doorways open: a segment that only touches a wall's end point
    (a door jamb) or runs through a gap is not blocked. Vectorised over segments × walls, in
    chunks so memory stays bounded for long walks.
    """
    n = len(p)
    out = np.zeros(n, dtype=bool)
    if n == 0 or len(walls) == 0:
        return out
    ax, ay, bx, by = (walls[:, i][None, :] for i in range(4))
    wx, wy = bx - ax, by - ay
    for s in range(0, n, _CHUNK):
        px, py = p[s : s + _CHUNK, 0:1], p[s : s + _CHUNK, 1:2]
        qx, qy = q[s : s + _CHUNK, 0:1], q[s : s + _CHUNK, 1:2]
        dx, dy = qx - px, qy - py
        d1 = _cross(wx, wy, px - ax, py - ay)
        d2 = _cross(wx, wy, qx - ax, qy - ay)
        d3 = _cross(dx, dy, ax - px, ay - py)
        d4 = _cross(dx, dy, bx - px, by - py)
        crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
        out[s : s + _CHUNK] = crossing.any(axis=1)
    return out


def point_segment_distance(points: F64, walls: F64) -> F64:
    """Distance from every 2D point to its nearest wall segment (inf without walls)."""
    if len(walls) == 0:
        return np.full(len(points), np.inf)
    a = walls[None, :, 0:2]
    b = walls[None, :, 2:4]
    p = points[:, None, 0:2]
    ab = b - a
    denom = np.maximum((ab * ab).sum(-1), 1e-12)
    u = np.clip(((p - a) * ab).sum(-1) / denom, 0.0, 1.0)
    closest = a + u[..., None] * ab
    return np.asarray(np.linalg.norm(p - closest, axis=-1).min(axis=1), dtype=np.float64)


def se2_compose(a: F64, b: F64) -> F64:
    """a ∘ b for broadcastable rows (x, y, yaw): apply b first, then a."""
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, a[..., 2] + b[..., 2]], axis=-1)


def se2_inverse(a: F64) -> F64:
    """The inverse transform of each row."""
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = -(c * a[..., 0] + s * a[..., 1])
    y = -(-s * a[..., 0] + c * a[..., 1])
    return np.stack([x, y, -a[..., 2]], axis=-1)


def se2_apply(a: F64, xyz: F64) -> F64:
    """Apply transforms a[i] to points xyz[i] (x/y rotated and shifted, z kept)."""
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    out = np.array(xyz, dtype=np.float64, copy=True)
    out[..., 0] = a[..., 0] + c * xyz[..., 0] - s * xyz[..., 1]
    out[..., 1] = a[..., 1] + s * xyz[..., 0] + c * xyz[..., 1]
    return out


def rotate_xy(yaw: F64, vec: F64) -> F64:
    """Rotate the x/y of vectors by yaw (velocities: no translation)."""
    c, s = np.cos(yaw), np.sin(yaw)
    out = np.array(vec, dtype=np.float64, copy=True)
    out[..., 0] = c * vec[..., 0] - s * vec[..., 1]
    out[..., 1] = s * vec[..., 0] + c * vec[..., 1]
    return out


def yaw_quaternion(yaw: F64) -> F64:
    """Quaternions (x, y, z, w) of rotations about z."""
    h = 0.5 * np.asarray(yaw, dtype=np.float64)
    z = np.zeros_like(h)
    return np.stack([z, z, np.sin(h), np.cos(h)], axis=-1)
