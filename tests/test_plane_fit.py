"""Plane fitting (RANSAC vertical plane, floor), planes: auto, the wrong-plane experiment's
perturbation, and cascade+'s fusion of rays and the plane prior."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from conftest import rays_to, as_raw, make_detections, ring_rig, simple_scene

from gymtrack.errors import SceneError
from gymtrack.eval.plane_bench import perturbed_plane
from gymtrack.formats.scene import scene_from_dict
from gymtrack.geometry.plane import Plane, intersect_rays_plane
from gymtrack.geometry.plane_fit import fit_plane, fit_vertical_plane, plane_difference
from gymtrack.tracking import track_detections
from gymtrack.tracking.fusion import fuse_rays_plane


def test_vertical_plane_is_recovered_despite_outliers(rng):
    n = np.array([np.sin(0.3), np.cos(0.3), 0.0])  # a plane turned 0.3 rad about z, 0.5 m off the origin
    along = np.array([np.cos(0.3), -np.sin(0.3), 0.0])
    s = rng.uniform(-4, 4, 300)
    pts = 0.5 * n + s[:, None] * along + rng.normal(0, 0.05, 300)[:, None] * n
    pts[:, 2] = rng.uniform(0.5, 3, 300)
    pts[:90] = rng.uniform(-4, 4, (90, 3))  # 30 % far off the plane
    pts[0] = np.nan  # ignored, not an inlier
    fit = fit_vertical_plane(pts, threshold=0.3)
    off, ang = plane_difference(fit.plane, Plane(0.5 * n, n), np.zeros(3))
    assert off < 0.02 and ang < 1.0 and fit.plane.normal[2] == 0
    assert not fit.inliers[0] and fit.inliers[90:].mean() > 0.95 and fit.rms < 0.08


def test_floor_is_recovered_from_box_bottoms(rng):
    pts = np.column_stack([rng.uniform(-5, 5, 200), rng.uniform(-5, 5, 200), rng.normal(0.02, 0.02, 200)])
    pts[:30, 2] += 1.0  # people on a step or badly triangulated
    fit = fit_plane(pts, threshold=0.1)
    assert fit.plane.normal[2] > 0.999 and abs(fit.plane.signed_distance(np.zeros(3))) < 0.01 + 0.02
    with pytest.raises(ValueError, match="at least 3"):
        fit_plane(np.full((5, 3), np.nan))


def test_plane_difference_hand_worked_and_the_perturbation():
    ref = Plane(np.zeros(3), np.array([0.0, 1.0, 0.0]))
    assert plane_difference(Plane(np.array([0, 0.3, 0]), np.array([0, -1.0, 0])), ref, np.zeros(3)) == pytest.approx((0.3, 0.0))
    turned = Plane(np.zeros(3), np.array([np.sin(np.radians(10)), np.cos(np.radians(10)), 0.0]))
    assert plane_difference(turned, ref, np.zeros(3)) == pytest.approx((0.0, 10.0))
    wrong = perturbed_plane(ref, np.array([1.0, 2.0, 1.0]), 0.3, 10.0)
    assert plane_difference(wrong, ref, np.array([1.0, 2.0, 1.0])) == pytest.approx((0.3, 10.0))


def test_planes_auto_in_scene_yaml():
    s = scene_from_dict({"apparatus": "vault", "planes": "auto"})
    assert s.auto_planes and len(s.planes) == 1  # the preset's plane is the starting guess
    assert s.to_yaml_dict()["planes"] == "auto" and scene_from_dict(s.to_yaml_dict()).auto_planes
    assert not scene_from_dict({"apparatus": "vault"}).auto_planes
    with pytest.raises(SceneError, match="'auto'"):
        scene_from_dict({"apparatus": "vault", "planes": "fitted"})


def test_fusion_without_prior_is_triangulation_against_opencv():
    rig = ring_rig([0, 70])
    X = np.array([0.3, -0.4, 1.3])
    uv, o, d = rays_to(rig, X)
    Xf, _ = fuse_rays_plane(o, d, np.ones(2), np.ones(2, bool), np.array([1.0, 0, 0]), np.zeros(3), np.inf)
    h = cv2.triangulatePoints(rig[0].P, rig[1].P, uv[0].reshape(2, 1), uv[1].reshape(2, 1))
    np.testing.assert_allclose(Xf, (h[:3] / h[3]).ravel(), atol=1e-6)
    np.testing.assert_allclose(Xf, X, atol=1e-6)


def test_fusion_with_a_tight_prior_is_the_paper_rule_eq9(rng):
    rig = ring_rig([0, 180])  # opposite views through the plane x = 0
    X = np.array([0.0, 0.5, 1.3])
    uv, o, d = rays_to(rig, X, 2.0, rng)
    plane = Plane(np.zeros(3), np.array([1.0, 0, 0]))
    cand, _ = intersect_rays_plane(o, d, plane)
    Xf, A = fuse_rays_plane(o, d, np.full(2, 0.01), np.ones(2, bool), plane.normal, plane.point, 1e-6)
    np.testing.assert_allclose(Xf, cand.mean(axis=0), atol=2e-3)  # Eq. 9: the candidates' average
    assert abs(Xf[0]) < 1e-6
    # a loose prior leaves a well-conditioned pair where its rays cross
    rig2 = ring_rig([0, 90])
    Y = np.array([1.0, 0.5, 1.3])  # 1 m off the plane
    _, o2, d2 = rays_to(rig2, Y)
    Yf, _ = fuse_rays_plane(o2, d2, np.full(2, 0.01), np.ones(2, bool), plane.normal, plane.point, 10.0)
    np.testing.assert_allclose(Yf, Y, atol=2e-3)


def fusing_scene():
    """The test scene with cascade+'s experimental plane fusion switched on (params.fuse_plane)."""
    scene = simple_scene()
    return scene.model_copy(update={"params": scene.params.model_copy(update={"fuse_plane": True})})


def test_cascade_plus_fuses_an_opposite_pair_on_the_plane_and_triangulates_an_off_plane_pair():
    T = 40
    t = np.arange(T)
    on = np.stack([np.zeros(T), -1.0 + 0.05 * t, 1.0 + 0.2 * np.sin(t / 6)], axis=1)[None]
    det, _ = make_detections(ring_rig([0, 180]), on, noise=1.0, seed=2)
    res = track_detections(ring_rig([0, 180]), fusing_scene(), as_raw(det), mode="cascade+")
    assert len(res.tracks) > 0.8 * T and res.summary["fused_plane"] > 0
    err = np.linalg.norm(res.tracks.xyz - on[0, res.tracks.frame], axis=1)
    assert np.median(err) < 0.05
    off = on + np.array([2.0, 0, 0])  # 2 m off the plane, seen from two views 90 degrees apart
    rig = ring_rig([0, 90])
    det, _ = make_detections(rig, off, noise=0.5, seed=4)
    res = track_detections(rig, fusing_scene(), as_raw(det), mode="cascade+")
    assert res.summary["fused_triangulated"] > 0 and res.summary["fused_plane"] == 0
    err = np.linalg.norm(res.tracks.xyz - off[0, res.tracks.frame], axis=1)
    assert np.median(err) < 0.05  # not pulled onto the plane
