"""Compiled kernels of the target stage: its pose boxes (paper Section III-D, Eq. 14), and the
distance to the apparatus that ``cascade+``'s reach rule asks of raised points (:func:`apparatus_distance`).

:func:`buffered_boxes` projects the smoothed target into every view
(:func:`gymtrack.geometry.primitives.project_point`, the model of :meth:`Camera.project`) and
sizes its square box from the target's detection there, or from the projected body box where
the view has none (see :mod:`gymtrack.tracking.target`). Numpy/OpenCV reference in
``tests/test_tracking_target.py``. Rows: xyz (N, 3), wh (N, C, 2).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ...geometry.primitives import project_point
from .sample import sample

_NAN = np.nan


class BodyBox(NamedTuple):
    """box_scale: alpha of Eq. 14; half_depth: the body box's half-depth across the plane
    (metres); tied: no plane (half-depth = half-length); min_cos: views seeing the plane more
    obliquely do not measure the half-length; min_half_length, default_half_height: metres."""

    box_scale: float
    half_depth: float
    tied: bool
    min_cos: float
    min_half_length: float
    default_half_height: float


@njit(cache=True, error_model="numpy")
def buffered_boxes(xyz, top_z, bottom_z, wh, across, prior, rig, body):
    """Eq. 14 boxes with the body box where a view has no detection (:func:`gymtrack.tracking.target.buffered_boxes`).

    xyz (N, 3), top_z, bottom_z (N,), wh (N, C, 2), across (N, 3) unit horizontal normals of the
    plane, prior (the last half-length measured before these rows); rig:
    :class:`~gymtrack.geometry.arrays.RigArrays`; body: :class:`BodyBox`.
    Returns (box (N, C, 4), ok (N, C), the last half-length).
    """
    N, C = wh.shape[0], wh.shape[1]
    R, t, K, dist, sizes = rig.R, rig.t, rig.K, rig.dist, rig.size
    box_scale, half_depth, tied = body.box_scale, body.half_depth, body.tied
    min_cos, min_half_length, default_half_height = body.min_cos, body.min_half_length, body.default_half_height
    box = np.empty((N, C, 4))
    ok = np.zeros((N, C), np.bool_)
    u = np.empty(C)
    v = np.empty(C)
    z = np.empty(C)
    size = np.empty(C)
    lo_u = np.empty(C)
    hi_u = np.empty(C)
    lo_v = np.empty(C)
    hi_v = np.empty(C)
    a_last = prior
    for n in range(N):
        X0, X1, X2 = xyz[n, 0], xyz[n, 1], xyz[n, 2]
        b0, b1 = across[n, 0], across[n, 1]
        g0, g1 = -b1, b0  # along the plane
        missing = False
        best = -np.inf
        for c in range(C):
            u[c], v[c], z[c] = project_point(R, t, K, dist, c, X0, X1, X2)
            w, h = wh[n, c, 0], wh[n, c, 1]
            size[c] = max(w, h) if (w == w and h == h) else _NAN
            if size[c] != size[c]:
                missing = True
                continue
            if not z[c] > 0:
                continue
            metres = w * z[c] / K[c, 0, 0]  # the box width at the centre's depth
            ca = abs(R[c, 0, 0] * g0 + R[c, 0, 1] * g1)
            cb = abs(R[c, 0, 0] * b0 + R[c, 0, 1] * b1)
            if tied:
                a = metres / (2 * (ca + cb))
            elif ca >= min_cos:
                a = (metres / 2 - half_depth * cb) / ca
            else:
                continue
            if a == a and abs(a) != np.inf and a > best:
                best = a
        if best > -np.inf:
            a_last = max(best, min_half_length)
        if missing:
            a = a_last
            b = a if tied else half_depth
            top = top_z[n] if top_z[n] == top_z[n] else X2 + default_half_height
            bot = bottom_z[n] if bottom_z[n] == bottom_z[n] else X2 - default_half_height
            for c in range(C):
                lo_u[c] = np.inf
                hi_u[c] = -np.inf
                lo_v[c] = np.inf
                hi_v[c] = -np.inf
            for sa in (-1.0, 1.0):
                for sb in (-1.0, 1.0):
                    cx = X0 + sa * a * g0 + sb * b * b0
                    cy = X1 + sa * a * g1 + sb * b * b1
                    for cz in (bot, top):
                        for c in range(C):
                            if size[c] == size[c]:
                                continue
                            pu, pv, _ = project_point(R, t, K, dist, c, cx, cy, cz)
                            if pu == pu:
                                lo_u[c] = min(lo_u[c], pu)
                                hi_u[c] = max(hi_u[c], pu)
                                lo_v[c] = min(lo_v[c], pv)
                                hi_v[c] = max(hi_v[c], pv)
            for c in range(C):
                if size[c] != size[c] and hi_u[c] >= lo_u[c]:
                    size[c] = max(hi_u[c] - lo_u[c], hi_v[c] - lo_v[c])
        for c in range(C):
            s = box_scale * size[c]
            box[n, c, 0] = u[c]
            box[n, c, 1] = v[c]
            box[n, c, 2] = s
            box[n, c, 3] = s
            ok[n, c] = z[c] > 0 and size[c] > 0 and 0 <= u[c] <= sizes[c, 0] and 0 <= v[c] <= sizes[c, 1]
    return box, ok, a_last



@njit(cache=True)
def apparatus_distance(X, bar_a, bar_b, bar_r, box_lo, box_hi, R, shift):
    """(n,) each point's distance to the nearest apparatus surface (inf without any; NaN for a
    point with a NaN where there is one): :func:`gymtrack.placement.apparatus_distance` (every surface, ``on_top``
    off) for the reach rule (:mod:`gymtrack.tracking.reach`), which asks it of every raised point
    of every window (~100 us of numpy calls each time). X: (n, 3); bar_a, bar_b: (B, 3) bar ends;
    bar_r: (B,) radii; box_lo, box_hi: (Q, 3) blocks in the preset's frame, which ``R`` (3, 3)
    turns and ``shift`` (3,) moves into the world (a point P there is ``(X - shift) @ R``)."""
    n = X.shape[0]
    out = np.full(n, np.inf)
    for i in range(n):
        x0, x1, x2 = X[i, 0], X[i, 1], X[i, 2]
        if x0 != x0 or x1 != x1 or x2 != x2:
            if bar_r.shape[0] + box_lo.shape[0]:
                out[i] = _NAN
            continue
        best = np.inf
        for b in range(bar_r.shape[0]):
            a0, a1, a2 = bar_a[b, 0], bar_a[b, 1], bar_a[b, 2]
            d0, d1, d2 = bar_b[b, 0] - a0, bar_b[b, 1] - a1, bar_b[b, 2] - a2
            t = ((x0 - a0) * d0 + (x1 - a1) * d1 + (x2 - a2) * d2) / max(d0 * d0 + d1 * d1 + d2 * d2, 1e-12)
            t = min(max(t, 0.0), 1.0)
            e0, e1, e2 = x0 - (a0 + t * d0), x1 - (a1 + t * d1), x2 - (a2 + t * d2)
            best = min(best, np.sqrt(e0 * e0 + e1 * e1 + e2 * e2) - bar_r[b])
        if box_lo.shape[0]:
            y0, y1, y2 = x0 - shift[0], x1 - shift[1], x2 - shift[2]
            p0 = y0 * R[0, 0] + y1 * R[1, 0] + y2 * R[2, 0]
            p1 = y0 * R[0, 1] + y1 * R[1, 1] + y2 * R[2, 1]
            p2 = y0 * R[0, 2] + y1 * R[1, 2] + y2 * R[2, 2]
            for q in range(box_lo.shape[0]):
                g0 = max(max(box_lo[q, 0] - p0, p0 - box_hi[q, 0]), 0.0)
                g1 = max(max(box_lo[q, 1] - p1, p1 - box_hi[q, 1]), 0.0)
                g2 = max(max(box_lo[q, 2] - p2, p2 - box_hi[q, 2]), 0.0)
                best = min(best, np.sqrt(g0 * g0 + g1 * g1 + g2 * g2))
        out[i] = best
    return out


def warm_up() -> None:
    """Compile (or load) the kernel: the sample person, detected in one view, with and without a plane."""
    s = sample()
    N, C = s.xyz.shape[0], len(s.rig)
    wh = np.full((N, C, 2), np.nan)
    wh[:, 0] = s.box[0, :, 2:]
    across = np.ascontiguousarray(np.broadcast_to(s.planes[0].normal, (N, 3)))
    bars, blocks = np.array([[0.0, -1.0, 2.0], [0.0, 1.0, 2.0]]), np.array([[-1.0, -1.0, 0.0], [1.0, 1.0, 1.0]])
    apparatus_distance(s.xyz, bars[:1], bars[1:], np.array([0.02]), blocks[:1], blocks[1:], np.eye(3), np.zeros(3))
    for tied in (False, True):
        buffered_boxes(s.xyz, s.xyz[:, 2] + 0.9, s.xyz[:, 2] - 0.9, wh, across, 0.25, s.rig.arrays,
                       BodyBox(1.3, 0.25, tied, 0.3, 0.1, 0.9))
