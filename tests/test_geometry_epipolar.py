"""Epipolar geometry and the box distance of paper Eq. 1, checked against OpenCV and by hand."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gymtrack.geometry import (
    Camera,
    epipolar_distance,
    epipolar_lines,
    fundamental_matrices,
    fundamental_matrix,
    point_line_distance,
)

from conftest import SIZE, points_seen_by, random_camera, random_points, random_rig


# pixels from image-normalised coordinates: conditions F so every entry matters in comparisons
# (in pixel units F[2, 2] dominates and entries of 1e-8 would hide below any tolerance)
T_PIX = np.array([[1000.0, 0.0, 960.0], [0.0, 1000.0, 540.0], [0.0, 0.0, 1.0]])


def same_up_to_scale(A: np.ndarray, B: np.ndarray) -> float:
    """Max difference of two fundamental matrices, conditioned, scaled to unit Frobenius norm,
    minimised over the sign."""
    A = T_PIX.T @ A @ T_PIX
    B = T_PIX.T @ B @ T_PIX
    A = A / np.linalg.norm(A)
    B = B / np.linalg.norm(B)
    return min(np.abs(A - B).max(), np.abs(A + B).max())


def algebraic(F: np.ndarray, xi: np.ndarray, xj: np.ndarray) -> np.ndarray:
    """``x_j^T F x_i`` for (N, 2) pixels."""
    hi = np.hstack([xi, np.ones((len(xi), 1))])
    hj = np.hstack([xj, np.ones((len(xj), 1))])
    return np.einsum("ni,ij,nj->n", hj, F, hi)


def pair(rng, distortion=None):
    rig = random_rig(rng, 2, distortion)
    X = points_seen_by(rng, rig, 60)
    return rig[0], rig[1], X


def boxes_at(xy: np.ndarray, rng, lo=40.0, hi=300.0) -> np.ndarray:
    """(N, 4) centre-form boxes centred at (N, 2) points with random sizes."""
    wh = rng.uniform(lo, hi, size=(len(xy), 2))
    return np.hstack([xy, wh])


# --------------------------------------------------------------------------- F
def test_true_correspondences_satisfy_the_epipolar_constraint(rng):
    for _ in range(5):
        ci, cj, X = pair(rng, distortion=5)
        F = fundamental_matrix(ci, cj)
        assert np.isclose(np.linalg.norm(F), 1.0)
        assert abs(np.linalg.det(F)) < 1e-12 and np.linalg.matrix_rank(F, tol=1e-9) == 2
        xi, xj = ci.project(X, distort=False), cj.project(X, distort=False)
        # algebraically, relative to the size of the homogeneous pixel vectors (F has unit norm)
        scale = np.linalg.norm(np.hstack([xi, np.ones((len(xi), 1))]), axis=1) * np.linalg.norm(np.hstack([xj, np.ones((len(xj), 1))]), axis=1)
        assert np.abs(algebraic(F, xi, xj) / scale).max() < 1e-12
        # in pixels: distance of x_j to the epipolar line of x_i (and back) is ~0
        np.testing.assert_allclose(point_line_distance(xj, epipolar_lines(F, xi)), 0.0, atol=1e-6)
        np.testing.assert_allclose(point_line_distance(xi, epipolar_lines(F.T, xj)), 0.0, atol=1e-6)
        # and the constraint is not trivially satisfied by unrelated points
        other = cj.project(random_points(rng, 60), distort=False)
        assert np.median(point_line_distance(other, epipolar_lines(F, xi))) > 5.0


@given(seed=st.integers(0, 2**32 - 1))
@settings(max_examples=30, deadline=None)
def test_epipolar_constraint_hypothesis(seed):
    rng = np.random.default_rng(seed)
    ci, cj = random_camera(rng, "a"), random_camera(rng, "b")
    X = random_points(rng, 10)
    ok = (ci.depth(X) > 0.1) & (cj.depth(X) > 0.1)
    F = fundamental_matrix(ci, cj)
    xi, xj = ci.project(X[ok], distort=False), cj.project(X[ok], distort=False)
    assert np.all(point_line_distance(xj, epipolar_lines(F, xi)) < 1e-5)


def test_F_matches_opencv_findFundamentalMat(rng):
    for _ in range(5):
        ci, cj, X = pair(rng, distortion=8)
        xi, xj = ci.project(X, distort=False), cj.project(X, distort=False)
        F_cv, _ = cv2.findFundamentalMat(xi, xj, cv2.FM_8POINT)  # OpenCV: x2^T F x1 = 0
        assert F_cv.shape == (3, 3)
        assert same_up_to_scale(fundamental_matrix(ci, cj), F_cv) < 1e-6
        # the other order is the transpose (that it is not the same matrix is checked in pixels
        # by test_swapping_the_cameras_breaks_the_constraint_unless_transposed)
        assert same_up_to_scale(fundamental_matrix(cj, ci), F_cv.T) < 1e-6


@pytest.mark.parametrize("which", [1, 2])
def test_epipolar_lines_match_opencv_computeCorrespondEpilines(rng, which):
    for _ in range(4):
        ci, cj, X = pair(rng)
        F = fundamental_matrix(ci, cj)
        src = (ci if which == 1 else cj).project(X, distort=False)
        ref = cv2.computeCorrespondEpilines(src.reshape(-1, 1, 2), which, F).reshape(-1, 3)
        # whichImage=1: lines in image 2 of points of image 1 (F x); 2: lines in image 1 (F^T x)
        ours = epipolar_lines(F if which == 1 else F.T, src)
        np.testing.assert_allclose(np.hypot(ours[:, 0], ours[:, 1]), 1.0)
        np.testing.assert_allclose(ours, ref, atol=1e-7)


def test_epipolar_lines_pass_through_the_epipole(rng):
    ci, cj, X = pair(rng)
    F = fundamental_matrix(ci, cj)
    e_j = cj.P @ np.append(ci.centre, 1.0)  # image of camera i's centre in view j (homogeneous)
    lines = epipolar_lines(F, ci.project(X, distort=False))
    np.testing.assert_allclose(lines @ e_j / np.linalg.norm(e_j), 0.0, atol=1e-9)


def test_fundamental_matrices_of_a_rig(rng):
    rig = random_rig(rng, 4)
    Fs = fundamental_matrices(rig)
    assert Fs.shape == (4, 4, 3, 3)
    for i in range(4):
        np.testing.assert_array_equal(Fs[i, i], 0.0)
        for j in range(4):
            if i != j:
                assert same_up_to_scale(Fs[i, j], fundamental_matrix(rig[i], rig[j])) < 1e-12
                np.testing.assert_allclose(Fs[j, i], Fs[i, j].T)


def test_swapping_the_cameras_breaks_the_constraint_unless_transposed(rng):
    """Guards ``x_j^T F(cam_i, cam_j) x_i = 0``: F(cam_j, cam_i) is its transpose, not itself."""
    for _ in range(4):
        ci, cj, X = pair(rng)
        xi, xj = ci.project(X, distort=False), cj.project(X, distort=False)
        F_wrong = fundamental_matrix(cj, ci)
        d_wrong = point_line_distance(xj, epipolar_lines(F_wrong, xi))
        assert np.median(d_wrong) > 5.0  # pixels
        np.testing.assert_allclose(point_line_distance(xj, epipolar_lines(F_wrong.T, xi)), 0.0, atol=1e-6)
        F = fundamental_matrix(ci, cj)
        h = np.abs(algebraic(F, xi, xj)).max()
        assert np.abs(algebraic(F_wrong, xi, xj)).max() > 1e3 * max(h, 1e-12)


def test_distorted_pixels_do_not_satisfy_the_constraint_but_undistorted_do(rng):
    """F relates undistorted pixels: raw pixels of a distorted lens must be undistorted first."""
    ci, cj, X = pair(rng, distortion=5)
    F = fundamental_matrix(ci, cj)
    raw_i, raw_j = ci.project(X), cj.project(X)
    d_raw = point_line_distance(raw_j, epipolar_lines(F, raw_i))
    d_und = point_line_distance(cj.undistort(raw_j), epipolar_lines(F, ci.undistort(raw_i)))
    assert d_raw.max() > 1.0
    np.testing.assert_allclose(d_und, 0.0, atol=1e-5)


# --------------------------------------------------------------------------- point-line distance
def test_point_line_distance_by_hand():
    # the vertical line x = 5, written unnormalised: 2x + 0y - 10 = 0
    np.testing.assert_allclose(point_line_distance(np.array([[8.0, 2.0], [5.0, -7.0], [1.0, 0.0]]), np.array([2.0, 0.0, -10.0])), [3, 0, 4])
    # the line x + y = 0 and the point (1, 1): sqrt(2)
    assert np.isclose(point_line_distance(np.array([1.0, 1.0]), np.array([1.0, 1.0, 0.0])), np.sqrt(2))


# --------------------------------------------------------------------------- Eq. 1
def rectified_pair(baseline: float = 1.0):
    """Two identical cameras, the second translated along the camera x axis (a rectified pair)."""
    K = np.array([[1000.0, 0.0, 960.0], [0.0, 1000.0, 540.0], [0.0, 0.0, 1.0]])
    ci = Camera("i", SIZE, K, np.eye(3), np.zeros(3))
    cj = Camera("j", SIZE, K, np.eye(3), np.array([-baseline, 0.0, 0.0]))  # centre at (baseline, 0, 0)
    return ci, cj


def test_rectified_pair_has_horizontal_epipolar_lines():
    ci, cj = rectified_pair()
    F = fundamental_matrix(ci, cj)
    # F is proportional to [[0, 0, 0], [0, 0, -1], [0, 1, 0]]: the line of (x, y) is v = y
    assert same_up_to_scale(F, np.array([[0.0, 0, 0], [0, 0, -1], [0, 1, 0]])) < 1e-12
    pts = np.array([[100.0, 200.0], [1500.0, 900.0]])
    lines = epipolar_lines(F, pts)
    np.testing.assert_allclose(lines[:, 0], 0.0, atol=1e-15)  # no u term: horizontal
    np.testing.assert_allclose(-lines[:, 2] / lines[:, 1], pts[:, 1])


def test_epipolar_distance_hand_worked_on_a_rectified_pair():
    """Eq. 1 by hand. Lines are horizontal, so each term is |y_i - y_j| / (w + h) of its box.

    box_i = (100, 200, 50, 150): line of x_j in view i is y = 230, distance 30, scale 200 -> 0.15
    box_j = (400, 230, 40, 60):  line of x_i in view j is y = 200, distance 30, scale 100 -> 0.30
    d = 0.45 (the x positions do not matter on a rectified pair)
    """
    F = fundamental_matrix(*rectified_pair())
    box_i = np.array([100.0, 200.0, 50.0, 150.0])
    box_j = np.array([400.0, 230.0, 40.0, 60.0])
    assert np.isclose(epipolar_distance(box_i, box_j, F), 0.15 + 0.30)
    # sliding box_j along its (horizontal) epipolar line changes nothing
    assert np.isclose(epipolar_distance(box_i, box_j + [700.0, 0, 0, 0], F), 0.45)
    # same row: zero
    assert np.isclose(epipolar_distance(box_i, np.array([1200.0, 200.0, 10.0, 10.0]), F), 0.0)


def test_epipolar_distance_is_zero_for_true_correspondences(rng):
    for _ in range(4):
        ci, cj, X = pair(rng)
        F = fundamental_matrix(ci, cj)
        bi = boxes_at(ci.project(X, distort=False), rng)
        bj = boxes_at(cj.project(X, distort=False), rng)
        d = epipolar_distance(bi, bj, F)
        assert d.shape == (len(X),)
        np.testing.assert_allclose(d, 0.0, atol=1e-8)
        # the same boxes paired with a different person are far (with the paper's 0.3 scale)
        d_wrong = epipolar_distance(bi, np.roll(bj, 1, axis=0), F)
        assert np.median(d_wrong) > 0.05


def test_epipolar_distance_is_symmetric_under_swapping(rng):
    ci, cj, X = pair(rng)
    F = fundamental_matrix(ci, cj)
    bi = boxes_at(ci.project(X, distort=False) + rng.normal(0, 15, (len(X), 2)), rng)
    bj = boxes_at(cj.project(X, distort=False) + rng.normal(0, 15, (len(X), 2)), rng)
    d = epipolar_distance(bi, bj, F)
    assert np.all(d > 0)
    np.testing.assert_allclose(epipolar_distance(bj, bi, F.T), d, rtol=1e-12)
    np.testing.assert_allclose(epipolar_distance(bj, bi, fundamental_matrix(cj, ci)), d, rtol=1e-9)


def test_epipolar_distance_is_normalised_by_box_scale(rng):
    ci, cj, X = pair(rng)
    F = fundamental_matrix(ci, cj)
    bi = boxes_at(ci.project(X, distort=False) + rng.normal(0, 10, (len(X), 2)), rng)
    bj = boxes_at(cj.project(X, distort=False) + rng.normal(0, 10, (len(X), 2)), rng)
    d = epipolar_distance(bi, bj, F)
    grow = np.array([1.0, 1.0, 2.0, 2.0])
    np.testing.assert_allclose(epipolar_distance(bi * grow, bj * grow, F), d / 2, rtol=1e-12)
    # doubling one box halves only its own term
    d_i = point_line_distance(bi[:, :2], epipolar_lines(F.T, bj[:, :2])) / (bi[:, 2] + bi[:, 3])
    d_j = point_line_distance(bj[:, :2], epipolar_lines(F, bi[:, :2])) / (bj[:, 2] + bj[:, 3])
    np.testing.assert_allclose(d, d_i + d_j, rtol=1e-12)
    np.testing.assert_allclose(epipolar_distance(bi * grow, bj, F), d_i / 2 + d_j, rtol=1e-12)
    # the scale is |w + h|, not w * h or max(w, h): a 30x10 box weighs like a 20x20 box
    b_a = bi.copy()
    b_a[:, 2:] = [30.0, 10.0]
    b_b = bi.copy()
    b_b[:, 2:] = [20.0, 20.0]
    np.testing.assert_allclose(epipolar_distance(b_a, bj, F), epipolar_distance(b_b, bj, F), rtol=1e-12)


def test_epipolar_distance_broadcasts_like_the_loop(rng):
    ci, cj = random_rig(rng, 2)
    Xi, Xj = points_seen_by(rng, [ci, cj], 7), points_seen_by(rng, [ci, cj], 5)
    F = fundamental_matrix(ci, cj)
    bi = boxes_at(ci.project(Xi, distort=False), rng)
    bj = boxes_at(cj.project(Xj, distort=False), rng)
    D = epipolar_distance(bi[:, None, :], bj[None, :, :], F)
    assert D.shape == (7, 5)
    loop = np.array([[float(epipolar_distance(a, b, F)) for b in bj] for a in bi])
    np.testing.assert_allclose(D, loop, rtol=1e-12)
    # a stack of F matrices broadcasts too: (P, 3, 3) with (P, 4) boxes
    rig = random_rig(rng, 3)
    Fs = fundamental_matrices(rig)
    pairs = [(0, 1), (1, 2), (2, 0)]
    X = points_seen_by(rng, rig, 3)
    b_i = np.stack([boxes_at(rig[i].project(X[[k]], distort=False), rng)[0] for k, (i, _) in enumerate(pairs)])
    b_j = np.stack([boxes_at(rig[j].project(X[[k]], distort=False), rng)[0] for k, (_, j) in enumerate(pairs)])
    F_stack = np.stack([Fs[i, j] for i, j in pairs])
    np.testing.assert_allclose(epipolar_distance(b_i, b_j, F_stack), 0.0, atol=1e-8)
    shuffled = epipolar_distance(b_i, b_j, F_stack[[1, 2, 0]])
    assert np.all(shuffled > 1e-3)
