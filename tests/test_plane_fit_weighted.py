"""The covariance-weighted apparatus-plane fit (two opposite views), its degeneracy reports, and
the tracker's online plane refinement."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from conftest import as_raw, make_detections, ring_rig, simple_scene

from gymtrack.eval.plane_bench import perturbed_plane
from gymtrack.geometry.plane import Plane
from gymtrack.geometry.plane_fit import fit_apparatus_plane, plane_difference, triangulation_covariances
from gymtrack.tracking import track_detections
from gymtrack.tracking.plane_fit import with_plane

TRUE = Plane(np.array([0.2, 0.0, 0.0]), np.array([np.cos(np.radians(15)), np.sin(np.radians(15)), 0.0]))


def _opencv_points(rig, X, noise_px, rng):
    """(N, 3) points projected by OpenCV into each view, pixel noise added, triangulated by OpenCV."""
    uv = []
    for cam in rig:
        rvec, _ = cv2.Rodrigues(cam.R)
        p, _ = cv2.projectPoints(X.reshape(-1, 1, 3), rvec, cam.t, cam.K, cam.dist)
        uv.append(p.reshape(-1, 2) + rng.normal(0, noise_px, (len(X), 2)))
    h = cv2.triangulatePoints(rig[0].P, rig[1].P, uv[0].T, uv[1].T)
    return (h[:3] / h[3]).T


def _on_plane(rng, n, plane=TRUE, stray=0.05):
    along = np.array([-plane.normal[1], plane.normal[0], 0.0])
    X = plane.point + rng.uniform(-2.5, 2.5, n)[:, None] * along + rng.normal(0, stray, n)[:, None] * plane.normal
    X[:, 2] = rng.uniform(1.0, 2.5, n)
    return X


def test_covariance_of_an_opposite_pair_matches_opencv_monte_carlo(rng):
    rig = ring_rig([0, 180])  # the cameras' axis is x: the pair is poor along x, precise across it
    X = np.array([[0.3, 0.5, 1.6]])
    est = np.stack([_opencv_points(rig, X, 1.0, rng)[0] for _ in range(1500)])
    cov = triangulation_covariances(rig.projections, X, np.ones((1, 2), bool), 1.0)[0]
    emp = np.cov(est.T)
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), np.sqrt(np.diag(emp)), rtol=0.15)
    assert cov[0, 0] > 25 * cov[1, 1]  # long along the axis
    assert np.isnan(triangulation_covariances(rig.projections, X, np.array([[True, False]]), 1.0)).all()


def test_two_opposite_views_recover_the_plane_and_swapping_the_cameras_changes_nothing(rng):
    rig = ring_rig([15, 195])  # the opposite pair looks along the plane's normal: the n_cam = 2 case
    X = _on_plane(rng, 400)
    pts = _opencv_points(rig, X, 1.5, rng)
    views = np.ones((len(pts), 2), bool)
    cov = triangulation_covariances(rig.projections, pts, views, 1.5)
    preset = perturbed_plane(TRUE, np.array([0.0, 0.0, 1.5]), 0.3, 10.0)
    fit = fit_apparatus_plane(pts, cov, preset)
    off, ang = plane_difference(fit.plane, TRUE, np.array([0.0, 0.0, 1.5]))
    assert fit.determined and off < 0.05 and ang < 2.0, (off, ang, fit.reason)
    assert fit.plane.normal[2] == 0
    # convention: the same points from the cameras in the other order give the same plane
    rig2 = type(rig)([rig[1], rig[0]])
    cov2 = triangulation_covariances(rig2.projections, pts, views, 1.5)
    fit2 = fit_apparatus_plane(pts, cov2, preset)
    o2, a2 = plane_difference(fit2.plane, fit.plane, np.array([0.0, 0.0, 1.5]))
    assert o2 < 1e-6 and a2 < 1e-6


def test_undetermined_direction_keeps_the_preset_and_says_why(rng):
    preset = perturbed_plane(TRUE, np.zeros(3), 0.3, 10.0)
    blob = np.array([0.5, 0.5, 1.5]) + rng.normal(0, 0.03, (200, 3))  # the gymnast hardly moves
    fit = fit_apparatus_plane(blob, None, preset)
    assert not fit.determined and "cells" in fit.reason
    np.testing.assert_allclose(fit.plane.normal, preset.normal, atol=1e-12)
    assert abs(fit.plane.signed_distance(np.array([0.5, 0.5, 1.5]))) < 0.02  # the offset is still fitted
    # circling the apparatus (pommel horse): the cloud is long across the preset's plane
    a = rng.uniform(0, 2 * np.pi, 400)
    ring = np.column_stack([0.3 * np.cos(a), 1.0 * np.sin(a), np.full(400, 1.4)])
    fit = fit_apparatus_plane(ring, None, Plane(np.zeros(3), np.array([0.0, 1.0, 0.0])))
    assert not fit.determined and "edge" in fit.reason
    np.testing.assert_allclose(fit.plane.normal, [0.0, 1.0, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match="at least 3"):
        fit_apparatus_plane(np.full((10, 3), np.nan))


def _walker_on_plane(T=300):
    """A gymnast (box bottom above h_bot) travelling along the plane x = 0 and back."""
    t = np.arange(T)
    y = 2.0 * np.sin(2 * np.pi * t / T)
    return np.stack([0.02 * np.sin(t / 7), y, 2.0 + 0.2 * np.sin(t / 5)], axis=1)[None]


def test_online_refinement_moves_a_wrong_plane_toward_the_true_one():
    rig = ring_rig([0, 120, 240])
    det, _ = make_detections(rig, _walker_on_plane(), noise=1.0, seed=3)
    true = Plane(np.zeros(3), np.array([1.0, 0.0, 0.0]))
    focus = np.array([0.0, 0.0, 1.5])
    wrong = with_plane(simple_scene(refine_plane=4), perturbed_plane(true, focus, 0.3, 10.0))
    res = track_detections(rig, wrong, as_raw(det), mode="cascade+")
    moved = res.summary["plane_refinement"]
    final = Plane(np.array(moved["point"]), np.array(moved["normal"]))
    off, ang = plane_difference(final, true, focus)
    assert moved["moves"] >= 1 and off < 0.1 and ang < 3.0, moved
    # the paper's cascade ignores the parameter: no refinement, no summary entry
    assert "plane_refinement" not in track_detections(rig, wrong, as_raw(det), mode="cascade").summary


def test_planes_auto_fits_offline_and_cascade_plus_refines_online():
    rig = ring_rig([0, 120, 240])
    det, _ = make_detections(rig, _walker_on_plane(), noise=1.0, seed=5)
    true = Plane(np.zeros(3), np.array([1.0, 0.0, 0.0]))
    focus = np.array([0.0, 0.0, 1.5])
    auto = with_plane(simple_scene(), perturbed_plane(true, focus, 0.3, 10.0)).model_copy(update={"auto_planes": True})
    res = track_detections(rig, auto, as_raw(det), mode="cascade+")
    assert res.summary["plane_refinement"]["refits"] >= 1
    # the refinement starts from the offline fit: it is already near the true plane
    final = res.summary["plane_refinement"]
    off, ang = plane_difference(Plane(np.array(final["point"]), np.array(final["normal"])), true, focus)
    assert off < 0.1 and ang < 3.0
    assert "plane_refinement" not in track_detections(rig, auto, as_raw(det), mode="cascade").summary


def test_the_batched_direction_scan_equals_the_one_direction_cost(rng):
    from gymtrack.geometry.plane_fit import _costs, _offset_cost  # (same package's helpers, tested together)

    xy = np.column_stack([rng.uniform(-2, 2, 500), rng.normal(0, 0.1, 500)])
    xy[:50] = rng.uniform(-3, 3, (50, 2))  # outliers: the truncation matters
    S = rng.uniform(0.0, 0.05, (500, 2, 2))
    S = S @ S.transpose(0, 2, 1) + 0.001 * np.eye(2)
    w = rng.uniform(0.2, 1.0, 500)
    angles = np.radians(np.arange(0.0, 180.0, 7.0))
    one = [_offset_cost(xy, S, np.array([np.cos(a), np.sin(a)]), 0.25, w)[0] for a in angles]
    np.testing.assert_allclose(_costs(xy, S, angles, 0.25, w), one, rtol=1e-12, atol=1e-12)


def test_scene_fit_from_two_opposite_views_with_a_cascade_pass():
    from gymtrack.tracking.plane_fit import fit_scene_planes

    rig = ring_rig([0, 180])  # n_cam = 2: only the opposite pair sees the gymnast
    det, _ = make_detections(rig, _walker_on_plane(400), noise=1.0, seed=7)
    true = Plane(np.zeros(3), np.array([1.0, 0.0, 0.0]))
    focus = np.array([0.0, 0.0, 1.5])
    wrong = with_plane(simple_scene(), perturbed_plane(true, focus, 0.3, 10.0))
    first = track_detections(rig, wrong, as_raw(det), mode="triangulation")
    casc = track_detections(rig, wrong, as_raw(det), mode="cascade")  # its points lie on the wrong plane
    fit = fit_scene_planes(first, wrong, rig=rig, extra=casc)
    off, ang = plane_difference(fit.plane.plane, true, focus)
    assert off < 0.1 and ang < 3.0, (off, ang, fit.plane.reason)
    # the cascade's points alone, taken as they are (on the wrong plane), would reproduce the wrong plane;
    # re-triangulated from their boxes they find the true one
    alone = fit_scene_planes(casc, wrong, rig=rig)
    assert plane_difference(alone.plane.plane, true, focus)[0] < 0.1


def test_online_refinement_on_a_simulated_routine_moves_toward_the_true_plane():
    from gymtrack.simulate import simulate_routine

    sim = simulate_routine("balance_beam", n_cam=4, seed=0, seconds=10)
    true, focus = Plane.from_spec(sim.scene.planes[0]), sim.scene.focus_point
    wrong = with_plane(sim.scene, perturbed_plane(true, focus, 0.3, 10.0))
    wrong = wrong.model_copy(update={"params": wrong.params.model_copy(update={"refine_plane": 4})})
    moved = track_detections(sim.rig, wrong, sim.detections, mode="cascade+").summary["plane_refinement"]
    off, ang = plane_difference(Plane(np.array(moved["point"]), np.array(moved["normal"])), true, focus)
    assert moved["moves"] >= 1 and off < 0.25 and ang < 7.0, (off, ang)  # from 0.3 m and 10 deg


def test_plane_bench_refuses_an_unknown_fit_pass_before_reading_the_suite(tmp_path):
    from typer.testing import CliRunner

    from gymtrack.cli import app

    # the suite folder does not exist: the option is checked first, and named
    r = CliRunner().invoke(app, ["plane-bench", "-s", str(tmp_path / "no-suite"), "--fit-pass", "triangulate"])
    from gymtrack.errors import InputError

    assert r.exit_code != 0 and isinstance(r.exception, InputError)  # (gymtrack.cli.main prints it as "error: ...")
    msg = str(r.exception)
    assert "--fit-pass" in msg and "triangulation, cascade, both" in msg and "'triangulate'" in msg
