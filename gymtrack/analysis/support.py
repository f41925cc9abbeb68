"""What the body touches at every frame: the floor, the apparatus, or nothing (airborne).

Paper: Section III-C and III-D (the apparatus and its plane, the performance space). Rule
(``shared/formats.md``, ``support``): a joint within :data:`TOUCH` (0.10 m) of a surface touches
it; the ankles count from the sole (0.04 x the body's height taken off first). Surfaces: the floor
``z = 0``, landing mats where the preset has them (``Apparatus.mats``; none of the presets does),
and the preset's bars (cylinders: bars, rails, beam edge, pommels, rings) and blocks (beam body,
horse, vault table). The preset's geometry is laid on the scene's plane: turned about z so its
plane normal is the scene's first plane's normal and shifted along that normal to the plane
(:mod:`gymtrack.placement`, shared with the tracker's reach rule).
"""

from __future__ import annotations

import numpy as np

from ..placement import Geometry, apparatus_distance, bar_distance
from .joints import I

TOUCH = 0.10  #: metres: a joint this close to a surface touches it
SOLE = 0.04  #: ankle height over the sole, as a fraction of the body's height
TOE = 0.06  #: metres more for a still ankle: a foot on its toes (take-off, landing) has the ankle higher
GRIP_STILL = 2.0  #: m/s: a joint faster than this towards both neighbouring rows passes an apparatus by
TOE_STILL = 1.0  #: m/s: an ankle slower than this (vertically, either side of the frame) may be on its toes
HOLD_SDS = 2.0  #: a wrist within TOUCH + this many sd of a bar may be holding it (:func:`hands_may_hold`)
NONE, FLOOR, APPARATUS = 0, 1, 2  #: support codes (``formats.elements.SUPPORT_NAMES`` order)
ANKLES = (I["left_ankle"], I["right_ankle"])
WRISTS = (I["left_wrist"], I["right_wrist"])


def support(X: np.ndarray, geo: Geometry, height: float, frame: np.ndarray | None = None,
            fps: float = 30.0, sigma: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(M,) support codes (:data:`NONE`, :data:`FLOOR`, :data:`APPARATUS`) and (M,) bool: both wrists
    touch a bar (the hands hold it: circles). X: (M, K, 3); height: the body's height (m); sigma:
    (M, K) the joints' position sd (m): a wrist within :data:`TOUCH` + :data:`HOLD_SDS` sd of a bar
    holds it for the grip (a measured wrist swinging in a giant is 5-20 cm off the bar for a frame
    or two; the support codes keep the plain :data:`TOUCH`).

    Touching the apparatus wins over the floor (hands on the bar, feet on the floor is a mount).
    A frame without any joint is ``none`` only if it has joints; a frame with none at all is NONE
    (the caller masks such frames).
    """
    sole = np.zeros(X.shape[1])
    if np.isfinite(height):
        sole[list(ANKLES)] = SOLE * height
    touch = np.full(X.shape[1], TOUCH)
    if frame is not None and len(frame) > 1:
        touch = np.broadcast_to(touch, X.shape[:2]).copy()
        touch[:, list(ANKLES)] += TOE * _still(X[:, list(ANKLES), 2], frame, fps)
    with np.errstate(invalid="ignore"):
        floor, grasp, solid = _distances(X, geo, sole)
        # a joint sweeping past a bar or rail faster than GRIP_STILL does not hold it
        if frame is not None and len(frame) > 1:
            grasp = np.where(_slow(X, frame, fps, GRIP_STILL), grasp, np.inf)
        app = np.minimum(grasp, solid)
        on_app = np.any(np.nan_to_num(app, nan=np.inf) < touch, axis=1)
        on_floor = np.any(np.nan_to_num(floor, nan=np.inf) < touch, axis=1)
    codes = np.where(on_app, APPARATUS, np.where(on_floor, FLOOR, NONE)).astype(np.int8)
    grip = np.zeros(len(X), bool)
    if len(geo.bar_r):
        w = X[:, list(WRISTS)]
        with np.errstate(invalid="ignore"):
            d = bar_distance(w, geo.bar_a, geo.bar_b, geo.bar_r)  # (M, 2, B)
            reach = TOUCH if sigma is None else TOUCH + HOLD_SDS * np.nan_to_num(sigma[:, list(WRISTS)])
            grip = np.all(np.nan_to_num(d, nan=np.inf).min(-1) < reach, axis=1)  # each hand on a bar or ring
    return codes, grip


def _distances(X: np.ndarray, geo: Geometry, sole: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M, K) each joint's distance (m, the ankles' from the sole) to the floor, to the bars and rings a
    hand holds, and to the other apparatus surfaces. Hands and feet hold and stand; the other joints
    rest on top only (shoulders rising between the parallel bars' rails, or legs swinging past the low
    bar, touch nothing)."""
    body = np.ones(X.shape[1], bool)
    body[list(WRISTS + ANKLES)] = False
    with np.errstate(invalid="ignore"):
        grasp = apparatus_distance(X, geo, bars="grasp")
        grasp[:, body] = apparatus_distance(X[:, body], geo, on_top=True, bars="grasp")
        solid = apparatus_distance(X, geo, bars="solid")
        solid[:, body] = apparatus_distance(X[:, body], geo, on_top=True, bars="solid")
        return X[..., 2] - sole, grasp - sole, solid - sole


def clearance(X: np.ndarray, geo: Geometry, height: float, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M,) the distance (m) from the joint nearest a surface it can touch to that surface, as
    :func:`support` measures it, and (M,) that joint's position sd (``sigma`` (M, K) m); NaN where a
    row has no joint."""
    sole = np.zeros(X.shape[1])
    if np.isfinite(height):
        sole[list(ANKLES)] = SOLE * height
    d = np.fmin.reduce(np.stack(_distances(X, geo, sole)), axis=0)
    d = np.where(np.isfinite(d), d, np.inf)
    k = np.argmin(d, axis=1)
    rows = np.arange(len(X))
    best = d[rows, k]
    return np.where(np.isfinite(best), best, np.nan), np.asarray(sigma, float)[rows, k]


def hands_may_hold(X: np.ndarray, sigma: np.ndarray, geo: Geometry) -> np.ndarray:
    """(M,) bool: a wrist lies within :data:`TOUCH` + :data:`HOLD_SDS` sd (its own position sd,
    ``sigma`` (M, K) m) of a bar or ring -- the noise alone may have taken a holding hand off it."""
    if not len(geo.bar_r):
        return np.zeros(len(X), bool)
    d = apparatus_distance(X[:, list(WRISTS)], geo, bars="grasp")
    with np.errstate(invalid="ignore"):
        return np.any(np.nan_to_num(d, nan=np.inf) < TOUCH + HOLD_SDS * np.nan_to_num(sigma[:, list(WRISTS)]), axis=1)


def _slow(P: np.ndarray, frame: np.ndarray, fps: float, limit: float) -> np.ndarray:
    """(M, n) the points P (M, n, 3) move slower than ``limit`` (m/s) towards the previous or the next row."""
    dt = np.diff(frame)[:, None] / fps
    v = np.linalg.norm(np.diff(P, axis=0), axis=-1) / dt
    inf = np.full((1, P.shape[1]), np.inf)
    with np.errstate(invalid="ignore"):
        return np.nan_to_num(np.fmin(np.vstack([inf, v]), np.vstack([v, inf])), nan=np.inf) < limit


def _still(z: np.ndarray, frame: np.ndarray, fps: float) -> np.ndarray:
    """(M, 2) the ankle's vertical speed is under TOE_STILL towards the previous or the next row."""
    dt = np.diff(frame)[:, None] / fps
    v = np.abs(np.diff(z, axis=0)) / dt
    inf = np.full((1, z.shape[1]), np.inf)
    back, fwd = np.vstack([inf, v]), np.vstack([v, inf])
    with np.errstate(invalid="ignore"):
        return np.nan_to_num(np.fmin(back, fwd), nan=np.inf) < TOE_STILL


def foot_height(X: np.ndarray, height: float) -> np.ndarray:
    """(M, 2) each foot's sole height above the floor (m): the ankle's z minus the sole."""
    return X[:, list(ANKLES), 2] - (SOLE * height if np.isfinite(height) else 0.0)
