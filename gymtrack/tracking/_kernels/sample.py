"""A tiny real scene for the kernels' warm-ups: two cameras, one person, one plane.

Paper: no method; Section III-A/B/C/D inputs in miniature. Every kernel module's ``warm_up``
runs its kernels once on these (boxes projected from a walking person, the plane x = 0), so
numba compiles -- or loads from its cache -- exactly the argument types the tracker passes,
without hand-built argument lists. Built once per process.
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np

from ...geometry.camera import Camera, Rig, look_at
from ...geometry.plane import Plane

#: frames of the sample window
WIDTH = 6


class Sample(NamedTuple):
    """rig: 2 cameras; planes: [x = 0]; camera (K,) int64, box (K, W, 4) undistorted centre-form
    boxes (NaN where not observed), observed (K, W) bool: one segment per camera of the person
    at xyz (W, 3)."""

    rig: Rig
    planes: list
    camera: np.ndarray
    box: np.ndarray
    observed: np.ndarray
    xyz: np.ndarray


@lru_cache(maxsize=1)
def sample() -> Sample:
    """The sample scene (cached: the warm-ups share it)."""
    K = np.array([[1000.0, 0.0, 960.0], [0.0, 1000.0, 540.0], [0.0, 0.0, 1.0]])
    cams = []
    for name, centre in (("a", (10.0, 1.0, 3.0)), ("b", (1.0, 10.0, 3.0))):
        R, t = look_at(np.array(centre), np.array([0.0, 0.0, 1.0]))
        cams.append(Camera(name, (1920, 1080), K, R, t, np.array([-0.1, 0.01, 0.0, 0.0, 0.0])))
    rig = Rig(cams)
    xyz = np.column_stack([np.zeros(WIDTH), np.linspace(-0.5, 0.5, WIDTH), np.full(WIDTH, 1.0)])
    box = np.empty((len(rig), WIDTH, 4))
    for c, cam in enumerate(rig):
        top, bottom = cam.project(xyz + [0, 0, 0.9], distort=False), cam.project(xyz - [0, 0, 0.9], distort=False)
        h = bottom[:, 1] - top[:, 1]
        box[c] = np.column_stack([(top + bottom) / 2, 0.4 * h, h])
    observed = np.ones((len(rig), WIDTH), bool)
    observed[0, 2] = False  # a missed box: filled by the window stage
    box[~observed] = np.nan
    return Sample(rig, [Plane(np.zeros(3), np.array([1.0, 0.0, 0.0]))], np.arange(len(rig), dtype=np.int64), box,
                  observed, xyz)
