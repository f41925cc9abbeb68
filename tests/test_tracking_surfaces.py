"""Scene surfaces beside the vertical plane (the recipe's ``surfaces``): the pommel horse's
horizontal support surface in the plane stage (Eq. 5-9 unchanged).

Checked against closed forms written here (the ray's parameter where it reaches the surface's
height; the vertical plane through the true centre facing the camera for the body's top and
bottom), against the vertical plane on a body circling off it, and for the contract: the preset
sets the surface, a scene without surfaces (or the recipe without the ingredient) tracks as before.
"""

from __future__ import annotations

from dataclasses import fields

import numpy as np

from gymtrack.geometry.plane import Plane
from gymtrack.modes import RECIPES, method_of
from gymtrack.scene import Scene
from gymtrack.simulate.routine import simulate_routine
from gymtrack.tracking.offline import track_detections
from gymtrack.tracking.plane_fallback import plane_stage
from gymtrack.tracking.types import WindowTracklets
from reference.plane import candidates
from conftest import person_boxes, ring_rig

W = 10
SUPPORT = 1.4
VERTICAL = Plane(np.zeros(3), np.array([0.0, 1.0, 0.0]))  # the pommel horse's plane y = 0
SURFACE = Plane(np.array([0.0, 0.0, SUPPORT]), np.array([0.0, 0.0, 1.0]))


def _circle(n=W, radius=0.35):
    """(n, 3) a body's centre circling at the support height about the hands at the origin."""
    a = np.linspace(0.6, 1.4, n)
    return np.c_[radius * np.cos(a), radius * np.sin(a), np.full(n, SUPPORT)]


def _segments(rig, centres):
    """One segment per camera: the undistorted boxes of a 0.5 x 0.4 x 1.7 m body at ``centres``."""
    box = np.stack([person_boxes(cam, centres) for cam in rig])  # (no distortion: raw = undistorted)
    C = len(rig)
    obs = np.ones((C, len(centres)), bool)
    return WindowTracklets(0, np.arange(C), np.arange(C), box, obs, obs, np.zeros((C, len(centres)), np.int64))


def test_surface_candidate_is_the_ray_at_the_support_height_and_top_bottom_are_the_bodys():
    rig = ring_rig([30, 120], height=6.0, target=(0, 0, SUPPORT))  # no distortion: raw = undistorted pixels
    X = _circle()
    segs = _segments(rig, X)
    cand, ok = candidates(segs, rig, [VERTICAL, SURFACE])
    assert ok[:, 1].all()
    for k, cam in enumerate(rig):
        o = cam.centre
        for q, dz in enumerate((0.0, 0.85, -0.85)):  # centre, top, bottom of the box
            uv = segs.box[k, :, :2] + np.c_[np.zeros(W), [0.0, -0.5, 0.5][q] * segs.box[k, :, 3]]
            d = cam.rays(uv, undistort=False)
            if q == 0:  # the ray reaches z = SUPPORT at lambda = (SUPPORT - o_z) / d_z
                lam = (SUPPORT - o[2]) / d[:, 2]
                np.testing.assert_allclose(cand[0, 1, k], o + lam[:, None] * d, atol=1e-9)
                np.testing.assert_allclose(cand[0, 1, k], X, atol=0.02)  # the box centre is nearly the body's
                continue
            # the vertical plane through the centre candidate, normal the centre ray's horizontal part
            c0 = cand[0, 1, k]
            h = cam.rays(segs.box[k, :, :2], undistort=False) * [1.0, 1.0, 0.0]
            lam = np.einsum("ij,ij->i", h, c0 - o) / np.einsum("ij,ij->i", h, d)
            np.testing.assert_allclose(cand[q, 1, k], o + lam[:, None] * d, atol=1e-9)
            # and so the body's top and bottom heights, not the surface's (seen from 20 degrees above, the
            # box of a 0.5 x 0.4 m body reaches ~0.15 m beyond its top and bottom, as on the plane)
            np.testing.assert_allclose(cand[q, 1, k, :, 2], SUPPORT + dz, atol=0.25)
            assert np.all(np.abs(cand[q, 1, k, :, 2] - SUPPORT) > 0.6)


def test_two_views_are_fused_on_the_surface_where_they_agree_nearer_than_on_the_plane():
    rig = ring_rig([30, 120], height=6.0, target=(0, 0, SUPPORT))
    X = _circle()  # 0.2-0.35 m off the vertical plane
    segs = _segments(rig, X)
    on_plane = plane_stage(segs, rig, [VERTICAL], 0.5)
    with_surface = plane_stage(segs, rig, [VERTICAL, SURFACE], 0.5)
    assert len(with_surface.members) == 1
    err_surface = np.linalg.norm(with_surface.xyz[0] - X, axis=1)
    assert err_surface.max() < 0.05
    if len(on_plane.members):  # (on the plane alone the two views may not even agree within 0.5 m)
        assert err_surface.mean() < 0.5 * np.linalg.norm(on_plane.xyz[0] - X, axis=1).mean()
    # the heights of the body's top and bottom stay the body's (Eq. 13 reads them)
    assert np.all(with_surface.top_z[0] > SUPPORT + 0.6) and np.all(with_surface.bottom_z[0] < SUPPORT - 0.6)


def test_a_view_nearly_level_with_the_body_is_better_served_by_the_plane():
    """The limit that keeps the ingredient out of cascade+: a camera 12 m away and 0.7 m above the
    centre (the square-on pair of the venues) meets the surface at a grazing angle, so 0.1 m of
    height off the surface moves its candidate ~1.7 m along the ray, against 0.35 m off the plane."""
    rig = ring_rig([-90], radius=12.0, height=2.1, target=(0, 0, SUPPORT))
    X = _circle() + [0.0, 0.0, 0.1]
    segs = _segments(rig, X)
    cand, _ = candidates(segs, rig, [VERTICAL, SURFACE])
    err_plane = np.linalg.norm(cand[0, 0, 0] - X, axis=1)
    err_surface = np.linalg.norm(cand[0, 1, 0] - X, axis=1)
    assert np.all(err_surface > 2 * err_plane)


def test_presets_set_the_surface_and_yaml_keeps_it():
    pommel = Scene(apparatus="pommel_horse")
    assert len(pommel.surfaces) == 1 and pommel.surfaces[0].normal == (0.0, 0.0, 1.0)
    assert pommel.surfaces[0].point[2] == SUPPORT
    assert Scene(apparatus="balance_beam").surfaces == ()  # the plane y = 0 is the beam's line already
    assert "surfaces" not in Scene(apparatus="still_rings").to_yaml_dict()
    assert Scene(**pommel.to_yaml_dict()) == pommel
    assert Scene(apparatus="pommel_horse", surfaces=[]).surfaces == ()  # the scene may drop it


def test_without_surfaces_tracking_is_unchanged():
    sim = simulate_routine("pommel_horse", n_cam=2, seed=3, seconds=6)
    bare = sim.scene.model_copy(update={"surfaces": ()})
    plus = track_detections(sim.rig, sim.scene, sim.detections, mode=RECIPES["cascade+"])
    same = [track_detections(sim.rig, bare, sim.detections, mode=m) for m in (RECIPES["cascade+"],
                                                                             method_of("cascade+ +surfaces"))]
    on = track_detections(sim.rig, sim.scene, sim.detections, mode=method_of("cascade+ +surfaces"))
    for r in same:
        for a, b in ((r.tracks, plus.tracks), (r.target, plus.target), (r.target_boxes, plus.target_boxes)):
            for f in fields(a):
                x, y = getattr(a, f.name), getattr(b, f.name)
                if isinstance(x, np.ndarray):
                    assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), f.name
    assert on.tracks.frame.size > 0  # (with the surface it runs; whether it differs is the benchmark's)


def _inside(inner, outer):
    """Centre-form boxes: ``inner`` within ``outer``."""
    return bool(np.all(inner[:2] - inner[2:] / 2 >= outer[:2] - outer[2:] / 2)
                and np.all(inner[:2] + inner[2:] / 2 <= outer[:2] + outer[2:] / 2))


def test_pommel_body_box_reaches_a_horizontal_body_across_the_plane():
    """Eq. 14 in a view without a detection: a body lying across the horse's plane (a circle's
    front or back, 1.6 m from head to toe along y) fits the body box of the preset's half-depth
    (half its length), not the trunk's 0.25 m of the other apparatus."""
    from gymtrack.tracking.target import buffered_boxes

    assert Scene(apparatus="pommel_horse").params.body_half_depth == 0.8
    assert Scene(apparatus="balance_beam").params.body_half_depth == 0.25
    assert Scene(apparatus="pommel_horse", params={"body_half_depth": 0.3}).params.body_half_depth == 0.3
    rig = ring_rig([40], radius=11.0, height=3.0, target=(0, 0, SUPPORT))
    X = np.array([[0.0, 0.0, SUPPORT]])
    true = person_boxes(rig[0], X[0], size=(0.4, 1.6, 0.3))
    wh = np.full((1, 1, 2), np.nan)  # the view has no detection of the gymnast
    fits = []
    for half_depth in (0.25, Scene(apparatus="pommel_horse").params.body_half_depth):
        box, ok = buffered_boxes(rig, X, X[:, 2] + 0.15, X[:, 2] - 0.15, wh, 1.3, {}, np.array([0.0, 1.0, 0.0]), half_depth)
        assert ok[0, 0]
        fits.append(_inside(true, box[0, 0]))
    assert fits == [False, True]
