"""Ray-plane intersection (paper Eq. 7): hand-worked cases, the literal formula, failure statuses."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gymtrack.geometry import Plane, RayPlaneStatus, intersect_rays_plane

from conftest import points_seen_by, random_camera, random_points, random_rig

OK, PARALLEL, BEHIND = RayPlaneStatus.OK, RayPlaneStatus.PARALLEL, RayPlaneStatus.BEHIND


def eq7_literal(Xo: np.ndarray, v: np.ndarray, n: np.ndarray, Xp: np.ndarray) -> np.ndarray:
    """Paper Eq. 7 written out for one ray: X = X^o + (n . (X^p - X^o)) / (n . v) v."""
    return Xo + (np.dot(n, Xp - Xo) / np.dot(n, v)) * v


def test_hand_worked_intersections():
    floor = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    # from 2 m up, 45 degrees down along +x: hits the floor at x = 2
    X, status = intersect_rays_plane(np.array([0.0, 0.0, 2.0]), np.array([1.0, 0.0, -1.0]), floor)
    np.testing.assert_allclose(X, [2.0, 0.0, 0.0], atol=1e-15)
    assert status == OK
    # the vertical plane x = 5 (the paper's apparatus plane case), ray at 45 degrees in x-y
    wall = Plane([5.0, -3.0, 0.7], [1.0, 0.0, 0.0])
    X, status = intersect_rays_plane(np.array([0.0, 0.0, 1.5]), np.array([1.0, 1.0, 0.0]), wall)
    np.testing.assert_allclose(X, [5.0, 5.0, 1.5], atol=1e-15)
    # a plane through (0, 0, 1) with normal (0, 1, 1)/sqrt2, i.e. y + z = 1; ray from (0, -4, 0)
    # along +y: y + 0 = 1 at y = 1
    tilted = Plane([0.0, 0.0, 1.0], [0.0, 2.0, 2.0])  # normal normalised by Plane
    np.testing.assert_allclose(tilted.normal, [0, 1 / np.sqrt(2), 1 / np.sqrt(2)])
    X, _ = intersect_rays_plane(np.array([0.0, -4.0, 0.0]), np.array([0.0, 3.0, 0.0]), tilted)
    np.testing.assert_allclose(X, [0.0, 1.0, 0.0], atol=1e-15)


def test_matches_eq7_literally_and_points_land_on_the_plane(rng):
    rig = random_rig(rng, 4, distortion=5)
    X_true = points_seen_by(rng, rig, 50)
    for cam in rig:
        for _ in range(3):
            n = rng.normal(size=3)
            n[2] *= 0.1  # vertical-ish planes, as in the paper
            plane = Plane(rng.uniform(-2, 2, 3) * [1, 1, 0], n)
            v = cam.rays(cam.project(X_true))  # Eq. 5-6, through raw (distorted) pixels
            X, status = intersect_rays_plane(cam.centre, v, plane)
            assert X.shape == (50, 3) and status.shape == (50,) and status.dtype == np.int8
            literal = np.array([eq7_literal(cam.centre, vi, plane.normal, plane.point) for vi in v])
            ok = status == OK
            np.testing.assert_allclose(X[ok], literal[ok], rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(plane.signed_distance(X[ok]), 0.0, atol=1e-9)
            # OK exactly where Eq. 7's ray parameter is positive
            lam = (plane.point - cam.centre) @ plane.normal / (v @ plane.normal)
            np.testing.assert_array_equal(ok, lam > 0)
            np.testing.assert_array_equal(status[~ok], BEHIND)
            assert np.all(np.isnan(X[~ok]))


def test_a_point_on_the_plane_is_recovered_from_its_pixel(rng):
    """The ray-plane fallback inverts projection for a point that lies on the plane."""
    for ncoef in (None, 5, 8):
        cam = random_camera(rng, distortion=ncoef)
        X_true = random_points(rng, 40)
        X_true[:, 1] = 0.3  # all on the plane y = 0.3
        X_true = X_true[cam.in_image(cam.project(X_true))]
        X, status = intersect_rays_plane(cam.centre, cam.rays(cam.project(X_true)), Plane([0, 0.3, 0], [0, 1, 0]))
        assert np.all(status == OK)
        np.testing.assert_allclose(X, X_true, atol=1e-6)


def test_normal_sign_and_direction_length_do_not_matter(rng):
    origins = rng.uniform(-10, 10, size=(30, 3))
    dirs = rng.normal(size=(30, 3))
    p = Plane([0.5, 1.0, -0.2], [0.3, -0.9, 0.1])
    q = Plane(p.point, -p.normal)
    X1, s1 = intersect_rays_plane(origins, dirs, p)
    X2, s2 = intersect_rays_plane(origins, dirs, q)
    X3, s3 = intersect_rays_plane(origins, 7.5 * dirs, p)
    np.testing.assert_array_equal(s1, s2)
    np.testing.assert_array_equal(s1, s3)
    np.testing.assert_allclose(X1, X2, equal_nan=True, atol=1e-9)
    np.testing.assert_allclose(X1, X3, equal_nan=True, atol=1e-9)
    assert (s1 == OK).any() and (s1 == BEHIND).any()  # random rays exercise both outcomes


def test_parallel_rays_give_nan_and_parallel_status():
    wall = Plane([5.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    origins = np.zeros((4, 3))
    dirs = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1e-5, 1.0, 0.0], [1.0, 1.0, 0.0]])
    X, status = intersect_rays_plane(origins, dirs, wall)
    np.testing.assert_array_equal(status, [PARALLEL, PARALLEL, PARALLEL, OK])
    assert np.all(np.isnan(X[:3]))
    np.testing.assert_allclose(X[3], [5.0, 5.0, 0.0])
    # the tolerance is configurable: a grazing ray at ~0.06 degrees passes with a smaller one
    X, status = intersect_rays_plane(origins[2], dirs[2], wall, min_cos=1e-7)
    assert status == OK and np.isclose(X[0], 5.0)
    # a ray lying in the plane is parallel too (not "anywhere")
    X, status = intersect_rays_plane(np.array([5.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), wall)
    assert status == PARALLEL and np.isnan(X).all()


def test_degenerate_rays_are_reported_quietly():
    """Exactly parallel, zero-length and NaN directions: a status, NaN, and no RuntimeWarning."""
    wall = Plane([5.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    dirs = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [np.nan, 0.0, 0.0], [1.0, 0.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        X, status = intersect_rays_plane(np.zeros(3), dirs, wall)
    np.testing.assert_array_equal(status, [PARALLEL, PARALLEL, PARALLEL, OK])
    assert np.isnan(X[:3]).all() and np.isfinite(X[3]).all()
    # the contract: X is NaN exactly where the status is not OK
    np.testing.assert_array_equal(np.isnan(X).any(-1), status != OK)


def test_plane_behind_the_camera_gives_nan_and_behind_status(rng):
    cam = random_camera(rng)
    # the plane through a point 5 m behind the camera, facing along the optical axis
    behind = Plane(cam.centre - 5 * cam.optical_axis, cam.optical_axis)
    ahead = Plane(cam.centre + 5 * cam.optical_axis, cam.optical_axis)
    uv = rng.uniform([0, 0], cam.size, size=(20, 2))
    v = cam.rays(uv)
    X, status = intersect_rays_plane(cam.centre, v, behind)
    assert np.all(status == BEHIND) and np.all(np.isnan(X))
    X, status = intersect_rays_plane(cam.centre, v, ahead)
    assert np.all(status == OK)
    np.testing.assert_allclose(cam.depth(X), 5.0, atol=1e-9)


def test_broadcasting_origins_and_directions(rng):
    plane = Plane([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    origins = np.array([[0.0, 0.0, 3.0], [1.0, 1.0, 2.0]])[:, None, :]  # (2, 1, 3)
    dirs = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 1.0, 1.0]])[None]  # (1, 3, 3)
    X, status = intersect_rays_plane(origins, dirs, plane)
    assert X.shape == (2, 3, 3) and status.shape == (2, 3)
    np.testing.assert_array_equal(status, [[OK, OK, BEHIND], [OK, OK, BEHIND]])
    np.testing.assert_allclose(X[:, :2], [[[0, 0, 0], [3, 0, 0]], [[1, 1, 0], [3, 1, 0]]], atol=1e-15)


@given(
    origin=st.tuples(*[st.floats(-20, 20)] * 3),
    direction=st.tuples(*[st.floats(-1, 1)] * 3),
    normal=st.tuples(*[st.floats(-1, 1)] * 3),
    point=st.tuples(*[st.floats(-5, 5)] * 3),
)
@settings(max_examples=100, deadline=None)
def test_eq7_hypothesis(origin, direction, normal, point):
    o, d, n = np.array(origin), np.array(direction), np.array(normal)
    if np.linalg.norm(n) < 1e-3 or np.linalg.norm(d) < 1e-3:
        return
    plane = Plane(point, n)
    X, status = intersect_rays_plane(o, d, plane)
    cos = abs(d @ plane.normal) / np.linalg.norm(d)
    if cos < 1e-3:
        assert status == PARALLEL and np.isnan(X).all()
        return
    lam = (plane.point - o) @ plane.normal / (d @ plane.normal)
    if lam > 0:
        assert status == OK
        np.testing.assert_allclose(X, eq7_literal(o, d, plane.normal, plane.point), rtol=1e-9, atol=1e-9)
        assert abs(plane.signed_distance(X)) < 1e-6 * max(1.0, np.abs(X).max())
    else:
        assert status == BEHIND and np.isnan(X).all()


def test_plane_validation_and_helpers():
    with pytest.raises(ValueError, match="normal"):
        Plane([0, 0, 0], [0, 0, 0])
    with pytest.raises(ValueError):
        Plane([np.nan, 0, 0], [1, 0, 0])
    p = Plane([1.0, 0.0, 0.0], [2.0, 0.0, 0.0])
    np.testing.assert_allclose(p.signed_distance(np.array([[3.0, 5, 1], [0, 0, 0]])), [2.0, -1.0])
    np.testing.assert_allclose(p.project(np.array([3.0, 5.0, 1.0])), [1.0, 5.0, 1.0])
