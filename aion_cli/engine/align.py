"""The rigid transform that puts one recording's occupancy onto another's.

Two recordings of one place in different frames hold the same walkways at other coordinates.
:func:`align_occupancy` finds the rotation, translation and (optionally) mirror that best lays
the moving points' 2D occupancy onto the fixed points': a sweep over rotations (and the
mirrored copy), each rotation's best translation from the FFT cross-correlation of the two
occupancy histograms, then a local refinement on the fixed occupancy smoothed, in log density.
Overlaps are histogram intersections Σ min(p, q) of 0.5 m occupancies (1: the same picture).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aion_cli.engine.types import F64


@dataclass(frozen=True)
class RigidAlignment:
    """``x' = R(angle) · M · x + shift``, M the mirror ``y → −y`` when ``mirror``."""

    angle: float
    """Radians, counter-clockwise, in [0, 2π)."""
    shift: tuple[float, float]
    mirror: bool
    overlap_before: float
    overlap_after: float

    def apply(self, xy: F64) -> F64:
        """The points (x and y the first two columns; others kept) in the fixed frame."""
        out = np.array(xy, dtype=np.float64, copy=True)
        out[:, :2] = _turn(out[:, :2], self.angle, self.mirror) + np.array(self.shift)
        return out

    def apply_heading(self, heading: F64) -> F64:
        """Headings (radians; NaN kept) turned as the points are, wrapped to [−π, π)."""
        h = -heading if self.mirror else heading
        return np.asarray(np.mod(h + self.angle + np.pi, 2 * np.pi) - np.pi, dtype=np.float64)


def _turn(xy: F64, angle: float, mirror: bool) -> F64:
    y = -xy[:, 1] if mirror else xy[:, 1]
    c, s = np.cos(angle), np.sin(angle)
    return np.asarray(np.c_[c * xy[:, 0] - s * y, s * xy[:, 0] + c * y], dtype=np.float64)


def _histogram(xy: F64, lo: F64, cell: float, n: tuple[int, int]) -> F64:
    i = np.floor((xy - lo) / cell).astype(np.int64)
    ok = (i >= 0).all(axis=1) & (i[:, 0] < n[0]) & (i[:, 1] < n[1])
    h = np.zeros(n)
    np.add.at(h, (i[ok, 0], i[ok, 1]), 1.0)
    return h


def occupancy_overlap(a: F64, b: F64, cell: float = 0.5) -> float:
    """Histogram intersection Σ min(p_a, p_b) of two point sets' occupancies on square cells
    of ``cell`` metres anchored at 0: 1 for the same distribution, 0 for disjoint places."""
    if len(a) == 0 or len(b) == 0:
        return 0.0
    keys = [np.floor(np.asarray(p)[:, :2] / cell).astype(np.int64) for p in (a, b)]
    both = np.concatenate(keys)
    _, inverse = np.unique(both, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    pa = np.bincount(inverse[: len(a)], minlength=int(inverse.max()) + 1) / len(a)
    pb = np.bincount(inverse[len(a):], minlength=int(inverse.max()) + 1) / len(b)
    return float(np.minimum(pa, pb).sum())


def align_occupancy(
    moving: F64, fixed: F64, *, cell: float = 0.5, angle_step_deg: float = 2.0,
    mirror: bool = True,
) -> RigidAlignment:
    """The rigid transform (and mirror, if ``mirror``) laying ``moving``'s occupancy onto
    ``fixed``'s (module docstring). Points are N × 2 or more (x and y first)."""
    from scipy.fft import irfft2, rfft2
    from scipy.ndimage import gaussian_filter, map_coordinates
    from scipy.optimize import minimize

    mov = np.asarray(moving, dtype=np.float64)[:, :2]
    fix = np.asarray(fixed, dtype=np.float64)[:, :2]
    lo_f, hi_f = np.percentile(fix, 0.5, axis=0), np.percentile(fix, 99.5, axis=0)
    reach = float(np.percentile(np.hypot(*(mov - np.median(mov, axis=0)).T), 99.5))
    half = max(float(np.max(hi_f - lo_f)), 2 * reach) + 4.0  # room for any turn, no wrap
    lo = (lo_f + hi_f) / 2 - half
    n = (int(2 * half / cell) + 1,) * 2
    target = _histogram(fix, lo, cell, n)
    spectrum = rfft2(np.log1p(gaussian_filter(target, 1.0) * 100.0 / len(fix)))
    centre = np.median(fix, axis=0)
    best: tuple[float, float, bool, F64] = (-np.inf, 0.0, False, np.zeros(2))
    for flip in (False, True) if mirror else (False,):
        for angle in np.deg2rad(np.arange(0.0, 360.0, angle_step_deg)):
            turned = _turn(mov, float(angle), flip)
            base = centre - np.median(turned, axis=0)
            corr = irfft2(spectrum * np.conj(rfft2(_histogram(turned + base, lo, cell, n))), s=n)
            k = np.array(np.unravel_index(int(np.argmax(corr)), n))
            if corr.flat[np.argmax(corr)] > best[0]:
                k = np.where(k > np.array(n) // 2, k - np.array(n), k)  # circular lag
                best = (float(corr.max()), float(angle), flip, base + k * cell)
    _, angle0, flip, shift0 = best
    x = np.array([angle0, *shift0])
    fine = cell / 5  # refined on a finer occupancy, blurred coarse to fine (4, 2, 0.8 cells),
    fine_n = (int(2 * half / fine) + 1,) * 2  # in log density (every walkway counts, not
    fine_target = _histogram(fix, lo, fine, fine_n) * (1e7 / len(fix))  # its busiest spots)
    for sigma in (10.0, 5.0, 2.0):
        smooth = np.log1p(gaussian_filter(fine_target, sigma))

        def cost(p: F64, smooth: F64 = smooth) -> float:
            pts = _turn(mov, float(p[0]), flip) + p[1:]
            return -float(map_coordinates(smooth, ((pts - lo) / fine - 0.5).T, order=1).mean())

        x = minimize(cost, x, method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-9}).x
    angle = float(np.mod(x[0], 2 * np.pi))
    after = _turn(mov, angle, flip) + x[1:]
    return RigidAlignment(
        angle=angle, shift=(float(x[1]), float(x[2])), mirror=flip,
        overlap_before=occupancy_overlap(mov, fix), overlap_after=occupancy_overlap(after, fix),
    )
