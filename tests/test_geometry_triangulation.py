"""Triangulation (paper Eq. 3): against OpenCV's DLT, a generic least-squares solver, and truth."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import least_squares

from gymtrack.geometry import Camera, Rig, reprojection_residuals, triangulate, triangulate_rig

from conftest import points_seen_by, random_rig


def observe(rig: Rig, X: np.ndarray, distort: bool = False) -> np.ndarray:
    """(N, C, 2) pixels of (N, 3) points in every camera of the rig."""
    return np.stack([cam.project(X, distort=distort) for cam in rig], axis=1)


def rms_reprojection(rig: Rig, X: np.ndarray, uv: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    """Direct RMS reprojection error (N,) over the observing views, written independently."""
    mask = np.ones(uv.shape[:2], bool) if mask is None else mask
    out = []
    for n in range(len(X)):
        sq = [np.sum((cam.project(X[n], distort=False) - uv[n, c]) ** 2) for c, cam in enumerate(rig) if mask[n, c]]
        out.append(np.sqrt(np.mean(sq)))
    return np.array(out)


def cv2_triangulate(P0: np.ndarray, P1: np.ndarray, uv0: np.ndarray, uv1: np.ndarray) -> np.ndarray:
    Xh = cv2.triangulatePoints(P0, P1, uv0.T.copy(), uv1.T.copy())
    return (Xh[:3] / Xh[3]).T


# --------------------------------------------------------------------------- two views
def test_two_views_noise_free_match_opencv_and_truth(rng):
    for _ in range(4):
        rig = random_rig(rng, 2)
        X = points_seen_by(rng, rig, 50)
        uv = observe(rig, X)
        X_ours, err = triangulate(rig.projections, uv)
        X_cv = cv2_triangulate(rig[0].P, rig[1].P, uv[:, 0], uv[:, 1])
        np.testing.assert_allclose(X_cv, X, atol=1e-6)
        np.testing.assert_allclose(X_ours, X, atol=1e-7)
        np.testing.assert_allclose(err, 0.0, atol=1e-6)
        # the DLT alone is exact without noise too
        np.testing.assert_allclose(triangulate(rig.projections, uv, iterations=0)[0], X, atol=1e-6)


def test_two_views_noisy_refinement_beats_the_dlt_and_opencv(rng):
    for _ in range(4):
        rig = random_rig(rng, 2)
        X = points_seen_by(rng, rig, 40)
        uv = observe(rig, X) + rng.normal(0.0, 2.0, size=(40, 2, 2))
        X_gn, err_gn = triangulate(rig.projections, uv)
        X_dlt, err_dlt = triangulate(rig.projections, uv, iterations=0)
        X_cv = cv2_triangulate(rig[0].P, rig[1].P, uv[:, 0], uv[:, 1])
        err_cv = rms_reprojection(rig, X_cv, uv)
        assert np.all(err_gn <= err_dlt + 1e-9)
        assert np.all(err_gn <= err_cv + 1e-9)
        assert np.mean(err_gn) < np.mean(err_cv)  # strictly better on average, not merely equal
        # noise of 2 px at ~15 m gives centimetres, not metres
        assert np.median(np.linalg.norm(X_gn - X, axis=1)) < 0.1


def test_refinement_reaches_the_least_squares_optimum(rng):
    """Eq. 3 is a least-squares problem: compare with scipy's solver started from the truth."""
    rig = random_rig(rng, 3)
    X = points_seen_by(rng, rig, 15)
    uv = observe(rig, X) + rng.normal(0.0, 3.0, size=(15, 3, 2))
    mask = np.ones((15, 3), bool)
    mask[::3, 2] = False  # some points seen by 2 views only
    X_gn, err_gn = triangulate(rig.projections, uv, mask)
    for n in range(15):
        views = np.flatnonzero(mask[n])
        P = rig.projections[views]

        def resid(x):
            return reprojection_residuals(P, uv[n : n + 1, views], x[None])[0].ravel()

        sol = least_squares(resid, X[n], xtol=1e-14, ftol=1e-14, gtol=1e-14)
        err_opt = np.sqrt(np.sum(sol.fun**2) / len(views))
        assert err_gn[n] <= err_opt + 1e-6
        np.testing.assert_allclose(X_gn[n], sol.x, atol=1e-4)


@given(seed=st.integers(0, 2**32 - 1), sigma=st.floats(0.0, 5.0), n_views=st.integers(2, 5))
@settings(max_examples=30, deadline=None)
def test_refinement_never_worse_than_dlt_hypothesis(seed, sigma, n_views):
    rng = np.random.default_rng(seed)
    rig = random_rig(rng, n_views)
    X = points_seen_by(rng, rig, 10)
    uv = observe(rig, X) + rng.normal(0.0, sigma, size=(10, n_views, 2))
    _, err_gn = triangulate(rig.projections, uv)
    _, err_dlt = triangulate(rig.projections, uv, iterations=0)
    assert np.all(err_gn <= err_dlt + 1e-9)


# --------------------------------------------------------------------------- N views, masks
def test_n_views_exact_recovery(rng):
    for n_views in (3, 4, 6):
        rig = random_rig(rng, n_views)
        X = points_seen_by(rng, rig, 30)
        X_hat, err = triangulate(rig.projections, observe(rig, X))
        np.testing.assert_allclose(X_hat, X, atol=1e-7)
        np.testing.assert_allclose(err, 0.0, atol=1e-6)


def test_fewer_than_two_views_give_nan(rng):
    rig = random_rig(rng, 4)
    X = points_seen_by(rng, rig, 5)
    uv = observe(rig, X)
    mask = np.array([[0, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 1], [1, 1, 1, 1], [0, 0, 1, 0]], bool)
    X_hat, err = triangulate(rig.projections, uv, mask)
    bad = mask.sum(1) < 2
    assert np.all(np.isnan(X_hat[bad])) and np.all(np.isnan(err[bad]))
    np.testing.assert_allclose(X_hat[~bad], X[~bad], atol=1e-7)
    # all rows unobservable: all NaN, right shapes
    X_hat, err = triangulate(rig.projections, uv, np.zeros((5, 4), bool))
    assert X_hat.shape == (5, 3) and err.shape == (5,) and np.isnan(X_hat).all() and np.isnan(err).all()
    # without a mask, NaN pixels mean "not seen"
    uv_nan = uv.copy()
    uv_nan[0, 1:] = np.nan
    X_hat, _ = triangulate(rig.projections, uv_nan)
    assert np.isnan(X_hat[0]).all() and np.isfinite(X_hat[1:]).all()


@pytest.mark.parametrize("garbage", [np.nan, 1e7, -3.0, np.inf])
def test_masked_views_are_ignored(rng, garbage):
    rig = random_rig(rng, 4)
    X = points_seen_by(rng, rig, 40)
    uv = observe(rig, X) + rng.normal(0, 1.0, size=(40, 4, 2))
    mask = rng.random((40, 4)) < 0.7
    mask[:, :2] |= ~(mask.sum(1, keepdims=True) >= 2)  # at least two views everywhere
    dirty = uv.copy()
    dirty[~mask] = garbage
    X_dirty, err_dirty = triangulate(rig.projections, dirty, mask)
    X_clean, err_clean = triangulate(rig.projections, uv, mask)
    np.testing.assert_array_equal(X_dirty, X_clean)
    np.testing.assert_array_equal(err_dirty, err_clean)
    # and equal to triangulating each point with only its observing cameras
    for n in range(0, 40, 7):
        views = np.flatnonzero(mask[n])
        Xn, en = triangulate(rig.projections[views], uv[n : n + 1, views])
        np.testing.assert_allclose(X_clean[n], Xn[0], atol=1e-9)
        np.testing.assert_allclose(err_clean[n], en[0], rtol=1e-9, atol=1e-12)


def test_reprojection_error_matches_a_direct_computation(rng):
    rig = random_rig(rng, 4)
    X = points_seen_by(rng, rig, 30)
    uv = observe(rig, X) + rng.normal(0, 2.0, size=(30, 4, 2))
    mask = np.ones((30, 4), bool)
    mask[::2, 3] = False
    mask[::5, 0] = False
    X_hat, err = triangulate(rig.projections, uv, mask)
    np.testing.assert_allclose(err, rms_reprojection(rig, X_hat, uv, mask), rtol=1e-9)
    assert np.median(err) > 0.5  # noisy views cannot all be met exactly: the check is not vacuous
    res = reprojection_residuals(rig.projections, uv, X_hat)
    assert res.shape == (30, 4, 2)
    np.testing.assert_allclose(res[:, 1], rig[1].project(X_hat, distort=False) - uv[:, 1], atol=1e-9)


def test_shape_mismatch_is_refused(rng):
    rig = random_rig(rng, 3)
    with pytest.raises(ValueError, match="P must be"):
        triangulate(rig.projections[:2], np.zeros((4, 3, 2)))


# --------------------------------------------------------------------------- rig, distortion
@pytest.mark.parametrize("ncoef", [5, 8])
def test_triangulate_rig_undistorts_raw_pixels(rng, ncoef):
    rig = random_rig(rng, 4, distortion=ncoef)
    X = points_seen_by(rng, rig, 40)
    raw = observe(rig, X, distort=True)
    X_hat, err = triangulate_rig(rig, raw)
    np.testing.assert_allclose(X_hat, X, atol=1e-6)
    np.testing.assert_allclose(err, 0.0, atol=1e-5)
    # ignoring the distortion gives a worse fit: the lens is not negligible
    X_bad, err_bad = triangulate_rig(rig, raw, undistort=False)
    assert np.max(err_bad) > 0.5
    assert np.max(np.linalg.norm(X_bad - X, axis=1)) > 1e-3
    # masks pass through
    mask = np.ones((40, 4), bool)
    mask[:, 2] = False
    raw[:, 2] = np.nan
    np.testing.assert_allclose(triangulate_rig(rig, raw, mask)[0], X, atol=1e-6)


# --------------------------------------------------------------------------- conventions
def test_t_of_the_wrong_camera_breaks_triangulation(rng):
    rig = random_rig(rng, 3)
    X = points_seen_by(rng, rig, 30)
    uv = observe(rig, X)
    c0 = rig[0]
    wrong0 = Camera(c0.name, c0.size, c0.K, c0.R, rig[1].t, c0.dist)
    X_hat, err = triangulate(Rig([wrong0, rig[1], rig[2]]).projections, uv)
    assert np.median(np.linalg.norm(X_hat - X, axis=1)) > 0.1
    assert np.median(err) > 5.0


def test_camera_order_must_match_the_uv_columns(rng):
    rig = random_rig(rng, 3)
    X = points_seen_by(rng, rig, 30)
    uv = observe(rig, X)
    P_swapped = rig.projections[[1, 0, 2]]
    X_hat, err = triangulate(P_swapped, uv)
    assert np.median(np.linalg.norm(X_hat - X, axis=1)) > 0.1
    assert np.median(err) > 5.0
    # swapping both consistently is fine
    np.testing.assert_allclose(triangulate(P_swapped, uv[:, [1, 0, 2]])[0], X, atol=1e-7)
