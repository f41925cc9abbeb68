"""Uncertainty-aware fusion of two views and the vertical plane (beyond the paper; mode ``cascade+``).

Paper: Section III-B/C, Eq. 3 and Eq. 5-9. The cascade switches hard: a two-view cluster is
triangulated (Eq. 3) unless its views are opposite, then both views go to the plane (Eq. 7-9).
Here a two-view cluster on the plane is one weighted least-squares problem over its rays and the
plane (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., Sec. 12.2 and 5.1.3: the
point-to-ray residuals weighted by the inverse measurement covariance; the plane as a prior):

* each ray (camera centre ``o``, unit direction ``d``, Eq. 5-6) is a measurement of the point
  with information ``(I - d d^T) / s^2`` across the ray, where ``s = z * sigma_px / f`` is the
  box centre's pixel noise seen at depth ``z`` (first-order propagation of an isotropic pixel
  error through the pinhole: a pixel offset ``e`` moves the ray by ``z e / f`` at depth ``z``),
  ``sigma_px^2 = pixel_sigma^2 + (box_sigma * h)^2``: a fixed detector noise plus the box
  centre's wander over the body, which grows with the box height ``h``. (On the default suite
  the box centres of matched detections lie, per axis, a median 0.02 h and RMS 0.03-0.06 h from
  the projected body centre: ``box_sigma`` 0.03 is the RMS, with heavy tails.) The sum over two
  rays is the triangulated point's information: near-opposite rays leave the direction along
  them badly known (variance ~ ``s^2 / sin^2`` of their angle), and that is where the prior acts;
* the plane ``(n, X^p)`` (Eq. 7) is a prior with information ``n n^T / plane_sigma^2`` along its
  normal: the body's centre stays within ~``plane_sigma`` of the apparatus plane.

The estimate ``X = A^-1 b`` with ``A = sum_i (I - d_i d_i^T) / s_i^2 + n n^T / sigma_n^2`` and
``b = sum_i (I - d_i d_i^T) o_i / s_i^2 + n (n . X^p) / sigma_n^2``; ``A^-1`` is X's covariance.
The paper's rule is the limit case: ``plane_sigma -> 0`` puts the point on the plane where the
rays cross it (for rays across the plane, the Eq. 9 average of the Eq. 7 candidates),
``plane_sigma -> inf`` is triangulation. One ray and the plane also give a point (as the plane
stage gives one from a view whose partner is missing at that frame).

Where it applies (the association stays the paper's):

* a non-opposite two-view cluster of Eq. 2 (:meth:`PlaneRayFusion.step`): fused instead of Eq. 3
  when the tests below pass, else triangulated by Eq. 3 as in the paper;
* opposite pairs go to the plane stage as in the paper (through ``cascade+``'s floor
  hypothesis), whose Algorithm 1 on Eq. 8 may join them with other views: Eq. 2 is ambiguous
  for opposite views and can split a person seen by four views into two opposite pairs, which,
  fused one by one, became two tracks of one person. The plane stage's tracklets of exactly two
  views then get the fused points instead of the Eq. 9 average (:meth:`PlaneRayFusion.refine`).

The model only holds for a person on the plane whose two boxes are of the same body, so a
pair is fused only when

* on the plane: the plane's Mahalanobis distance from the two-ray point
  (``(n . (X_t - X^p))^2 / (n^T A_t^-1 n + sigma_n^2)``, median over the window's frames) is
  below ``PLANE_GATE`` (chi-square, 1 degree of freedom, 3 sigma); of several planes the closest;
* consistent: at every frame with two rays the fused points' (centre, top, bottom) weighted
  squared residuals are below ``CHI2_GATE`` (chi-square, 2 degrees of freedom: 2 x 2 across the
  rays + 1 along the normal - 3 unknowns, p = 0.001). Without it one frame where the IoU tracker
  handed a view's 2D track to someone else (boxes metres apart) drew the least-squares compromise
  metres off the plane, and Eq. 4 then dropped the whole tracklet: the target was lost;
* Eq. 8 agrees: the two views' Eq. 7 candidates are within ``cluster_plane`` on average.

``plane_sigma`` trades: small values follow the plane like the paper (right where the body's
centre stays on it: the default suite's balance beam, vault, rings and parallel bars keep it
within 2-7 cm RMS), large values follow the rays (right on the pommel horse, ~35 cm RMS, and
the bars, 13-19 cm) but let noisy opposite rays, which fix depth to only ~``s / sin`` of their
angle, pull the point off. 0.1 m is the default (benchmark in the README); set it per scene.

Why the first version doubled the n_cam = 2 failure rate (measured on the default suite): one-ray
frames came out NaN yet valid (an absent ray's NaN direction times its zero weight poisoned
``A``), which broke cross-window links; the missing consistency test (above: vault, FR 100 %);
opposite pairs fused one by one, outside the plane stage's association (above: duplicate tracks,
identity switches); and ``plane_sigma`` 0.25 m, looser than the body's real spread on most
apparatus (AED). Its per-window numpy code halved the speed; the kernel costs ~5 % of cascade+.

Speed: one compiled call per window (:func:`._kernels.fusion.fuse_pairs`); its numpy reference
is ``tests/reference/fusion.py``. :func:`fuse_rays_plane` is the same least squares as an array
function (the tests and the limit cases).

Shapes: segments ``box`` (K, W, 4) centre form, undistorted pixels; ``members`` (M, C).
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from ..errors import InputError
from ..geometry.arrays import PlaneArrays
from ..geometry.camera import Rig
from ..scene import Scene
from ._kernels.fusion import fuse_pairs
from .plane_fallback import MIN_COS
from .reconstruct import observed_views
from .types import INTERPOLATED, TRIANGULATION, WindowTracklets, WindowTracklets3D

__all__ = ["PLANE_GATE", "CHI2_GATE", "fuse_rays_plane", "fusion_chi2", "PlaneRayFusion"]

#: Mahalanobis distance squared of the plane below which a pair is taken to be on it (3 sigma)
PLANE_GATE = 9.0
#: chi-square (2 degrees of freedom) above which a frame's two rays and the plane contradict
#: each other (p = 0.001): not one body on the plane
CHI2_GATE = 13.8
#: the counters reported only when the fusion is on (the others are in :data:`.summary.COUNTS`)
COUNTS = ("fused_inconsistent",)
_TINY = 1e-9  # information of a direction no ray constrains (keeps A invertible)


def fuse_rays_plane(o: np.ndarray, d: np.ndarray, s: np.ndarray, valid: np.ndarray, normal: np.ndarray,
                    point: np.ndarray, plane_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """The weighted least-squares point of rays and a plane prior.

    o, d: (..., V, 3) ray origins and unit directions; s: (..., V) the rays' sigma across the
    ray at the point (metres); valid: (..., V) bool, rays that count; normal, point: (3,) the plane;
    plane_sigma: metres along the normal (``inf``: no prior). Returns X (..., 3) and the
    information matrix A (..., 3, 3) (its inverse is X's covariance).
    """
    w = _weights(s, valid, plane_sigma)
    d = np.where(valid[..., None], d, 0.0)  # (an absent ray's NaN direction would poison A: 0 * NaN)
    Q = np.eye(3) - d[..., :, None] * d[..., None, :]  # (..., V, 3, 3)
    A = np.einsum("...v,...vij->...ij", w, Q)
    b = np.einsum("...v,...vij,...vj->...i", w, Q, np.where(valid[..., None], o, 0.0))
    nn = np.outer(normal, normal)
    lam = 0.0 if not np.isfinite(plane_sigma) else 1.0 / plane_sigma ** 2
    A = A + lam * nn + _TINY * np.eye(3)
    b = b + lam * normal * float(normal @ point)
    return np.linalg.solve(A, b[..., None])[..., 0], A


def fusion_chi2(X: np.ndarray, o: np.ndarray, d: np.ndarray, s: np.ndarray, valid: np.ndarray, normal: np.ndarray,
                point: np.ndarray, plane_sigma: float) -> np.ndarray:
    """The weighted squared residuals of a point X (..., 3) of :func:`fuse_rays_plane` (same
    arguments): across each valid ray and along the plane's normal. Under the model (Gaussian
    noise of the given sigmas, one point) a chi-square with ``2 V' + 1 - 3`` degrees of freedom
    (``V'`` valid rays; without the prior ``2 V' - 3``)."""
    w = _weights(s, valid, plane_sigma)
    d = np.where(valid[..., None], d, 0.0)
    r = X[..., None, :] - np.where(valid[..., None], o, 0.0)
    r = r - (r * d).sum(-1, keepdims=True) * d
    c = (w * (r ** 2).sum(-1)).sum(-1)
    if np.isfinite(plane_sigma):
        c = c + ((X @ normal - normal @ point) / plane_sigma) ** 2
    return c




def _weights(s: np.ndarray, valid: np.ndarray, plane_sigma: float) -> np.ndarray:
    """1 / s^2 of the valid rays (0 elsewhere); sigmas must be positive (``plane_sigma``: inf = no prior)."""
    s, valid = np.asarray(s, dtype=np.float64), np.asarray(valid, bool)
    if not plane_sigma > 0:  # (NaN fails too)
        raise InputError(f"plane_sigma must be > 0 (inf: no prior), got {plane_sigma}", field="plane_sigma")
    if (valid & ~(s > 0) | valid & ~np.isfinite(s)).any():
        raise InputError("ray sigmas must be finite and > 0 where the ray is valid", field="s")
    return np.where(valid, 1.0 / np.where(valid, s, 1.0) ** 2, 0.0)


class PlaneRayFusion:
    """Mode ``cascade+``'s handling of two-view clusters (see the module docstring).

    rig, scene: the cameras and the scene (``params.plane_sigma``, ``pixel_sigma``, ``box_sigma``,
    ``cluster_plane``); planes: the P planes; opposite: (C, C) bool opposite camera pairs; counts:
    the dict where ``fused_plane`` (fused with the plane), ``fused_triangulated`` (left to Eq. 3:
    off the plane or inconsistent), ``fused_to_plane_stage`` (opposite pairs left to the plane
    stage) and ``fused_inconsistent`` (clusters on the plane that failed :data:`CHI2_GATE`) are counted.
    """

    def __init__(self, rig: Rig, scene: Scene, planes: PlaneArrays, opposite: np.ndarray, counts: dict | None = None):
        a = rig.arrays
        self.centres, self.back = a.centres, a.back
        self.focal = np.ascontiguousarray((a.K[:, 0, 0] + a.K[:, 1, 1]) / 2)  # (C,)
        self.planes = planes if len(planes.point) else None
        p = scene.params
        self.plane_sigma, self.pixel_sigma, self.box_sigma = p.plane_sigma, p.pixel_sigma, p.box_sigma
        self.cluster_plane = p.cluster_plane
        self.opposite = np.asarray(opposite, bool)
        # (C,) first guess of each camera's depth: its distance to the scene's focus, the apparatus
        self.depth0 = np.ascontiguousarray(np.linalg.norm(self.centres - scene.focus_point, axis=1))
        self.counts = defaultdict(int) if counts is None else counts  # (the tracker's summary counters)

    def set_planes(self, planes: PlaneArrays) -> None:
        """Use other planes from now on (an online plane estimate)."""
        self.planes = planes if len(planes.point) else None

    def step(self, segs: WindowTracklets, members: np.ndarray, fallback: np.ndarray, multi: np.ndarray
             ) -> tuple[WindowTracklets3D | None, np.ndarray, np.ndarray]:
        """The window's non-opposite two-view clusters fused with the plane (instead of Eq. 3).

        members: (M, C) clusters; fallback, multi: (M,) bool, the paper's choice of clusters for
        the plane stage and for triangulation. Returns the fused 3D tracklets (None: none) and
        the new fallback and multi masks (the clusters fused here are in neither; the others
        keep the paper's route). Opposite pairs go to the plane stage as in the paper, whose
        Algorithm 1 on Eq. 8 may join them with other views (Eq. 2 is ambiguous for opposite
        views: it splits a person seen by four views into two opposite pairs); :meth:`refine`
        then fuses the plane stage's two-view tracklets.
        """
        has = members >= 0
        two = (has.sum(axis=1) == 2) & ~fallback
        if self.planes is None or not two.any():
            return None, fallback, multi
        idx = np.flatnonzero(two)
        seg = np.sort(np.where(has[idx], members[idx], np.iinfo(np.int64).max), axis=1)[:, :2]  # (m, 2)
        X, use = self._fuse(segs, seg)
        self.counts["fused_triangulated"] += int((~use).sum())
        if not use.any():
            return None, fallback, multi
        multi = multi.copy()
        multi[idx[use]] = False
        valid = np.isfinite(X[:, 0]).all(axis=-1)[use]  # (m', W): one ray and the plane give a point
        return self._tracklets(segs, members[idx[use]], X[use], valid), fallback, multi

    def refine(self, segs: WindowTracklets, pl: WindowTracklets3D) -> WindowTracklets3D:
        """The plane stage's tracklets of exactly two views (``members`` index ``segs``), their
        Eq. 9 averages replaced by the fused points where the pair is on the plane and consistent."""
        has = pl.members >= 0
        two = has.sum(axis=1) == 2
        if self.planes is None or not two.any():
            return pl
        idx = np.flatnonzero(two)
        seg = np.sort(np.where(has[idx], pl.members[idx], np.iinfo(np.int64).max), axis=1)[:, :2]
        self.counts["fused_to_plane_stage"] += len(idx)
        X, use = self._fuse(segs, seg)
        if not use.any():
            return pl
        rows = idx[use]
        ok = pl.valid[rows] & np.isfinite(X[use, 0]).all(axis=-1)  # (the plane stage's frames)
        xyz, top, bottom = pl.xyz.copy(), pl.top_z.copy(), pl.bottom_z.copy()
        xyz[rows] = np.where(ok[..., None], X[use, 0], xyz[rows])
        top[rows] = np.where(ok, X[use, 1, :, 2], top[rows])
        bottom[rows] = np.where(ok, X[use, 2, :, 2], bottom[rows])
        return WindowTracklets3D(pl.start, xyz, top, bottom, pl.valid, pl.source, pl.n_views, pl.members, pl.track_id)

    def _fuse(self, segs: WindowTracklets, seg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The kernel on the pairs of segments ``seg`` (m, 2) (of different cameras): the fused
        points X (m, 3, W, 3) and which pairs pass the plane and consistency gates (and Eq. 8)."""
        cams = np.ascontiguousarray(segs.camera[seg], dtype=np.int64)
        X, _, m2, chi2, eq8 = fuse_pairs(
            np.ascontiguousarray(segs.box[seg], dtype=np.float64), np.ascontiguousarray(segs.observed[seg]), cams,
            self.centres, self.back, self.focal, self.depth0, float(self.pixel_sigma), float(self.box_sigma),
            self.planes.normal, self.planes.point, float(self.plane_sigma), MIN_COS)
        on = m2 <= PLANE_GATE
        consistent = chi2 <= CHI2_GATE
        use = on & consistent & (eq8 <= self.cluster_plane)
        self.counts["fused_plane"] += int(use.sum())
        self.counts["fused_inconsistent"] += int((on & ~consistent).sum())
        return X, use

    @staticmethod
    def _tracklets(segs: WindowTracklets, members: np.ndarray, X: np.ndarray, valid: np.ndarray) -> WindowTracklets3D:
        """X (m, 3, W, 3) centre / top / bottom, valid (m, W) -> the window's 3D tracklets."""
        n_views = observed_views(segs, members)
        source = np.where(n_views > 0, TRIANGULATION, INTERPOLATED).astype(np.int8)
        return WindowTracklets3D(segs.start, np.ascontiguousarray(X[:, 0]), X[:, 1, :, 2], X[:, 2, :, 2], valid,
                                 source, n_views, members, np.full(len(members), -1, np.int64))
