"""Line-of-sight angles and opposite camera pairs (Section III-C), hand-worked."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gymtrack.geometry import Camera, Rig, line_of_sight_angle, opposite_pairs, pairwise_angles

from conftest import SIZE, look_at, random_rig


def cam_at(name: str, centre, target=(0.0, 0.0, 1.0)) -> Camera:
    R, t = look_at(np.asarray(centre, float), np.asarray(target, float))
    return Camera(name, SIZE, np.array([[1500.0, 0, 960], [0, 1500, 540], [0, 0, 1]]), R, t)


def test_hand_worked_angles():
    X = np.array([0.0, 0.0, 1.0])
    # facing each other through X
    assert np.isclose(line_of_sight_angle([10.0, 0, 1], [-10.0, 0, 1], X), 180.0)
    # same side, both on one ray through X (one behind the other): 0
    assert np.isclose(line_of_sight_angle([10.0, 0, 1], [20.0, 0, 1], X), 0.0, atol=1e-6)
    # same side, slightly apart: small
    assert 0 < line_of_sight_angle([10.0, 0, 1], [10.0, 0.5, 1], X) < 3.0
    # perpendicular
    assert np.isclose(line_of_sight_angle([10.0, 0, 1], [0, 7.0, 1], X), 90.0)
    # lines of sight (-4, 0, 0) and (-4, -3, 0): atan(3/4)
    assert np.isclose(line_of_sight_angle([4.0, 0, 0], [4.0, 3.0, 0], [0.0, 0, 0]), np.degrees(np.arctan2(3, 4)))
    # 135 degrees: lines of sight (1, 0, 0) and (-1, 1, 0)
    assert np.isclose(line_of_sight_angle([-1.0, 0, 0], [1.0, -1.0, 0], [0.0, 0, 0]), 135.0)


def test_angle_broadcasts_and_is_symmetric(rng):
    a = rng.normal(size=(5, 1, 3)) * 10
    b = rng.normal(size=(1, 4, 3)) * 10
    X = rng.normal(size=3)
    ang = line_of_sight_angle(a, b, X)
    assert ang.shape == (5, 4)
    np.testing.assert_allclose(ang, line_of_sight_angle(b, a, X))  # symmetric in the two cameras
    for i in range(5):
        for j in range(4):
            u, v = X - a[i, 0], X - b[0, j]
            ref = np.degrees(np.arccos(u @ v / np.linalg.norm(u) / np.linalg.norm(v)))
            assert np.isclose(ang[i, j], ref, atol=1e-6)
    assert np.all((ang >= 0) & (ang <= 180))


@given(seed=st.integers(0, 2**32 - 1))
@settings(max_examples=30, deadline=None)
def test_angle_is_in_range_and_mirrors_hypothesis(seed):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-3, 3, 3)
    a = X + rng.normal(size=3) * 10
    b = X + rng.normal(size=3) * 10
    ang = float(line_of_sight_angle(a, b, X))
    assert 0.0 <= ang <= 180.0
    # mirroring camera b through X turns the angle into its supplement
    assert np.isclose(float(line_of_sight_angle(a, 2 * X - b, X)), 180.0 - ang, atol=1e-6)


def test_opposite_pairs_of_a_four_camera_rig():
    """Cameras on the +x, +y, -x, -y sides: 0/2 and 1/3 face each other; neighbours are at 90."""
    rig = Rig(
        [cam_at("east", [12, 0, 1]), cam_at("north", [0, 9, 1]), cam_at("west", [-8, 0, 1]), cam_at("south", [0, -15, 1])]
    )
    X = np.array([0.0, 0.0, 1.0])
    ang = pairwise_angles(rig, X)
    expected = np.array([[0, 90, 180, 90], [90, 0, 90, 180], [180, 90, 0, 90], [90, 180, 90, 0]], float)
    np.testing.assert_allclose(ang, expected, atol=1e-6)
    opp = opposite_pairs(rig, X)
    assert opp.dtype == bool and opp.shape == (4, 4)
    np.testing.assert_array_equal(opp, expected > 150)
    # the decision moves with the point: off-centre, east and west no longer meet at 180
    X_off = np.array([0.0, 6.0, 1.0])
    ang_off = pairwise_angles(rig, X_off)
    assert ang_off[0, 2] < 150
    assert not opposite_pairs(rig, X_off)[0, 2]
    # threshold is honoured
    assert opposite_pairs(rig, X_off, threshold_deg=ang_off[0, 2] - 1)[0, 2]


def test_opposite_pairs_symmetric_with_false_diagonal(rng):
    for _ in range(5):
        rig = random_rig(rng, 5)
        X = rng.uniform(-3, 3, 3)
        for thr in (0.0, 90.0, 150.0):
            opp = opposite_pairs(rig, X, threshold_deg=thr)
            np.testing.assert_array_equal(opp, opp.T)
            assert not opp.diagonal().any()
        # threshold 0: every distinct pair (all angles are > 0 for distinct centres)
        assert opposite_pairs(rig, X, threshold_deg=0.0).sum() == 5 * 4


@pytest.mark.parametrize("threshold", [120.0, 150.0, 170.0])
def test_opposite_pairs_agrees_with_the_angle(rng, threshold):
    rig = random_rig(rng, 6)
    X = rng.uniform(-3, 3, 3)
    ang = pairwise_angles(rig, X)
    opp = opposite_pairs(rig, X, threshold)
    off = ~np.eye(6, dtype=bool)
    np.testing.assert_array_equal(opp[off], ang[off] > threshold)
