"""Ballistic flights (the recipe's ``ballistic``): the parabola under g against a simulated
flight's ground truth, and a detector gap in flight that keeps the target."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.modes import RECIPES, recipe
from gymtrack.simulate import simulate_routine
from gymtrack.scene import Scene
from gymtrack.tracking.ballistic import FIT_FRAMES, G, Footprint, fit_flight
from gymtrack.tracking.offline import track_detections


@pytest.fixture(scope="module")
def vault():
    """A simulated vault (two opposite views) and its longest flight (first, last row)."""
    sim = simulate_routine("vault", n_cam=2, seed=5, seconds=6.0)
    f = sim.flight.astype(np.int8)
    starts = np.flatnonzero(np.diff(np.r_[0, f]) == 1)
    ends = np.flatnonzero(np.diff(np.r_[f, 0]) == -1)
    k = int(np.argmax(ends - starts))
    return sim, int(starts[k]), int(ends[k])


def test_fit_predicts_the_simulated_flight_and_its_landing(vault):
    sim, a, b = vault
    assert b - a + 1 >= FIT_FRAMES + 8  # a flight long enough to predict
    c, fr = sim.centre[0], sim.frames
    rng = np.random.default_rng(0)
    i = np.arange(a, a + FIT_FRAMES)
    noisy = c[i] + rng.normal(0, 0.02, (len(i), 3))  # the tracker's centre noise
    fl = fit_flight(fr[i], noisy, sim.fps, sim.bottom_z[0, i[-1]], land_z=float(c[b, 2]))
    assert fl.airborne
    j = np.arange(a + FIT_FRAMES, b + 1)
    err = np.linalg.norm(fl.predict(fr[j]) - c[j], axis=1)
    assert err.max() < 0.15, err  # the rest of the flight, up to 0.6 s ahead, from a third of a second
    assert abs(fl.landing_frame() - fr[b]) < 2.0
    # the fit is the parabola under g: exact points give back the velocity of the simulation
    exact = fit_flight(fr[i], c[i], sim.fps)
    v = (c[i[-1]] - c[i[-2]]) * sim.fps
    v[2] -= G / (2 * sim.fps)  # the mean over the last frame is the speed half a frame earlier
    assert exact.rms < 0.01 and np.allclose(exact.v, v, atol=0.05)


def test_standing_on_the_beam_is_not_predicted_to_move():
    """A gymnast standing on the beam (centre 2.1 m, bottom 1.25 m), seen with 3 cm of noise: if
    the test calls it airborne, the parabola lands at once and the last point is held."""
    rng = np.random.default_rng(1)
    fr = np.arange(100, 100 + FIT_FRAMES)
    held = 0
    for _ in range(50):
        xyz = np.array([0.5, 0.0, 2.1]) + rng.normal(0, 0.03, (len(fr), 3))
        fl = fit_flight(fr, xyz, 30.0, 1.25, land_z=2.1 - 0.06)
        if fl.airborne:
            held += 1
            p = fl.predict(fr[-1] + np.arange(1, 16))
            assert np.linalg.norm(p - fl.p, axis=1).max() < 0.2
            assert fl.reach() <= fr[-1] + 0.5 * 30 + 3
    assert held < 50  # the test is not always passed


def test_a_detector_gap_in_flight_keeps_the_target(vault):
    sim, a, b = vault
    gap = sim.frames[a + FIT_FRAMES: b + 1]  # the target unseen from a third of a second into the flight to its landing
    drop = (sim.det_person == sim.target_id) & np.isin(sim.detections.frame, gap)
    det = sim.detections.select(~drop)
    truth = dict(zip(sim.frames.tolist(), sim.centre[0]))

    def covered(method):
        t = track_detections(sim.rig, sim.scene, det, mode=method).target
        near = [f for f, p in zip(t.frame.tolist(), t.xyz) if f in truth and np.linalg.norm(p - truth[f]) < 0.35]
        return np.isin(gap, near).mean(), np.isin(sim.frames[b + 1: b + 31], near).mean()

    with_, after = covered(RECIPES["cascade+"])
    without, _ = covered(recipe("cascade+", without=["ballistic"]))
    assert with_ >= 0.8 and with_ > without + 0.3, (with_, without)
    assert after >= 0.9  # the track that resumes after the landing is the gymnast's


def test_a_beam_dismount_lands_on_the_floor_where_it_leaves_the_beam():
    """The simulated dismount off the beam's end: fitted from its first third of a second with the
    support's height (the lowest centre on the beam before), the parabola alone stops at beam
    height 0.3 m short and 7 frames early; with the footprint it comes down to the floor where
    the gymnast does (ground truth)."""
    sim = simulate_routine("balance_beam", n_cam=2, seed=5, seconds=20.0)
    c, fr = sim.centre[0], sim.frames
    f = sim.flight.astype(np.int8)
    starts, ends = np.flatnonzero(np.diff(np.r_[0, f]) == 1), np.flatnonzero(np.diff(np.r_[f, 0]) == -1)
    k = int(np.flatnonzero(c[ends, 2] < 1.2)[-1])  # the last flight that ends on the floor: the dismount
    a, b = int(starts[k]), int(ends[k])
    assert c[a, 2] > 1.8 and b - a + 1 > FIT_FRAMES + 8  # from the beam, long enough to predict
    i = np.arange(a, a + FIT_FRAMES)
    support = float(c[a - 60: a + FIT_FRAMES, 2].min())  # on the beam: the keeper's landing height
    fl = fit_flight(fr[i], c[i], sim.fps, sim.bottom_z[0, i[-1]], land_z=support)
    assert fl.airborne and support > 1.8
    on_floor = Footprint.of_scene(sim.scene).landing(fl)
    assert on_floor.land_z < 1.0
    assert abs(on_floor.landing_frame() - fr[b]) < 2.0
    assert np.linalg.norm(on_floor.predict(fr[b:b + 1])[0] - c[b]) < 0.3
    assert np.linalg.norm(fl.predict(fr[b:b + 1])[0] - c[b]) > 0.8  # the support's height: far off


def test_footprint_keeps_a_landing_on_the_beam_and_needs_a_preset():
    """A leap along the beam comes down over it: the support's height stays; a scene without an
    apparatus has no footprint; the footprint follows the scene's plane (beam turned 90 degrees)."""
    scene = Scene(apparatus="balance_beam")
    fr = np.arange(FIT_FRAMES)
    t = (fr - fr[-1]) / 30.0
    xyz = np.stack([1.0 + 2.0 * t, np.zeros_like(t), 2.4 + 1.0 * t - G / 2 * t * t], axis=1)  # along the beam
    fl = fit_flight(fr, xyz, 30.0, 1.6, land_z=2.05)
    assert fl.airborne and Footprint.of_scene(scene).landing(fl).land_z == 2.05
    off = fit_flight(fr, xyz[:, [1, 0, 2]] * [1, 1, 1], 30.0, 1.6, land_z=2.05)  # the same leap across it
    assert Footprint.of_scene(scene).landing(off).land_z < 1.0
    turned = Scene(apparatus="balance_beam", planes=[{"point": [0, 0, 0], "normal": [1, 0, 0]}])
    assert Footprint.of_scene(turned).landing(off).land_z == 2.05  # the beam now lies along y
    assert Footprint.of_scene(Scene(performance_space=[-3, -3, 0, 3, 3, 4])) is None
