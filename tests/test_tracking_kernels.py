"""The kernels' plumbing: warm-up covers every signature the tracker uses, RigArrays / PlaneArrays
hold the calibration the kernels read, and the scalar primitives of ``gymtrack.geometry``
(Eq. 1, 6, 7 and the distorted projection) agree with OpenCV and the numpy code they replaced.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from numba import njit
from numba.core.registry import CPUDispatcher

from conftest import random_rig
from gymtrack.geometry import primitives
from gymtrack.geometry.arrays import PlaneArrays, RigArrays
from gymtrack.geometry.epipolar import epipolar_distance, fundamental_matrices
from gymtrack.geometry.plane import Plane, intersect_rays_plane
from gymtrack.tracking import _kernels, track_detections, warm_up
from reference.epipolar import epipolar_distance_numpy, intersect_rays_plane_numpy
from conftest import make_detections, ring_rig, simple_scene


def signatures() -> dict[str, int]:
    mods = (_kernels.single_view, _kernels.windows, _kernels.clustering, _kernels.reconstruct, _kernels.linking,
            _kernels.plane, _kernels.target, _kernels.drift, primitives)
    return {f"{m.__name__}.{name}": len(f.signatures) for m in mods for name, f in vars(m).items()
            if isinstance(f, CPUDispatcher)}


def test_warm_up_compiles_what_the_tracker_runs():
    """After warm_up no kernel compiles anything new while tracking (every mode, both associations)."""
    warm_up()
    before = signatures()
    assert before["gymtrack.tracking._kernels.plane.plane_stage"] >= 1
    assert before["gymtrack.tracking._kernels.target.buffered_boxes"] >= 1
    rig = ring_rig([0, 80, 180, 260], dist=[-0.1, 0.02, 0.0, 0.0, 0.0])
    T = 60
    t = np.arange(T)
    traj = np.stack([np.stack([0.05 * np.sin(t / 7), 1.5 * np.sin(t / 15), 1.7 + 0.8 * np.sin(t / 10)], axis=1),
                     np.stack([np.full(T, 1.5), np.full(T, -1.0), np.full(T, 0.9)], axis=1)])
    det, _ = make_detections(rig, traj, noise=2.0, drop=0.1, seed=1)
    for mode, association in (("cascade", "iou"), ("triangulation", "iou"), ("plane", "iou"), ("cascade", "oracle")):
        res = track_detections(rig, simple_scene(), det, mode=mode, association=association)
        assert len(res.tracks) > 0
    assert signatures() == before


def test_rig_arrays_built_once_and_match_the_cameras(rng):
    rig = random_rig(rng, 3)
    a = rig.arrays
    assert a is rig.arrays  # cached on the rig: no id() caches
    assert isinstance(a, RigArrays)
    for c, cam in enumerate(rig):
        np.testing.assert_array_equal(a.K[c], cam.K)
        np.testing.assert_array_equal(a.P[c], cam.P)
        np.testing.assert_array_equal(a.dist[c, : cam.dist.size], cam.dist[:8])
        assert not a.dist[c, cam.dist.size:].any()
        np.testing.assert_allclose(a.centres[c], cam.centre, atol=1e-12)
        assert tuple(a.size[c]) == cam.size
        # Eq. 6: back-projected pixels are the camera's rays
        uv = rng.uniform(0, 1000, (5, 2))
        d = np.column_stack([uv, np.ones(5)]) @ a.back[c].T
        np.testing.assert_allclose(d / np.linalg.norm(d, axis=1, keepdims=True), cam.rays(uv, undistort=False),
                                   atol=1e-12)
    for arr in a:
        assert arr.dtype == np.float64 and arr.flags.c_contiguous


def test_plane_arrays():
    planes = [Plane(np.zeros(3), np.array([2.0, 0, 0])), Plane(np.array([0, 1.0, 0]), np.array([0, 1.0, 1.0]))]
    pa = PlaneArrays.from_planes(planes)
    assert pa.point.shape == pa.normal.shape == (2, 3)
    np.testing.assert_allclose(pa.normal[1], [0, 2 ** -0.5, 2 ** -0.5])
    assert PlaneArrays.from_planes(pa) is pa
    assert PlaneArrays.from_planes([]).point.shape == (0, 3)


@njit(cache=False)
def _project_all(R, t, K, dist, c, X):
    out = np.empty((X.shape[0], 2))
    for n in range(X.shape[0]):
        out[n, 0], out[n, 1], _ = primitives.project_point(R, t, K, dist, c, X[n, 0], X[n, 1], X[n, 2])
    return out


@pytest.mark.parametrize("ncoef", [5, 8])
def test_project_point_matches_opencv(rng, ncoef):
    """The Eq. 14 kernel's projection (raw pixels, 8-coefficient distortion) against cv2.projectPoints."""
    from conftest import random_distortion

    rig = random_rig(rng, 2)
    a = rig.arrays
    dist = np.zeros((2, 8))
    dist[:, :ncoef] = [random_distortion(rng, ncoef, 0.8) for _ in range(2)]
    X = rng.uniform([-3, -3, 0], [3, 3, 2.5], (50, 3))
    for c, cam in enumerate(rig):
        ref, _ = cv2.projectPoints(X, cam.rvec, cam.t, cam.K, dist[c, :ncoef])
        np.testing.assert_allclose(_project_all(a.R, a.t, a.K, dist, c, X), ref[:, 0], atol=1e-6)
    behind = _project_all(a.R, a.t, a.K, dist, 0, (2 * rig[0].centre - X[:1])[None, 0])
    assert np.isnan(behind).all()


def test_epipolar_distance_matches_the_numpy_formula(rng):
    rig = random_rig(rng, 3)
    F = fundamental_matrices(rig)
    bi = np.column_stack([rng.uniform(0, 1900, 40), rng.uniform(0, 1000, 40), rng.uniform(20, 200, (40, 2))])
    bj = np.column_stack([rng.uniform(0, 1900, 30), rng.uniform(0, 1000, 30), rng.uniform(20, 200, (30, 2))])
    got = epipolar_distance(bi[:, None], bj[None], F[0, 1])
    assert got.shape == (40, 30)
    np.testing.assert_allclose(got, epipolar_distance_numpy(bi[:, None], bj[None], F[0, 1]), rtol=1e-10)
    # a zero F (one camera with itself) has no epipolar lines: NaN, as before
    assert np.isnan(epipolar_distance(bi[:3], bi[:3], F[1, 1])).all()


def test_intersect_rays_plane_matches_the_numpy_formula(rng):
    plane = Plane(np.array([0.0, 0.5, 0.0]), np.array([0.1, 1.0, 0.0]))
    o = rng.normal(0, 5, (200, 3))
    d = rng.normal(0, 1, (200, 3))
    # parallel, along the plane, zero, NaN and denormal directions
    d[:5] = [[1.0, -0.1, 0], [0, 0, 1.0], [0, 0, 0], [np.nan, 0, 0], [1e-320, 1e-320, 0]]
    X, status = intersect_rays_plane(o, d, plane)
    Xr, sr = intersect_rays_plane_numpy(o, d, plane)
    np.testing.assert_array_equal(status, sr)
    np.testing.assert_allclose(X, Xr, rtol=1e-12, atol=1e-12)
    assert set(np.unique(status)) == {0, 1, 2}


def test_regroup_kernel_matches_its_numpy_reference():
    from gymtrack.tracking.regroup import regroup, regroup_pairs
    from reference.regroup import regroup_pairs_numpy

    rng = np.random.default_rng(7)
    found = 0
    for _ in range(300):
        C = int(rng.integers(2, 6))
        K = int(rng.integers(0, 14))
        camera = np.sort(rng.integers(0, C, K)).astype(np.int64)
        D2 = rng.uniform(0, 0.6, (K, K))
        D2 = (D2 + D2.T) / 2
        D2[rng.random((K, K)) < 0.1] = np.nan
        D2 = np.where(np.isnan(D2) | np.isnan(D2.T), np.nan, D2)  # symmetric NaNs, as Eq. 2's
        D2[camera[:, None] == camera[None, :]] = np.inf
        if K and rng.random() < 0.3:  # ties
            D2 = np.round(D2, 1)
        opposite = rng.random((C, C)) < 0.4
        opposite = (opposite | opposite.T) & ~np.eye(C, dtype=bool)
        labels = rng.integers(0, max(K, 1), K)
        tested = np.full((len(np.unique(labels)), C), -1, np.int64)
        for r, lab in enumerate(np.unique(labels)):
            for k in np.flatnonzero(labels == lab):
                tested[r, camera[k]] = k
        kept = tested[rng.random(len(tested)) < 0.5]
        seg, groups = regroup_pairs(tested, kept, D2, camera, opposite, 0.3)
        ref_seg, ref_groups = regroup_pairs_numpy(tested, kept, D2, camera, opposite, 0.3)
        assert seg.tolist() == ref_seg.tolist()
        assert (groups is None) == (ref_groups is None)
        if groups is not None:
            assert groups.tolist() == ref_groups.tolist()
            found += 1
        # the tracker's step: to_plane gains the pairs' segments, floor_only loses them, fresh: not in floor_only
        to_plane = np.flatnonzero(rng.random(K) < 0.3)
        floor_only = np.setdiff1d(np.flatnonzero(rng.random(K) < 0.3), to_plane)
        counts = {"segments_regrouped": 0}
        seg2, groups2, plane, floor, fresh = regroup(tested, kept, D2, camera, opposite, 0.3, to_plane, floor_only, counts)
        assert seg2.tolist() == ref_seg.tolist() and counts["segments_regrouped"] == len(ref_seg)
        assert plane.tolist() == np.union1d(to_plane, ref_seg).tolist()
        assert floor.tolist() == np.setdiff1d(floor_only, ref_seg).tolist()
        assert fresh.tolist() == np.setdiff1d(ref_seg, floor_only).tolist()
    assert found > 20  # the test saw pairs, not only empty answers
