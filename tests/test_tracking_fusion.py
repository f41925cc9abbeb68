"""cascade+'s ray-plane fusion (tracking.fusion, tracking._kernels.fusion): the weighted least
squares against scipy's solver on the same residuals, its limit cases against OpenCV and Eq. 7/9,
its covariance against a Monte Carlo of noisy pixels, the compiled kernel against the numpy
reference (tests/reference/fusion.py) on random windows, the consistency gate, bad sigmas."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.optimize import least_squares

from conftest import rays_to, ring_rig, same, simple_scene
from gymtrack.errors import InputError
from gymtrack.geometry.arrays import PlaneArrays
from gymtrack.geometry.plane import Plane, intersect_rays_plane
from gymtrack.tracking._kernels.fusion import fuse_pairs
from gymtrack.tracking.fusion import CHI2_GATE, PlaneRayFusion, fuse_rays_plane, fusion_chi2
from gymtrack.tracking.plane_fallback import MIN_COS, plane_stage
from gymtrack.tracking.types import WindowTracklets
from reference import fusion as ref

W = 10


def test_weighted_least_squares_against_scipy(rng):
    for _ in range(20):
        V = rng.integers(1, 4)
        o = rng.normal(0, 5, (V, 3))
        d = rng.normal(0, 1, (V, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        s = rng.uniform(0.01, 0.5, V)
        n = rng.normal(0, 1, 3)
        n /= np.linalg.norm(n)
        p, sig = rng.normal(0, 1, 3), rng.uniform(0.05, 1.0)

        def residuals(X):  # across each ray (2 components: any orthonormal basis) and along the normal
            out = []
            for i in range(V):
                r = X - o[i]
                r = r - (r @ d[i]) * d[i]
                out.append(r / s[i])  # 3 components spanning the 2D residual: same squared norm
            return np.r_[np.concatenate(out), (n @ (X - p)) / sig]

        sol = least_squares(residuals, np.zeros(3), xtol=1e-14, ftol=1e-14, gtol=1e-14)
        X, A = fuse_rays_plane(o, d, s, np.ones(V, bool), n, p, sig)
        np.testing.assert_allclose(X, sol.x, rtol=1e-6, atol=1e-6)
        # the cost at the optimum is the chi-square of the residuals
        np.testing.assert_allclose(fusion_chi2(X, o, d, s, np.ones(V, bool), n, p, sig), 2 * sol.cost, rtol=1e-6, atol=1e-9)
        # and A is the Gauss-Newton information J^T J of those residuals; they are linear in X, so
        # J is exact by unit steps (scipy's finite-difference jac is only good to ~1e-6 relative)
        J = np.stack([residuals(e) - residuals(np.zeros(3)) for e in np.eye(3)], axis=1)
        np.testing.assert_allclose(sol.jac, J, rtol=1e-4, atol=1e-4)
        np.testing.assert_allclose(A, J.T @ J, rtol=1e-9, atol=1e-9)


def test_limits_opencv_without_prior_and_eq9_with_a_rigid_plane(rng):
    rig = ring_rig([0, 70])
    X = np.array([0.3, -0.4, 1.3])
    uv, o, d = rays_to(rig, X)
    Xf, _ = fuse_rays_plane(o, d, np.ones(2), np.ones(2, bool), np.array([1.0, 0, 0]), np.zeros(3), np.inf)
    h = cv2.triangulatePoints(rig[0].P, rig[1].P, uv[0].reshape(2, 1), uv[1].reshape(2, 1))
    np.testing.assert_allclose(Xf, (h[:3] / h[3]).ravel(), atol=1e-6)
    # plane_sigma -> 0 with opposite views: the Eq. 9 average of the Eq. 7 candidates
    rig = ring_rig([0, 180])
    uv, o, d = rays_to(rig, np.array([0.0, 0.5, 1.3]), 2.0, rng)
    plane = Plane(np.zeros(3), np.array([1.0, 0, 0]))
    cand, _ = intersect_rays_plane(o, d, plane)
    Xf, _ = fuse_rays_plane(o, d, np.full(2, 0.01), np.ones(2, bool), plane.normal, plane.point, 1e-6)
    np.testing.assert_allclose(Xf, cand.mean(axis=0), atol=2e-3)
    # one ray and a rigid plane: the Eq. 7 candidate of that ray
    Xf, _ = fuse_rays_plane(o, d, np.full(2, 0.01), np.array([True, False]), plane.normal, plane.point, 1e-7)
    np.testing.assert_allclose(Xf, cand[0], atol=1e-6)


def test_covariance_against_monte_carlo(rng):
    """The inverse information is the spread of the point under pixel noise (first order)."""
    rig = ring_rig([0, 40])
    X = np.array([0.4, -0.2, 1.4])
    sigma_px, f = 2.0, rig[0].K[0, 0]
    plane = Plane(np.zeros(3), np.array([1.0, 0, 0]))
    s = np.linalg.norm(X - rig.centres, axis=1) * sigma_px / f  # depth along the optical axis ~ distance here
    _, o, d0 = rays_to(rig, X)
    _, A = fuse_rays_plane(o, d0, s, np.ones(2, bool), plane.normal, plane.point, 0.3)
    samples = []
    for _ in range(3000):
        _, o, d = rays_to(rig, X, sigma_px, rng)
        # the prior is a measurement too: the plane's offset drawn with its sigma
        p = plane.point + rng.normal(0, 0.3) * plane.normal
        samples.append(fuse_rays_plane(o, d, s, np.ones(2, bool), plane.normal, p, 0.3)[0])
    cov = np.cov(np.array(samples).T)
    pred = np.linalg.inv(A)
    # compare along the principal axes (the directions the angle between the rays sets)
    w, V = np.linalg.eigh(pred)
    np.testing.assert_allclose(np.diag(V.T @ cov @ V), w, rtol=0.15)


def _window(rng, rig, m):
    """m two-view pairs of boxes: people on or off the plane x = 0, noise, gaps, wrong boxes."""
    C = len(rig)
    box = np.full((m, 2, W, 4), np.nan)
    observed = np.zeros((m, 2, W), bool)
    cams = np.zeros((m, 2), np.int64)
    for k in range(m):
        cams[k] = np.sort(rng.choice(C, 2, replace=False))
        x0 = np.array([rng.normal(0, 0.1) if rng.random() < 0.6 else rng.uniform(-2, 2), rng.uniform(-2, 2), 1.0])
        for w in range(W):
            X = x0 + np.array([0, 0.05 * w, 0.1 * np.sin(w)])
            for j in range(2):
                cam = rig[cams[k, j]]
                top, mid, bot = (cam.project(np.array([X + [0, 0, dz]]), distort=False)[0] for dz in (0.85, 0, -0.85))
                h = bot[1] - top[1]
                box[k, j, w] = [mid[0], (top[1] + bot[1]) / 2, 0.4 * h, h]
                box[k, j, w, :2] += rng.normal(0, 2.0, 2)
        box[k][rng.random((2, W)) < 0.15] = np.nan
        observed[k] = np.isfinite(box[k]).all(-1) & (rng.random((2, W)) < 0.9)
        if rng.random() < 0.2:  # a wrong box: someone else, a metre away, at one frame
            box[k, rng.integers(2), rng.integers(W), 0] += 200.0
    return box, observed, cams


def test_kernel_matches_the_numpy_reference(rng):
    rig = ring_rig([0, 60, 150, 180, 250])
    a = rig.arrays
    focal = np.ascontiguousarray((a.K[:, 0, 0] + a.K[:, 1, 1]) / 2)
    depth0 = np.linalg.norm(a.centres - np.array([0, 0, 1.2]), axis=1)
    planes = PlaneArrays.from_planes([Plane(np.zeros(3), np.array([1.0, 0, 0])),
                                      Plane(np.array([0.0, 1.5, 0]), np.array([0.0, 1, 0]))])
    for trial in range(6):
        box, observed, cams = _window(rng, rig, 12)
        P = 1 if trial % 2 else 2
        args = (box, observed, cams, a.centres, a.back, focal, depth0, 2.0, 0.03, planes.normal[:P].copy(),
                planes.point[:P].copy(), [0.05, 0.1, 0.25][trial % 3], MIN_COS)
        got, want = fuse_pairs(*args), ref.fuse_pairs(*args)
        np.testing.assert_array_equal(got[1], want[1])  # the planes chosen
        for g, w_ in zip(got[:1] + got[2:], want[:1] + want[2:]):
            same(g, w_, rtol=1e-6, atol=1e-6)


def test_consistency_gate_rejects_a_wrong_box_and_keeps_the_noisy_truth(rng):
    rig = ring_rig([0, 180])
    a = rig.arrays
    focal = np.ascontiguousarray((a.K[:, 0, 0] + a.K[:, 1, 1]) / 2)
    depth0 = np.linalg.norm(a.centres - np.array([0, 0, 1.2]), axis=1)
    planes = PlaneArrays.from_planes([Plane(np.zeros(3), np.array([1.0, 0, 0]))])
    chis = []
    for _ in range(200):  # people on and off the plane, 2 px noise, some wrong boxes
        box, observed, cams = _window(rng, rig, 1)
        chis.append(fuse_pairs(box, observed, cams, a.centres, a.back, focal, depth0, 2.0, 0.03, planes.normal,
                               planes.point, 1.0, MIN_COS)[3][0])
    chis = np.array(chis)
    assert 0.05 < np.mean(chis > CHI2_GATE) < 0.6  # (the off-plane people and wrong boxes; plane_sigma 1 m)
    # a view whose box jumps to someone 1.5 m along the plane at one frame: far above the gate
    X = np.array([0.0, 0.0, 1.2])
    box = np.zeros((1, 2, W, 4))
    for j, cam in enumerate(rig):
        for w in range(W):
            Y = X + ([0, 1.5, 0] if (j == 1 and w == 5) else 0)
            top, mid, bot = (cam.project(np.array([Y + [0, 0, dz]]), distort=False)[0] for dz in (0.85, 0, -0.85))
            box[0, j, w] = [mid[0], mid[1], 80, bot[1] - top[1]]  # (the centre: the projection of Y)
    out = fuse_pairs(box, np.ones((1, 2, W), bool), np.array([[0, 1]]), a.centres, a.back, focal, depth0, 2.0, 0.03,
                     planes.normal, planes.point, 0.1, MIN_COS)
    assert out[3][0] > 10 * CHI2_GATE
    ok = fuse_pairs(box[:, :, :5], np.ones((1, 2, 5), bool), np.array([[0, 1]]), a.centres, a.back, focal, depth0,
                    2.0, 0.03, planes.normal, planes.point, 0.1, MIN_COS)
    assert ok[3][0] < 1.0 and ok[2][0] < 1.0  # noise-free, on the plane
    np.testing.assert_allclose(ok[0][0, 0], np.tile(X, (5, 1)), atol=1e-6)


def test_invalid_sigmas_raise():
    o, d = np.zeros((2, 3)), np.eye(3)[:2]
    for s, sig in ((np.array([0.1, 0.0]), 0.1), (np.array([0.1, np.nan]), 0.1), (np.array([0.1, -1.0]), 0.1),
                   (np.ones(2), 0.0), (np.ones(2), -0.1), (np.ones(2), np.nan)):
        with pytest.raises(InputError):
            fuse_rays_plane(o, d, s, np.ones(2, bool), np.array([0, 0, 1.0]), np.zeros(3), sig)
    # an invalid ray's sigma is not read
    fuse_rays_plane(o, d, np.array([0.1, np.nan]), np.array([True, False]), np.array([0, 0, 1.0]), np.zeros(3), 0.1)


def _pair_window(rig, X, jump=None):
    """Segments of one person at X (W, 3) in two views (exact boxes; ``jump``: (frame, offset) of
    the second view's box: someone else at that frame)."""
    box = np.zeros((2, W, 4))
    for j, cam in enumerate(rig):
        for w in range(W):
            Y = X[w] + (jump[1] if jump is not None and j == 1 and w == jump[0] else 0)
            top, mid, bot = (cam.project(np.array([Y + [0, 0, dz]]), distort=False)[0] for dz in (0.85, 0, -0.85))
            box[j, w] = [mid[0], mid[1], 80, bot[1] - top[1]]
    ones = np.ones((2, W), bool)
    return WindowTracklets(0, np.arange(2), np.arange(2), box, ones, ones, np.arange(2 * W).reshape(2, W))


@pytest.mark.parametrize("sigma", [1e-4, 0.1])
def test_refine_fuses_the_plane_stages_two_view_tracklets(sigma):
    """cascade+'s hook: an opposite pair the plane stage matched (Eq. 8, Eq. 9 average) gets the
    fused points -- the Eq. 9 average itself when the prior is rigid -- and keeps Eq. 9 when its
    boxes contradict each other at a frame."""
    rig = ring_rig([0, 165])
    X = np.stack([np.full(W, 0.15), np.linspace(-0.5, 0.5, W), np.full(W, 1.2)], axis=1)  # 15 cm off x = 0
    scene = simple_scene(plane_sigma=sigma, fuse_plane=True)
    planes = PlaneArrays.from_planes([Plane(np.zeros(3), np.array([1.0, 0, 0]))])
    fusion = PlaneRayFusion(rig, scene, planes, np.array([[False, True], [True, False]]))
    segs = _pair_window(rig, X)
    pl = plane_stage(segs, rig, planes, 0.5)
    assert len(pl) == 1 and (pl.members[0] >= 0).sum() == 2
    out = fusion.refine(segs, pl)
    assert fusion.counts["fused_plane"] == 1
    if sigma < 1e-3:  # the limit: the paper's Eq. 9 average of the candidates
        np.testing.assert_allclose(out.xyz, pl.xyz, atol=2e-3)
    else:  # the fused point leaves the plane towards the truth, as far as the prior lets it
        assert np.all((out.xyz[0, :, 0] > 0.01) & (out.xyz[0, :, 0] < 0.15))
        assert np.linalg.norm(out.xyz[0] - X, axis=1).mean() < np.linalg.norm(pl.xyz[0] - X, axis=1).mean()
    # a wrong box at one frame: inconsistent, the Eq. 9 points are kept
    bad = _pair_window(rig, X, jump=(4, np.array([0.0, 0.3, 0.0])))
    pl = plane_stage(bad, rig, planes, 0.5)
    out = fusion.refine(bad, pl)
    assert fusion.counts["fused_inconsistent"] == 1
    np.testing.assert_array_equal(out.xyz, pl.xyz)
