"""Uncertainty-aware fusion of two views and the vertical plane (beyond the paper; mode ``cascade+``).

Paper: Section III-B/C, Eq. 3 and Eq. 5-9. The cascade switches hard: a two-view cluster is
triangulated (Eq. 3) unless its views are opposite, then both views go to the plane (Eq. 7-9).
Here every two-view cluster is one weighted least-squares problem over its rays and the plane:

* each ray (camera centre ``o``, unit direction ``d``, Eq. 5-6) is a measurement of the point
  with information ``(I - d d^T) / s^2`` across the ray, where ``s = z * sigma_px / f`` is the
  detector's pixel noise (``pixel_sigma`` plus ``box_sigma`` x box height, the box centre's
  jitter grows with the box) seen at depth ``z``. The sum over two rays is the triangulated
  point's information: near-opposite rays leave the direction along them unknown, and that is
  where the uncertainty goes (the angle between the rays sets the conditioning);
* the plane ``(n, X^p)`` (Eq. 7) is a prior with information ``n n^T / plane_sigma^2`` along its
  normal (the body's centre stays within ~``plane_sigma`` of the apparatus plane).

The estimate ``X = A^-1 b`` with ``A = sum_i (I - d_i d_i^T) / s_i^2 + n n^T / sigma_n^2`` and
``b = sum_i (I - d_i d_i^T) o_i / s_i^2 + n (n . X^p) / sigma_n^2``. The paper's rule is the limit
case: ``plane_sigma -> 0`` puts the point on the plane where the rays cross it (for rays across
the plane, the Eq. 9 average of the Eq. 7 candidates), ``plane_sigma -> inf`` is triangulation.

The prior only applies to a person on the plane: per cluster, the plane's Mahalanobis distance
from the two-ray point (``(n . (X_t - X^p))^2 / (n^T A_t^-1 n + sigma_n^2)``, median over the
window's frames) must be below ``PLANE_GATE``; of several planes the closest is used. Otherwise
the pair is triangulated (non-opposite views) or handed to the plane stage as in the paper
(opposite views, whose triangulation is unreliable). An opposite pair is also handed to the plane
stage when its two Eq. 7 candidates disagree by more than ``cluster_plane`` (Eq. 8): the
paper's test against phantom pairs.

Shapes: segments ``box`` (K, W, 4) centre form, undistorted pixels; ``members`` (M, C).
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from ..geometry.arrays import PlaneArrays
from ..geometry.camera import Rig
from ..scene import Scene
from .reconstruct import observed_views
from .types import INTERPOLATED, TRIANGULATION, WindowTracklets, WindowTracklets3D

__all__ = ["PLANE_GATE", "fuse_rays_plane", "PlaneRayFusion"]

#: Mahalanobis distance squared of the plane below which a pair is taken to be on it (3 sigma)
PLANE_GATE = 9.0
_TINY = 1e-9  # information of a direction no ray constrains (keeps A invertible)
_OFFSETS = np.array([0.0, -0.5, 0.5])  # centre, top-centre, bottom-centre: v = cy + offset * h


def fuse_rays_plane(o: np.ndarray, d: np.ndarray, s: np.ndarray, valid: np.ndarray, normal: np.ndarray,
                    point: np.ndarray, plane_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """The weighted least-squares point of rays and a plane prior.

    o, d: (..., V, 3) ray origins and unit directions; s: (..., V) the rays' sigma across the
    ray at the point (metres); valid: (..., V) bool, rays that count; normal, point: (3,) the plane;
    plane_sigma: metres along the normal (``inf``: no prior). Returns X (..., 3) and the
    information matrix A (..., 3, 3) (its inverse is X's covariance).
    """
    w = np.where(valid, 1.0 / np.where(valid, s, 1.0) ** 2, 0.0)  # (..., V)
    Q = np.eye(3) - d[..., :, None] * d[..., None, :]  # (..., V, 3, 3)
    A = np.einsum("...v,...vij->...ij", w, Q)
    b = np.einsum("...v,...vij,...vj->...i", w, Q, np.where(valid[..., None], o, 0.0))
    nn = np.outer(normal, normal)
    lam = 0.0 if not np.isfinite(plane_sigma) else 1.0 / plane_sigma ** 2
    A = A + lam * nn + _TINY * np.eye(3)
    b = b + lam * normal * float(normal @ point)
    return np.linalg.solve(A, b[..., None])[..., 0], A


class PlaneRayFusion:
    """Mode ``cascade+``'s handling of two-view clusters (see the module docstring).

    rig, scene: the cameras and the scene (``params.plane_sigma``, ``pixel_sigma``, ``box_sigma``,
    ``cluster_plane``); planes: the P planes; opposite: (C, C) bool opposite camera pairs; counts:
    the dict where ``fused_plane``, ``fused_triangulated``, ``fused_to_plane_stage`` are counted.
    """

    def __init__(self, rig: Rig, scene: Scene, planes: PlaneArrays, opposite: np.ndarray, counts: dict | None = None):
        a = rig.arrays
        self.centres, self.back = a.centres, a.back
        self.focal = (a.K[:, 0, 0] + a.K[:, 1, 1]) / 2  # (C,)
        self.planes = planes if len(planes.point) else None
        p = scene.params
        self.plane_sigma, self.pixel_sigma, self.box_sigma = p.plane_sigma, p.pixel_sigma, p.box_sigma
        self.cluster_plane = p.cluster_plane
        self.opposite = np.asarray(opposite, bool)
        self.depth0 = np.linalg.norm(self.centres - scene.focus_point, axis=1)  # (C,) first guess of z
        self.counts = defaultdict(int) if counts is None else counts  # (the tracker's summary counters)

    def set_planes(self, planes: PlaneArrays) -> None:
        """Use other planes from now on (an online plane estimate)."""
        self.planes = planes

    # ------------------------------------------------------------------ one window
    def step(self, segs: WindowTracklets, members: np.ndarray, fallback: np.ndarray, multi: np.ndarray
             ) -> tuple[WindowTracklets3D | None, np.ndarray, np.ndarray]:
        """The window's two-view clusters fused with the plane.

        members: (M, C) clusters; fallback, multi: (M,) bool, the paper's choice of clusters for
        the plane stage and for triangulation. Returns the fused 3D tracklets (None: none) and
        the new fallback and multi masks (the clusters fused here are in neither).
        """
        M, C = members.shape
        has = members >= 0
        two = has.sum(axis=1) == 2
        if not two.any():
            return None, fallback, multi
        idx = np.flatnonzero(two)
        cams = np.sort(np.argsort(~has[idx], axis=1, kind="stable")[:, :2], axis=1)  # (m, 2)
        seg = members[idx[:, None], cams]  # (m, 2)
        opp = self.opposite[cams[:, 0], cams[:, 1]]
        box = segs.box[seg]  # (m, 2, W, 4)
        ok = np.isfinite(box).all(axis=-1)  # (m, 2, W)
        o, d, f = self._rays(box, cams)  # (m, 2, 1, 3), (m, 2, 3, W, 3), (m, 2, 1, 1)
        sig_px = np.hypot(self.pixel_sigma, self.box_sigma * box[..., 3])[:, :, None, :]  # (m, 2, 1, W)
        z = self.depth0[cams][:, :, None, None]
        valid = np.broadcast_to(ok[:, :, None, :], sig_px.shape[:2] + (3, ok.shape[-1]))
        # (m, 3, W, 2, ...) layout for the solver: views last
        mv = lambda x: np.moveaxis(x, 1, -2) if x.ndim == 5 else np.moveaxis(x, 1, -1)  # noqa: E731
        O, D, V = np.moveaxis(np.broadcast_to(o, d.shape), 1, -2), mv(d), mv(valid)
        both = V.all(axis=-1)[:, 0]  # (m, W) frames with two rays
        # the two-ray point (no prior), its information, then the depth refined once
        X, A = None, None
        for _ in range(2):
            s = mv(z * sig_px / f) if X is None else np.linalg.norm(X[..., None, :] - O, axis=-1) * mv(sig_px / f)
            X, A = fuse_rays_plane(O, D, s, V, np.array([0.0, 0.0, 1.0]), np.zeros(3), np.inf)
        plane, use = self._choose_plane(X[:, 0], A[:, 0], both)
        out_X = X.copy()
        if self.planes is not None and use.any():
            for p in np.unique(plane[use]):
                sel = use & (plane == p)
                Xp, _ = fuse_rays_plane(O[sel], D[sel], s[sel], V[sel], self.planes.normal[p], self.planes.point[p],
                                        self.plane_sigma)
                out_X[sel] = Xp
        pair_valid = np.where(use[:, None], V.any(axis=-1)[:, 0], both)  # one ray + the plane is a point
        # opposite pairs: off the plane, or Eq. 8 disagreement -> the paper's plane stage
        to_stage = opp & ~use
        if self.planes is not None and (opp & use).any():
            to_stage |= opp & use & (self._eq8(o, d[:, :, 0], segs.observed[seg] & ok, plane) > self.cluster_plane)
        keep = ~to_stage
        self.counts["fused_plane"] += int((use & keep).sum())
        self.counts["fused_triangulated"] += int((~use & keep).sum())
        self.counts["fused_to_plane_stage"] += int(to_stage.sum())
        handled = np.zeros(M, bool)
        handled[idx[keep]] = True
        fallback = fallback & ~handled
        fallback[idx[to_stage]] = True
        multi = multi & ~handled & ~fallback
        if not keep.any():
            return None, fallback, multi
        return self._tracklets(segs, members[idx[keep]], out_X[keep], pair_valid[keep]), fallback, multi

    # ------------------------------------------------------------------ helpers
    def _rays(self, box: np.ndarray, cams: np.ndarray):
        """Rays of the centre, top-centre and bottom-centre: origins (m, 2, 1, 1, 3), unit
        directions (m, 2, 3, W, 3), focal lengths (m, 2, 1, 1)."""
        u = box[..., 0][:, :, None, :]
        v = box[..., 1][:, :, None, :] + _OFFSETS[:, None] * box[..., 3][:, :, None, :]  # (m, 2, 3, W)
        pix = np.stack([np.broadcast_to(u, v.shape), v, np.ones_like(v)], axis=-1)
        d = np.einsum("mcij,mcqwj->mcqwi", self.back[cams], pix)
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        return self.centres[cams][:, :, None, None, :], d, self.focal[cams][:, :, None, None]

    def _choose_plane(self, X: np.ndarray, A: np.ndarray, both: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per cluster: the plane closest to the two-ray centres (median Mahalanobis distance
        squared over frames with two rays) and whether it is within :data:`PLANE_GATE`.
        X (m, W, 3), A (m, W, 3, 3), both (m, W)."""
        m = len(X)
        if self.planes is None:
            return np.zeros(m, np.int64), np.zeros(m, bool)
        cov = np.linalg.inv(A)
        n, pt = self.planes.normal, self.planes.point  # (P, 3)
        r = np.einsum("mwi,pi->pmw", X, n) - (n * pt).sum(axis=1)[:, None, None]  # (P, m, W)
        var = np.einsum("pi,mwij,pj->pmw", n, cov, n) + self.plane_sigma ** 2
        m2 = np.where(both[None], r ** 2 / var, np.nan)
        med = np.full(m2.shape[:2], 0.0)
        anyb = both.any(axis=1)
        if anyb.any():
            med[:, anyb] = np.nanmedian(m2[:, anyb], axis=2)
        plane = np.argmin(med, axis=0)
        return plane, med[plane, np.arange(m)] <= PLANE_GATE

    def _eq8(self, o: np.ndarray, d: np.ndarray, observed: np.ndarray, plane: np.ndarray) -> np.ndarray:
        """Eq. 8: the mean distance of the two views' Eq. 7 centre candidates on each cluster's
        plane over frames both observed. o (m, 2, 1, 1, 3), d (m, 2, W, 3), observed (m, 2, W)."""
        n, pt = self.planes.normal[plane][:, None, None, :], self.planes.point[plane][:, None, None, :]
        o = o[:, :, 0]
        dn = (d * n).sum(-1)
        lam = ((pt - o) * n).sum(-1) / np.where(np.abs(dn) > 1e-3, dn, np.nan)
        Xc = o + np.where(lam > 0, lam, np.nan)[..., None] * d  # (m, 2, W, 3)
        dist = np.linalg.norm(Xc[:, 0] - Xc[:, 1], axis=-1)
        good = observed.all(axis=1) & np.isfinite(dist)
        with np.errstate(invalid="ignore"):
            return np.where(good.any(axis=1), np.where(good, dist, 0).sum(1) / np.maximum(good.sum(1), 1), np.inf)

    @staticmethod
    def _tracklets(segs: WindowTracklets, members: np.ndarray, X: np.ndarray, valid: np.ndarray) -> WindowTracklets3D:
        """X (m, 3, W, 3) centre / top / bottom, valid (m, W) -> the window's 3D tracklets."""
        n_views = observed_views(segs, members)
        X = np.where(valid[:, None, :, None], X, np.nan)
        source = np.where(n_views > 0, TRIANGULATION, INTERPOLATED).astype(np.int8)
        return WindowTracklets3D(segs.start, np.ascontiguousarray(X[:, 0]), X[:, 1, :, 2], X[:, 2, :, 2], valid,
                                 source, n_views, members, np.full(len(members), -1, np.int64))
