"""Synthetic scenes for the tracker tests: a ring of cameras, people as 3D boxes, their 2D boxes.

The helpers live in ``conftest.py`` (the other ``test_tracking_*`` files import them from there);
this file checks them. People are axis-aligned 3D boxes (``size`` = width, depth, height) around a centre; a view's
box is the bounding box of the projected corners, so box centres are close to -- not exactly
-- the projection of the 3D centre, as with a real detector.
"""

from __future__ import annotations

import numpy as np

from conftest import make_detections, person_boxes, ring_rig


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
