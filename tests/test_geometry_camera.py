"""Camera: projection against OpenCV, undistortion round trip, rays (Eq. 5-6), validation."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gymtrack.errors import CalibrationError
from gymtrack.geometry import Camera, Rig

from conftest import SIZE, look_at, radial_is_monotonic, random_camera, random_points

HYP = settings(max_examples=40, deadline=None)


def cv2_project(cam: Camera, X: np.ndarray) -> np.ndarray:
    # OpenCV takes the 3x3 matrix in place of an rvec: the reference does not depend on Camera.rvec
    uv, _ = cv2.projectPoints(X.reshape(-1, 1, 3), cam.R, cam.t, cam.K, cam.dist)
    return uv.reshape(-1, 2)


# --------------------------------------------------------------------------- projection
@pytest.mark.parametrize("ncoef", [None, 4, 5, 8])
def test_project_matches_opencv_on_random_cameras(rng, ncoef):
    for k in range(10):
        cam = random_camera(rng, f"c{k}", distortion=ncoef)
        X = random_points(rng, 200)
        assert np.all(cam.depth(X) > 0)
        uv = cam.project(X)
        np.testing.assert_allclose(uv, cv2_project(cam, X), rtol=1e-10, atol=1e-7)
        # and they really are in the image for most points (realistic cameras)
        assert cam.in_image(uv).mean() > 0.5


@given(
    rvec=st.tuples(*[st.floats(-1.8, 1.8)] * 3),
    xyz=st.tuples(st.floats(-0.6, 0.6), st.floats(-0.4, 0.4), st.floats(2.0, 30.0)),
    f=st.floats(300.0, 3000.0),
    dist=st.tuples(
        st.floats(-0.3, 0.3), st.floats(-0.1, 0.1), st.floats(-2e-3, 2e-3), st.floats(-2e-3, 2e-3),
        st.floats(-0.05, 0.05), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1),
    ),
    ncoef=st.sampled_from([5, 8]),
)
@HYP
def test_project_matches_opencv_hypothesis(rvec, xyz, f, dist, ncoef):
    """Any rotation (via rvec), any translation, 5 or 8 coefficients: same pixels as OpenCV."""
    R = cv2.Rodrigues(np.array(rvec, float))[0]
    # a camera whose optical axis passes near the world point xyz-scaled, 3 points in front
    t = np.array([0.1, -0.2, 0.3])
    cam = Camera("h", SIZE, [[f, 0, 960], [0, f, 540], [0, 0, 1]], R, t, np.array(dist[:ncoef]))
    Xc = np.array([[xyz[0] * xyz[2], xyz[1] * xyz[2], xyz[2]], [0.0, 0.0, 5.0], [-0.3, 0.2, 1.0]])
    X = (Xc - t) @ R  # camera frame -> world frame
    np.testing.assert_allclose(cam.depth(X), Xc[:, 2], atol=1e-9)
    np.testing.assert_allclose(cam.project(X), cv2_project(cam, X), rtol=1e-10, atol=1e-7)


def test_points_behind_or_on_the_camera_plane_give_nan(rng):
    cam = random_camera(rng, distortion=5)
    C, axis = cam.centre, cam.optical_axis
    side = cam.R[0]  # camera x axis, in the camera plane
    X = np.stack([C + 3 * axis, C - 3 * axis, C - 0.5 * axis + 2 * side, C + 2 * side, C + 1e-3 * axis])
    uv = cam.project(X)
    assert uv.shape == (5, 2)
    assert np.all(np.isfinite(uv[[0, 4]]))
    assert np.all(np.isnan(uv[[1, 2, 3]]))  # behind, behind off-axis, on the camera plane
    # the point straight ahead lands on the principal point (undistorted) / distorted point of r=0
    np.testing.assert_allclose(cam.project(X[0], distort=False), cam.K[:2, 2], atol=1e-9)


def test_project_keeps_leading_shape(rng):
    cam = random_camera(rng, distortion=8)
    X = random_points(rng, 24).reshape(2, 3, 4, 3)
    uv = cam.project(X)
    assert uv.shape == (2, 3, 4, 2)
    np.testing.assert_allclose(uv.reshape(-1, 2), cam.project(X.reshape(-1, 3)))
    assert cam.project(X[0, 0, 0]).shape == (2,)


def test_P_centre_depth_rvec_are_consistent(rng):
    cam = random_camera(rng, distortion=5)
    X = random_points(rng, 50)
    Xh = np.hstack([X, np.ones((50, 1))])
    x = Xh @ cam.P.T
    np.testing.assert_allclose(x[:, :2] / x[:, 2:], cam.project(X, distort=False), atol=1e-8)
    np.testing.assert_allclose(x[:, 2], cam.depth(X), rtol=1e-12)  # K's last row is [0, 0, 1]
    np.testing.assert_allclose(cam.P @ np.append(cam.centre, 1.0), 0.0, atol=1e-8)  # centre is P's null space
    np.testing.assert_allclose(cv2.Rodrigues(cam.rvec)[0], cam.R, atol=1e-12)


@pytest.mark.parametrize("angle", [1e-7, 1e-5, 0.3, 2.0, np.pi - 1e-6])
def test_rvec_round_trips_small_and_large_rotations(angle):
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    R = cv2.Rodrigues(angle * axis)[0]
    cam = Camera("r", SIZE, np.diag([1000.0, 1000.0, 1.0]), R, np.zeros(3))
    np.testing.assert_allclose(cv2.Rodrigues(cam.rvec)[0], R, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(cam.rvec), angle, rtol=1e-6)
    np.testing.assert_allclose(cam.optical_axis, cam.R.T @ [0, 0, 1])
    np.testing.assert_allclose(cam.depth(cam.centre + 2.5 * cam.optical_axis), 2.5)


def test_look_at_camera_sees_its_target_at_the_principal_point():
    """A hand-placed camera: at (10, 0, 3) looking at (0, 0, 1), no roll."""
    R, t = look_at(np.array([10.0, 0.0, 3.0]), np.array([0.0, 0.0, 1.0]))
    cam = Camera("a", SIZE, [[1000, 0, 960], [0, 1000, 540], [0, 0, 1]], R, t)
    np.testing.assert_allclose(cam.centre, [10, 0, 3], atol=1e-12)
    np.testing.assert_allclose(cam.project([0.0, 0.0, 1.0]), [960, 540], atol=1e-9)
    # facing -x with z up, world +y is on the camera's right (forward x up = +y): u increases.
    # World up is image up: v decreases.
    u0, v0 = cam.project([0.0, 0.0, 1.0])
    assert cam.project([0.0, 1.0, 1.0])[0] > u0 + 50
    assert cam.project([0.0, 0.0, 2.0])[1] < v0 - 50


def test_in_image(rng):
    cam = random_camera(rng)
    uv = np.array([[0, 0], [1920, 1080], [-1, 5], [5, 1081], [960, 540]])
    np.testing.assert_array_equal(cam.in_image(uv), [True, True, False, False, True])
    np.testing.assert_array_equal(cam.in_image(uv, margin=2), [True] * 5)


# --------------------------------------------------------------------------- undistortion
def image_grid(n: int = 25) -> np.ndarray:
    """(n*n, 2) raw pixels covering the whole image, corners included."""
    u, v = np.meshgrid(np.linspace(0, SIZE[0], n), np.linspace(0, SIZE[1], n))
    return np.stack([u.ravel(), v.ravel()], axis=-1)


@pytest.mark.parametrize("ncoef", [4, 5, 8])
def test_undistort_inverts_project_across_the_image(rng, ncoef):
    for k in range(8):
        cam = random_camera(rng, f"c{k}", distortion=ncoef)
        assert cam.has_distortion
        # world points whose raw pixels cover the whole image, corners included: back-project
        # the raw grid with the camera's own ideal model (independent of the code under test)
        grid = image_grid()
        ideal = cv2.undistortPointsIter(
            grid.reshape(-1, 1, 2), cam.K, cam.dist, None, cam.K, (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-14)
        ).reshape(-1, 2)
        # the raw grid is reproduced by distorting the ideal points: OpenCV's inverse converged
        np.testing.assert_allclose(cv2_project_normalised(cam, ideal), grid, atol=1e-6)
        rays = np.linalg.solve(cam.K, np.hstack([ideal, np.ones((len(ideal), 1))]).T).T @ cam.R
        X = cam.centre + rng.uniform(3, 20, size=(len(rays), 1)) * rays
        raw = cam.project(X)
        np.testing.assert_allclose(raw, grid, atol=1e-6)
        np.testing.assert_allclose(cam.undistort(raw), cam.project(X, distort=False), atol=1e-6)
        # the distortion is not negligible: the corners move by pixels
        assert np.abs(raw - cam.project(X, distort=False)).max() > 2.0


def cv2_project_normalised(cam: Camera, ideal_px: np.ndarray) -> np.ndarray:
    """Distort ideal (undistorted) pixels with OpenCV: through normalised coordinates."""
    xn = np.linalg.solve(cam.K, np.hstack([ideal_px, np.ones((len(ideal_px), 1))]).T).T
    uv, _ = cv2.projectPoints(xn.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), cam.K, cam.dist)
    return uv.reshape(-1, 2)


def test_undistort_round_trip_on_random_points(rng):
    for k in range(8):
        cam = random_camera(rng, f"c{k}", distortion=(5, 8)[k % 2])
        X = random_points(rng, 300)
        X = X[cam.in_image(cam.project(X))]
        np.testing.assert_allclose(cam.undistort(cam.project(X)), cam.project(X, distort=False), atol=1e-6)


def test_undistort_without_distortion_is_identity_and_keeps_nan(rng):
    cam = random_camera(rng)
    assert not cam.has_distortion
    uv = rng.uniform(-100, 2000, size=(7, 3, 2))
    out = cam.undistort(uv)
    assert out.shape == uv.shape and out is not uv
    np.testing.assert_array_equal(out, uv)
    cam_d = random_camera(rng, distortion=5)
    uv[1, 2] = np.nan
    out = cam_d.undistort(uv)
    assert out.shape == uv.shape
    assert np.all(np.isnan(out[1, 2])) and np.isfinite(np.delete(out.reshape(-1, 2), 5, axis=0)).all()
    assert cam_d.undistort(np.zeros((0, 2))).shape == (0, 2)


def test_conftest_distortions_are_monotonic_and_realistic(rng):
    """Guard for the fixtures themselves: the drawn lenses are invertible and not trivial."""
    for ncoef in (5, 8):
        cam = random_camera(rng, distortion=ncoef)
        assert radial_is_monotonic(cam.dist, 1.2)
        assert np.abs(cam.dist[:2]).max() > 0


# --------------------------------------------------------------------------- rays (Eq. 5-6)
def distance_to_ray(X: np.ndarray, origin: np.ndarray, d: np.ndarray) -> np.ndarray:
    v = X - origin
    return np.linalg.norm(v - np.sum(v * d, axis=-1, keepdims=True) * d, axis=-1)


@pytest.mark.parametrize("ncoef", [None, 5, 8])
def test_ray_through_projection_passes_through_the_point(rng, ncoef):
    for k in range(6):
        cam = random_camera(rng, f"c{k}", distortion=ncoef)
        X = random_points(rng, 200)
        X = X[cam.in_image(cam.project(X))]
        d = cam.rays(cam.project(X))
        assert d.shape == X.shape
        np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-12)
        assert np.all(np.sum(d * (X - cam.centre), axis=-1) > 0)  # forward, towards X
        np.testing.assert_allclose(distance_to_ray(X, cam.centre, d), 0.0, atol=1e-7)  # metres at <= 20 m
        # the unit ray is the normalised direction to X
        np.testing.assert_allclose(d, (X - cam.centre) / np.linalg.norm(X - cam.centre, axis=-1, keepdims=True), atol=1e-8)
        # ideal pixels with undistort=False give the same rays
        np.testing.assert_allclose(cam.rays(cam.project(X, distort=False), undistort=False), d, atol=1e-8)


def test_ray_is_the_paper_eq6_row_vector_times_R(rng):
    """Eq. 5-6 written literally (zero skew): [(x-cx)/fx, (y-cy)/fy, 1] R, then normalised."""
    cam = random_camera(rng)
    uv = rng.uniform([0, 0], SIZE, size=(50, 2))
    K = cam.K
    v_cam = np.stack([(uv[:, 0] - K[0, 2]) / K[0, 0], (uv[:, 1] - K[1, 2]) / K[1, 1], np.ones(50)], axis=-1)
    v_w = np.stack([row @ cam.R for row in v_cam])
    np.testing.assert_allclose(cam.rays(uv), v_w / np.linalg.norm(v_w, axis=1, keepdims=True), atol=1e-12)
    # the principal point's ray is the optical axis
    np.testing.assert_allclose(cam.rays(K[:2, 2]), cam.optical_axis, atol=1e-12)


@given(seed=st.integers(0, 2**32 - 1), ncoef=st.sampled_from([None, 5, 8]))
@settings(max_examples=30, deadline=None)
def test_rays_hypothesis(seed, ncoef):
    rng = np.random.default_rng(seed)
    cam = random_camera(rng, distortion=ncoef)
    X = random_points(rng, 20)
    X = X[cam.in_image(cam.project(X))]
    d = cam.rays(cam.project(X))
    assert np.allclose(distance_to_ray(X, cam.centre, d), 0.0, atol=1e-7)
    assert np.all(np.sum(d * (X - cam.centre), axis=-1) > 0)


# --------------------------------------------------------------------------- conventions
def test_swapping_R_for_its_transpose_breaks_projection(rng):
    """Guards the world-to-camera convention: R.T (camera-to-world) in place of R is wrong."""
    tested = 0
    while tested < 5:
        cam = random_camera(rng, distortion=5)
        # look-at cameras often rotate by nearly 180 degrees, where R.T ~ R and the swap is
        # invisible; only test clearly non-symmetric rotations
        if np.abs(cam.R - cam.R.T).max() < 0.5:
            continue
        tested += 1
        wrong = Camera("wrong", cam.size, cam.K, cam.R.T, cam.t, cam.dist)
        X = random_points(rng, 100)
        err = np.linalg.norm(wrong.project(X) - cam.project(X), axis=-1)
        err = np.where(np.isnan(err), np.inf, err)  # behind the wrong camera counts as wrong
        assert np.median(err) > 100.0


def test_using_the_camera_centre_as_t_breaks_projection(rng):
    """t is not the camera position: C = -R.T t."""
    cam = random_camera(rng)
    wrong = Camera("wrong", cam.size, cam.K, cam.R, cam.centre)
    X = random_points(rng, 100)
    err = np.linalg.norm(wrong.project(X) - cam.project(X), axis=-1)
    assert np.median(np.where(np.isnan(err), np.inf, err)) > 100.0


# --------------------------------------------------------------------------- validation
def good_kwargs():
    R, t = look_at(np.array([10.0, 2.0, 4.0]), np.zeros(3))
    return dict(name="cam7", size=(1920, 1080), K=np.array([[1500.0, 0, 960], [0, 1500, 540], [0, 0, 1]]), R=R, t=t, dist=np.zeros(5))


def _bad(**changes):
    kw = good_kwargs()
    kw.update(changes)
    return kw


def _reflect(R):
    R = R.copy()
    R[1] *= -1
    return R


def _nan_at(a, idx):
    a = np.array(a, dtype=float)
    a[idx] = np.nan
    return a


BAD_CAMERAS = {
    "scaled rotation": (lambda kw: _bad(R=1.1 * kw["R"]), "cam7.R", "not a rotation"),
    "reflection": (lambda kw: _bad(R=_reflect(kw["R"])), "cam7.R", "reflection"),
    "shear": (lambda kw: _bad(R=kw["R"] + np.triu(np.full((3, 3), 0.05), 1)), "cam7.R", "rotation"),
    "R wrong shape": (lambda kw: _bad(R=np.eye(3)[:2]), "cam7.R", "shape"),
    "R NaN": (lambda kw: _bad(R=_nan_at(kw["R"], (0, 0))), "cam7.R", "NaN"),
    "R not numeric": (lambda kw: _bad(R=[["a", 0, 0], [0, 1, 0], [0, 0, 1]]), "cam7.R", "numeric"),
    "K singular": (lambda kw: _bad(K=np.array([[0.0, 0, 960], [0, 1500, 540], [0, 0, 1]])), "cam7.K", "fx"),
    "K negative focal": (lambda kw: _bad(K=np.array([[1500.0, 0, 960], [0, -1500, 540], [0, 0, 1]])), "cam7.K", "fy"),
    "K bad last row": (lambda kw: _bad(K=np.array([[1500.0, 0, 960], [0, 1500, 540], [0, 0, 0]])), "cam7.K", "last row"),
    "K wrong shape": (lambda kw: _bad(K=np.eye(4)), "cam7.K", "shape"),
    "K infinite": (lambda kw: _bad(K=np.array([[np.inf, 0, 960], [0, 1500, 540], [0, 0, 1]])), "cam7.K", "infinity"),
    "t wrong shape": (lambda kw: _bad(t=np.zeros(4)), "cam7.t", "shape"),
    "t NaN": (lambda kw: _bad(t=_nan_at(kw["t"], 2)), "cam7.t", "NaN"),
    "dist 6 coefficients": (lambda kw: _bad(dist=np.zeros(6)), "cam7.dist", "coefficients"),
    "dist NaN": (lambda kw: _bad(dist=_nan_at(np.zeros(5), 0)), "cam7.dist", "NaN"),
    "size negative": (lambda kw: _bad(size=(1920, -1)), "cam7.size", "positive"),
    "size not a pair": (lambda kw: _bad(size="big"), "cam7.size", "size"),
    "empty name": (lambda kw: _bad(name=""), "name", "name"),
}


@pytest.mark.parametrize("case", list(BAD_CAMERAS))
def test_bad_calibration_raises_naming_the_field(case):
    make, field, words = BAD_CAMERAS[case]
    with pytest.raises(CalibrationError) as info:
        Camera(**make(good_kwargs()))
    err = info.value
    assert err.field == field
    assert f"'{field}'" in str(err)
    assert words.lower() in str(err).lower()


def test_good_calibration_is_accepted_and_frozen():
    kw = good_kwargs()
    cam = Camera(**kw)
    # column t and 4 coefficients are accepted; dist padded to 5
    cam2 = Camera(**{**kw, "t": kw["t"][:, None], "dist": [0.1, 0.0, 0.0, 0.0]})
    np.testing.assert_array_equal(cam2.t, cam.t)
    assert cam2.dist.shape == (5,) and cam2.has_distortion
    with pytest.raises(ValueError):
        cam.R[0, 0] = 2.0  # read-only arrays: a camera cannot be half-changed after validation
    with pytest.raises(AttributeError):
        cam.K = np.eye(3)  # type: ignore[misc]


# --------------------------------------------------------------------------- rig
def test_rig_order_names_and_stacks(rng):
    cams = [random_camera(rng, n) for n in ("left", "right", "top")]
    rig = Rig(cams)
    assert len(rig) == 3 and rig.names == ("left", "right", "top")
    assert rig["right"] is cams[1] and rig[2] is cams[2] and rig.index("top") == 2
    assert rig.centres.shape == (3, 3) and rig.projections.shape == (3, 3, 4)
    np.testing.assert_allclose(rig.centres[1], cams[1].centre)
    np.testing.assert_allclose(rig.projections[2], cams[2].P)
    assert rig.subset(["top", "left"]).names == ("top", "left")
    with pytest.raises(KeyError, match="nope"):
        rig["nope"]


def test_rig_rejects_duplicate_names_and_empty(rng):
    a = random_camera(rng, "a")
    with pytest.raises(CalibrationError, match="'a'"):
        Rig([a, random_camera(rng, "b"), a.with_name("a")])
    with pytest.raises(CalibrationError):
        Rig([])
