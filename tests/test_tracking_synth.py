"""Synthetic scenes for the tracker tests: a ring of cameras, people as 3D boxes, their 2D boxes.

Helpers (imported by the other ``test_tracking_*`` files) plus checks of the helpers themselves.
People are axis-aligned 3D boxes (``size`` = width, depth, height) around a centre; a view's
box is the bounding box of the projected corners, so box centres are close to -- not exactly
-- the projection of the 3D centre, as with a real detector.
"""

from __future__ import annotations

import numpy as np

from gymtrack.detections import Detections
from gymtrack.formats.scene import scene_from_dict
from gymtrack.geometry.camera import Camera, Rig, look_at

SIZE = (1920, 1080)


def ring_rig(azimuths_deg, radius=12.0, height=3.0, f=1400.0, target=(0.0, 0.0, 1.2), dist=None) -> Rig:
    """Cameras on a circle around the origin, at the given azimuths (degrees), looking at ``target``."""
    cams = []
    for i, az in enumerate(azimuths_deg):
        a = np.radians(az)
        c = np.array([radius * np.cos(a), radius * np.sin(a), height])
        R, t = look_at(c, target)
        K = np.array([[f, 0, SIZE[0] / 2], [0, f, SIZE[1] / 2], [0, 0, 1.0]])
        cams.append(Camera(f"cam{i}", SIZE, K, R, t, np.zeros(5) if dist is None else np.asarray(dist)))
    return Rig(cams)


def simple_scene(**params):
    """A scene around the origin: plane x = 0 (normal +x), generous performance space."""
    return scene_from_dict({
        "performance_space": [-3.0, -3.0, 0.0, 3.0, 3.0, 4.5],
        "buffer": 1.0,
        "planes": [{"point": [0, 0, 0], "normal": [1, 0, 0]}],
        "target": {"h_top": 2.0, "h_bot": 0.6},
        "params": params,
    })


def person_boxes(cam: Camera, centre: np.ndarray, size=(0.5, 0.4, 1.7)) -> np.ndarray:
    """(..., 3) centres -> (..., 4) centre-form raw-pixel boxes of the 3D box around each centre."""
    centre = np.asarray(centre, float)
    s = np.asarray(size, float) / 2
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * s
    uv = cam.project(centre[..., None, :] + corners)  # (..., 8, 2)
    lo, hi = uv.min(axis=-2), uv.max(axis=-2)
    return np.concatenate([(lo + hi) / 2, hi - lo], axis=-1)


def make_detections(rig: Rig, traj: np.ndarray, sizes=None, frames=None, noise=0.0, drop=0.0, seed=0,
                    visible=None) -> tuple[Detections, np.ndarray]:
    """Boxes of P people over T frames in every view.

    traj: (P, T, 3) centres (NaN = absent); sizes: (P, 3) or None; frames: (T,) numbers (default 0..T-1);
    noise: box jitter in pixels (std); drop: probability a box is missed; visible: (P, C) bool mask
    of which views see each person (default all).
    Returns the detections with ``track_id`` = person id (ground truth) and (N,) person ids.
    """
    rng = np.random.default_rng(seed)
    P, T, _ = traj.shape
    frames = np.arange(T) if frames is None else np.asarray(frames)
    sizes = np.tile([0.5, 0.4, 1.7], (P, 1)) if sizes is None else np.asarray(sizes, float)
    parts = []
    for c, cam in enumerate(rig):
        for p in range(P):
            if visible is not None and not visible[p, c]:
                continue
            b = person_boxes(cam, traj[p], sizes[p])
            ok = np.all(np.isfinite(b), axis=1) & (cam.depth(np.nan_to_num(traj[p])) > 0) & cam.in_image(b[:, :2])
            ok &= rng.random(T) >= drop
            b = b + rng.normal(scale=noise, size=b.shape) * np.array([1, 1, 0.5, 0.5])
            parts.append((frames[ok], np.full(ok.sum(), c), b[ok], np.full(ok.sum(), p)))
    f, c, b, pid = (np.concatenate(x) for x in zip(*parts))
    det = Detections.from_arrays(f, c, b, rig.names, track_id=pid).sorted()
    return det, det.track_id.copy()


def as_raw(det: Detections) -> Detections:
    """The same boxes with ``track_id`` = -1 (what a detector gives)."""
    return Detections(det.frame, det.camera, det.box, det.score, np.full(len(det), -1, np.int64), det.camera_names)


# ------------------------------------------------------------------ checks of the helpers
def test_person_box_contains_projected_centre():
    rig = ring_rig([0, 90, 180, 270])
    X = np.array([[0.3, -0.2, 1.0], [1.0, 1.0, 0.9]])
    for cam in rig:
        b = person_boxes(cam, X)
        uv = cam.project(X)
        assert np.all(np.abs(uv - b[:, :2]) < b[:, 2:] / 2)
        assert np.all(b[:, 3] > b[:, 2])  # a standing person is taller than wide


def test_make_detections_counts():
    rig = ring_rig([0, 120, 240])
    traj = np.zeros((2, 10, 3)) + np.array([0, 0, 1.0])
    traj[1] += [1.0, 0.5, 0]
    det, pid = make_detections(rig, traj)
    assert len(det) == 2 * 10 * 3
    assert set(pid.tolist()) == {0, 1}
