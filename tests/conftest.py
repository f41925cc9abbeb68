"""Shared test fixtures: a seeded random generator and realistic random cameras.

The camera factory places cameras the way a gym rig is set up: 8-18 m from a region of
interest (the performance space around the world origin, z up), 2-7 m high, looking at a
point inside the region with a small roll, 1920x1080 images, focal lengths that keep the
region in view, and (optionally) realistic lens distortion with 5 or 8 OpenCV coefficients.
Distortion is rejection-sampled so the radial map stays monotonic a margin beyond the image
corners, as every real calibration does (otherwise undistortion has no unique answer).

The factories are session-scoped fixtures returning plain functions that take a
``numpy.random.Generator``, so hypothesis tests (which must not use function-scoped
fixtures) can call them with a generator seeded from a drawn integer.

Plain helpers the test modules import (``from conftest import ...``; pytest puts this folder on
``sys.path``): the random cameras above; :func:`same`, array equality to 1e-9 with NaN and inf
where the other has them; the synthetic tracker scenes (:func:`ring_rig`, :func:`simple_scene`,
:func:`person_boxes`, :func:`make_detections`, :func:`as_raw`: people as 3D boxes seen by a ring of
cameras; a view's box is the bounding box of the projected corners, so box centres are close to --
not exactly -- the projection of the 3D centre, as with a real detector); :data:`WILDTRACK`, the
real data set, when it is there.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from gymtrack.detections import Detections
from gymtrack.formats.scene import scene_from_dict
from gymtrack.geometry import Camera, Rig
from gymtrack.geometry.camera import look_at


def _shared_data() -> Path:
    """``shared/data`` beside the repository, or beside the folder of worktrees holding it
    (``GYMTRACK_SHARED_DATA`` overrides both)."""
    if os.environ.get("GYMTRACK_SHARED_DATA"):
        return Path(os.environ["GYMTRACK_SHARED_DATA"])
    repo = Path(__file__).resolve().parents[1]
    for up in (repo.parent, repo.parent.parent):
        if (up / "shared" / "data").is_dir():
            return up / "shared" / "data"
    return repo.parent / "shared" / "data"


#: The WILDTRACK data set (tests that need it skip when it is absent).
WILDTRACK = _shared_data() / "wildtrack"


def needs_data(path: Path, what: str):
    """A skipif mark: skip unless ``path`` exists, with a reason naming it (a clone without
    ``../shared`` runs every other test)."""
    return pytest.mark.skipif(
        not Path(path).exists(),
        reason=f"needs {what}: {path} not found (put it under ../shared/data or set $GYMTRACK_SHARED_DATA)",
    )


#: Tests on the real WILDTRACK annotations and calibration.
needs_wildtrack = needs_data(WILDTRACK / "annotations_positions", "the WILDTRACK data set")

SIZE = (1920, 1080)
#: the region the random cameras look at: [xmin, ymin, zmin, xmax, ymax, zmax], metres
REGION = np.array([-4.0, -3.0, 0.0, 4.0, 3.0, 2.5])


def radial_is_monotonic(dist: np.ndarray, r_max: float, min_slope: float = 0.3) -> bool:
    """True when ``r -> r * radial(r)`` of OpenCV's model has slope >= ``min_slope`` on [0, r_max]."""
    d = np.zeros(8)
    d[: len(dist)] = dist
    k1, k2, _, _, k3, k4, k5, k6 = d
    r = np.linspace(0.0, r_max, 400)
    r2 = r * r
    rd = r * (1 + k1 * r2 + k2 * r2**2 + k3 * r2**3) / (1 + k4 * r2 + k5 * r2**2 + k6 * r2**3)
    slope = np.gradient(rd, r)
    return bool(np.all(slope >= min_slope) and np.all(1 + k4 * r2 + k5 * r2**2 + k6 * r2**3 > 0.3))


def random_distortion(rng: np.random.Generator, ncoef: int, r_max: float) -> np.ndarray:
    """Realistic OpenCV distortion with ``ncoef`` in (4, 5, 8) coefficients, monotonic to ``r_max``."""
    for _ in range(1000):
        k1 = rng.uniform(-0.35, 0.15)
        k2 = rng.uniform(-0.05, 0.15)
        p1, p2 = rng.uniform(-1.5e-3, 1.5e-3, size=2)
        k3 = rng.uniform(-0.03, 0.03)
        d = [k1, k2, p1, p2, k3]
        if ncoef == 8:
            d += list(rng.uniform(-0.1, 0.1, size=3))
        d = np.array(d[:ncoef])
        if radial_is_monotonic(d, r_max):
            return d
    raise RuntimeError("could not draw a monotonic distortion")  # pragma: no cover


def random_camera(
    rng: np.random.Generator,
    name: str = "cam0",
    distortion: int | None = None,
    azimuth: float | None = None,
) -> Camera:
    """A realistic camera looking at :data:`REGION`.

    distortion: None (no distortion), 4, 5 or 8 OpenCV coefficients.
    azimuth: direction (radians) of the camera from the region centre; random if None.
    """
    az = rng.uniform(0, 2 * np.pi) if azimuth is None else azimuth
    dist_xy = rng.uniform(8.0, 18.0)
    centre = np.array([dist_xy * np.cos(az), dist_xy * np.sin(az), rng.uniform(2.0, 7.0)])
    target = np.array([rng.uniform(-1.5, 1.5), rng.uniform(-1.0, 1.0), rng.uniform(0.5, 1.5)])
    R, t = look_at(centre, target, roll=rng.uniform(-0.05, 0.05))
    f = rng.uniform(1100.0, 2000.0)
    w, h = SIZE
    K = np.array(
        [[f, 0.0, w / 2 + rng.uniform(-20, 20)], [0.0, f * rng.uniform(0.995, 1.005), h / 2 + rng.uniform(-20, 20)], [0.0, 0.0, 1.0]]
    )
    if distortion is None:
        dist = np.zeros(5)
    else:
        # normalised radius of the farthest image corner, plus a margin
        r_corner = np.hypot(max(K[0, 2], w - K[0, 2]) / K[0, 0], max(K[1, 2], h - K[1, 2]) / K[1, 1])
        dist = random_distortion(rng, distortion, 1.3 * r_corner)
    return Camera(name, SIZE, K, R, t, dist)


def random_rig(rng: np.random.Generator, n: int = 4, distortion: int | None = None) -> Rig:
    """``n`` cameras spread around :data:`REGION` (azimuths jittered around even spacing)."""
    az0 = rng.uniform(0, 2 * np.pi)
    cams = [
        random_camera(rng, f"cam{i}", distortion, az0 + 2 * np.pi * i / n + rng.uniform(-0.3, 0.3)) for i in range(n)
    ]
    return Rig(cams)


def random_points(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 3) points uniform in :data:`REGION`."""
    return rng.uniform(REGION[:3], REGION[3:], size=(n, 3))


def points_seen_by(rng: np.random.Generator, cams, n: int, margin: float = 0.0) -> np.ndarray:
    """(n, 3) points of :data:`REGION` in front of every camera and inside every image (raw pixels)."""
    out = []
    while sum(len(o) for o in out) < n:
        X = random_points(rng, 4 * n)
        ok = np.ones(len(X), bool)
        for cam in cams:
            uv = cam.project(X)
            ok &= (cam.depth(X) > 0.1) & cam.in_image(uv, margin=-margin)
        out.append(X[ok])
    return np.concatenate(out)[:n]


def same(a, b, rtol=1e-9, atol=1e-9) -> None:
    """Assert equal shapes, NaN and inf in the same places, and values within ``rtol``/``atol``."""
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape
    assert np.array_equal(np.isnan(a), np.isnan(b))
    assert np.array_equal(np.isinf(a), np.isinf(b))
    np.testing.assert_allclose(a, b, rtol=rtol, atol=atol, equal_nan=True)


# ----------------------------------------------------------------------------- synthetic tracker scenes
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


def rays_to(rig: Rig, X: np.ndarray, noise_px: float = 0.0, rng=None):
    """Pixels of X (3,) in every view of ``rig`` (optionally noisy), the cameras' centres, and
    the unit rays through those pixels: (C, 2), (C, 3), (C, 3)."""
    uv = np.stack([cam.project(X[None])[0] for cam in rig])
    if noise_px:
        uv = uv + rng.normal(0, noise_px, uv.shape)
    d = np.stack([cam.rays(uv[i:i + 1])[0] for i, cam in enumerate(rig)])
    return uv, rig.centres, d / np.linalg.norm(d, axis=1, keepdims=True)


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


# ----------------------------------------------------------------------------- fixtures
@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every test run sees the same random cameras and points."""
    return np.random.default_rng(20240607)


@pytest.fixture(scope="session")
def make_camera() -> Callable[..., Camera]:
    """``make_camera(rng, name="cam0", distortion=None|4|5|8, azimuth=None) -> Camera``."""
    return random_camera


@pytest.fixture(scope="session")
def make_rig() -> Callable[..., Rig]:
    """``make_rig(rng, n=4, distortion=None|4|5|8) -> Rig``."""
    return random_rig


@pytest.fixture(scope="session")
def make_points() -> Callable[..., np.ndarray]:
    """``make_points(rng, cams, n, margin=0) -> (n, 3)`` points seen by every camera of ``cams``."""
    return points_seen_by
