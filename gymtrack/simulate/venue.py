"""The venue: four calibrated cameras in two opposite pairs around one apparatus.

Paper: Sections I and III-C. Space in a gymnastics hall allows only a few cameras; the paper
uses four, 1920x1080 at 30 fps, and its failure case is two *opposite* views (lines of sight
meeting at nearly 180 degrees), where triangulation is ill-conditioned along the line joining
the cameras.

Layout (world frame of :mod:`gymtrack.apparatus`):

* ``cam0`` and ``cam1``: the square-on opposite pair, on both sides of the gymnast's vertical
  plane along its normal, a little above the action so that their lines of sight meet at
  166-173 degrees at the apparatus (this is the pair kept for ``n_cam = 2``).
* ``cam2`` and ``cam3``: the diagonal opposite pair, 25-55 degrees off the plane's horizontal
  axis, higher up.

Every camera is 8-15 m from the apparatus centre, 2-5 m high, has a 50-70 degree horizontal
field of view (widened, or the camera moved back, until the performance volume fits) and a
slight lens distortion (``|k1| <= 0.05``).
"""

from __future__ import annotations

import numpy as np

from ..apparatus import Apparatus
from ..geometry.camera import Camera, Rig, look_at
from ..geometry.views import line_of_sight_angle

IMAGE_SIZE = (1920, 1080)
FPS = 30.0
CAMERA_NAMES = ("cam0", "cam1", "cam2", "cam3")
#: Limits every simulated camera respects (checked by the tests).
DISTANCE_RANGE = (8.0, 15.0)
HEIGHT_RANGE = (2.0, 5.0)
HFOV_RANGE_DEG = (50.0, 70.0)
MIN_OPPOSITE_ANGLE_DEG = 166.0
#: Real rigs look slightly down on the apparatus: the pair is not perfectly collinear.
MAX_OPPOSITE_ANGLE_DEG = 173.0


def apparatus_centre(app: Apparatus) -> np.ndarray:
    """(3,) centre of the apparatus' solid parts (bars and blocks), e.g. the vault table."""
    pts = [np.array(b.start) for b in app.bars] + [np.array(b.end) for b in app.bars]
    pts += [np.array(b.lo) for b in app.blocks] + [np.array(b.hi) for b in app.blocks]
    P = np.stack(pts)
    return (P.min(axis=0) + P.max(axis=0)) / 2


def plane_axes(app: Apparatus) -> tuple[np.ndarray, np.ndarray]:
    """(normal, along): horizontal unit normal of the gymnast's plane and the horizontal axis in it."""
    n = np.asarray(app.plane_normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    along = np.array([n[1], -n[0], 0.0])
    if along @ np.array([1.0, 1.0, 0.0]) < 0:
        along = -along
    return n, along


def _required_hfov(R: np.ndarray, C: np.ndarray, pts: np.ndarray, margin: float = 0.9) -> float:
    """Horizontal FOV (deg) a centred pinhole at (R, C) needs to hold ``pts`` (M, 3) with a margin."""
    Xc = (pts - C) @ R.T
    front = Xc[:, 2] > 0.5
    if not front.any():
        return 180.0
    Xc = Xc[front]
    x = np.abs(Xc[:, 0] / Xc[:, 2])
    y = np.abs(Xc[:, 1] / Xc[:, 2]) * IMAGE_SIZE[0] / IMAGE_SIZE[1]
    need = float(np.quantile(np.maximum(x, y), 0.995)) / margin
    return float(np.degrees(2 * np.arctan(need)))


def make_rig(app: Apparatus, rng: np.random.Generator, cover: np.ndarray, aim: np.ndarray | None = None) -> tuple[Rig, dict]:
    """Four cameras around ``app`` that all see the points ``cover`` (M, 3).

    Parameters
    ----------
    app: the apparatus preset.
    rng: random generator (only this function draws from it).
    cover: (M, 3) world points every view should hold (the target's body while performing).
    aim: (3,) point the cameras look at; default the centre of ``cover``'s bounding box.

    Returns
    -------
    (rig, info): info holds the aim point and each camera's distance, height and field of view.
    """
    cover = np.asarray(cover, dtype=np.float64)
    lo, hi = cover.min(axis=0), cover.max(axis=0)
    aim = (lo + hi) / 2 if aim is None else np.asarray(aim, dtype=np.float64)
    app_c = apparatus_centre(app)
    n, along = plane_axes(app)
    W, H = IMAGE_SIZE

    def rot(v, deg):
        a = np.radians(deg)
        c, s = np.cos(a), np.sin(a)
        return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], 0.0])

    # Square-on opposite pair: both sides of the plane, nearly level with the action.
    z_ref = 0.5 * (aim[2] + app_c[2])
    for _ in range(500):
        d = rng.uniform(10.0, 14.0, 2)
        jit = rng.uniform(-4.0, 4.0, 2)
        lo_h, hi_h = max(HEIGHT_RANGE[0], z_ref - 1.5), min(HEIGHT_RANGE[1], z_ref + 2.5)
        h = rng.uniform(lo_h, hi_h, 2)
        C0 = np.array([app_c[0], app_c[1], 0.0]) + d[0] * rot(-n, jit[0])
        C1 = np.array([app_c[0], app_c[1], 0.0]) + d[1] * rot(n, jit[1])
        C0[2], C1[2] = h
        ok = MIN_OPPOSITE_ANGLE_DEG < line_of_sight_angle(C0, C1, app_c) < MAX_OPPOSITE_ANGLE_DEG
        ok &= line_of_sight_angle(C0, C1, aim) > 160.0
        ok &= all(DISTANCE_RANGE[0] + 0.2 < np.linalg.norm(C - app_c) < DISTANCE_RANGE[1] - 0.3 for C in (C0, C1))
        if ok:
            break
    else:  # pragma: no cover - the ranges above always admit a solution
        raise RuntimeError("could not place the square-on camera pair")

    # Diagonal opposite pair.
    for _ in range(500):
        alpha = rng.uniform(25.0, 55.0)
        s_al, s_n = rng.choice([-1.0, 1.0], 2)
        u2 = np.cos(np.radians(alpha)) * s_al * along - np.sin(np.radians(alpha)) * s_n * n
        u3 = rot(-u2, rng.uniform(-10.0, 10.0))
        d = rng.uniform(8.8, 13.5, 2)
        h = rng.uniform(2.8, 5.0, 2)
        C2 = np.array([app_c[0], app_c[1], 0.0]) + d[0] * u2
        C3 = np.array([app_c[0], app_c[1], 0.0]) + d[1] * u3
        C2[2], C3[2] = h
        if all(DISTANCE_RANGE[0] + 0.2 < np.linalg.norm(C - app_c) < DISTANCE_RANGE[1] - 0.3 for C in (C2, C3)):
            break
    else:  # pragma: no cover
        raise RuntimeError("could not place the diagonal camera pair")

    cams, info = [], {"aim": aim.tolist(), "cameras": {}}
    for name, C in zip(CAMERA_NAMES, (C0, C1, C2, C3)):
        target = aim + rng.normal(0.0, 0.15, 3) * np.array([1.0, 1.0, 0.5])
        roll = np.radians(rng.uniform(-1.0, 1.0))
        # Move back along the horizontal line of sight until the volume fits in 70 degrees.
        for _ in range(20):
            R = look_at(C, target, roll)[0]
            need = _required_hfov(R, C, cover)
            far = np.linalg.norm(C - app_c) > DISTANCE_RANGE[1] - 0.8
            if need <= HFOV_RANGE_DEG[1] - 1.0 or far:
                break
            step = np.array([C[0] - target[0], C[1] - target[1], 0.0])
            C = C + 0.5 * step / np.linalg.norm(step)
        hfov = float(np.clip(max(rng.uniform(52.0, 64.0), need), HFOV_RANGE_DEG[0], HFOV_RANGE_DEG[1] - 0.5))
        f = (W / 2) / np.tan(np.radians(hfov) / 2)
        K = np.array([[f, 0.0, W / 2 + rng.uniform(-8, 8)], [0.0, f, H / 2 + rng.uniform(-8, 8)], [0.0, 0.0, 1.0]])
        dist = np.array([rng.uniform(-0.05, 0.05), rng.uniform(-0.01, 0.01), rng.uniform(-5e-4, 5e-4), rng.uniform(-5e-4, 5e-4), 0.0])
        cams.append(Camera(name, IMAGE_SIZE, K, R, -R @ C, dist))
        info["cameras"][name] = {
            "distance_m": float(np.linalg.norm(C - app_c)), "height_m": float(C[2]), "hfov_deg": hfov, "needed_hfov_deg": need,
        }
    return Rig(cams), info
