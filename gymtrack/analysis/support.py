"""What the body touches at every frame: the floor, the apparatus, or nothing (airborne).

Paper: Section III-C and III-D (the apparatus and its plane, the performance space). Rule
(``shared/formats.md``, ``support``): a joint within :data:`TOUCH` (0.10 m) of a surface touches
it; the ankles count from the sole (0.04 x the body's height taken off first). Surfaces: the floor
``z = 0``, landing mats where the preset has them (``Apparatus.mats``; none of the presets does),
and the preset's bars (cylinders: bars, rails, beam edge, pommels, rings) and blocks (beam body,
horse, vault table). The preset's geometry is laid on the scene's plane: turned about z so its
plane normal is the scene's first plane's normal and shifted along that normal to the plane.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..apparatus import Apparatus, get_apparatus
from ..scene import Scene
from .joints import I

#: surfaces the presets leave out that the body lands on or pushes from (preset frame, lo/hi corners):
#: the vault's springboard (its place varies, 2-3 m before the table; 0.12 m high), and the
#: pommel horse's top up to the pommels' height along the whole horse (the hands work on the
#: pommels and on the body beside them; pommels are set 0.40-0.45 m apart)
EXTRA_BLOCKS: dict[str, tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...]] = {
    "vault": (((-3.4, -0.35, 0.0), (-2.0, 0.35, 0.12)),),
    "pommel_horse": (((-0.8, -0.175, 1.03), (0.8, 0.175, 1.15)),),
}
TOUCH = 0.10  #: metres: a joint this close to a surface touches it
SOLE = 0.04  #: ankle height over the sole, as a fraction of the body's height
TOE = 0.06  #: metres more for a still ankle: a foot on its toes (take-off, landing) has the ankle higher
GRIP_STILL = 2.0  #: m/s: a joint faster than this towards both neighbouring rows passes an apparatus by
TOE_STILL = 1.0  #: m/s: an ankle slower than this (vertically, either side of the frame) may be on its toes
HOLD_SDS = 2.0  #: a wrist within TOUCH + this many sd of a bar may be holding it (:func:`hands_may_hold`)
NONE, FLOOR, APPARATUS = 0, 1, 2  #: support codes (``formats.elements.SUPPORT_NAMES`` order)
ANKLES = (I["left_ankle"], I["right_ankle"])
WRISTS = (I["left_wrist"], I["right_wrist"])


@dataclass(frozen=True)
class Geometry:
    """The scene's surfaces in world coordinates.

    bar_a, bar_b: (B, 3) bar ends; bar_r: (B,) radii; box_lo, box_hi: (Q, 3) block corners
    (axis-aligned in the preset's frame, turned by ``yaw`` about ``pivot``); mats: (T, 6) boxes.
    apparatus: the preset name or None; plane_normal: (3,) unit or None; somersault_axis: (3,) unit
    or None, the preset's :attr:`~gymtrack.apparatus.Apparatus.somersault_axis` laid on the plane
    (the plane's normal where the scene names no apparatus).
    """

    apparatus: str | None
    bar_a: np.ndarray
    bar_b: np.ndarray
    bar_r: np.ndarray
    box_lo: np.ndarray
    box_hi: np.ndarray
    yaw: float
    shift: np.ndarray
    plane_normal: np.ndarray | None
    somersault_axis: np.ndarray | None = None

    @property
    def has_apparatus(self) -> bool:
        return len(self.bar_r) + len(self.box_lo) > 0


def _rot(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def scene_geometry(scene: Scene) -> Geometry:
    """The apparatus preset of ``scene`` placed on its plane (no apparatus: floor only)."""
    normal = np.asarray(scene.planes[0].normal, float) if scene.planes else None
    if normal is not None and abs(normal[2]) > 1e-6:
        normal = None  # a somersault axis must be horizontal; a tilted plane is not an apparatus plane
    empty3 = np.zeros((0, 3))
    if scene.apparatus is None:
        return Geometry(None, empty3, empty3, np.zeros(0), empty3, empty3, 0.0, np.zeros(3), normal, normal)
    app: Apparatus = get_apparatus(scene.apparatus)
    yaw, shift = 0.0, np.zeros(3)
    if normal is not None:
        pn = np.asarray(app.plane_normal, float)
        yaw = float(np.arctan2(normal[1], normal[0]) - np.arctan2(pn[1], pn[0]))
        yaw = (yaw + np.pi / 2) % np.pi - np.pi / 2  # a normal and its opposite are one plane
        pp = np.asarray(scene.planes[0].point, float)
        shift = normal * float(np.dot(pp - np.asarray(app.plane_point, float), normal))
    R = _rot(yaw)
    bars = app.bars
    a = np.array([b.start for b in bars], float).reshape(-1, 3) @ R.T + shift
    b = np.array([b.end for b in bars], float).reshape(-1, 3) @ R.T + shift
    r = np.array([b.radius for b in bars], float)
    blocks = tuple(app.blocks) + tuple(getattr(app, "mats", ()))
    extra = EXTRA_BLOCKS.get(app.name, ())
    lo = np.array([k.lo for k in blocks] + [e[0] for e in extra], float).reshape(-1, 3)
    hi = np.array([k.hi for k in blocks] + [e[1] for e in extra], float).reshape(-1, 3)
    axis = None
    if normal is not None:  # the preset's axis turned with it, its sign following the scene's normal
        axis = R @ np.asarray(app.somersault_axis, float)
        axis *= np.sign(np.dot(R @ np.asarray(app.plane_normal, float), normal)) or 1.0
    return Geometry(app.name, a, b, r, lo, hi, yaw, shift, normal, axis)


def bar_distance(P: np.ndarray, a: np.ndarray, b: np.ndarray, r: np.ndarray, on_top: bool = False) -> np.ndarray:
    """(..., B) distance from points P (..., 3) to the surfaces of B cylinders (axis a-b, radius r);
    ``on_top``: inf where the point lies below the axis (it cannot rest on the bar)."""
    ab = b - a
    t = np.clip(np.einsum("...bk,bk->...b", P[..., None, :] - a, ab) / np.maximum(np.sum(ab * ab, -1), 1e-12), 0, 1)
    closest = a + t[..., None] * ab
    d = np.linalg.norm(P[..., None, :] - closest, axis=-1) - r
    return np.where(P[..., None, 2] >= closest[..., 2], d, np.inf) if on_top else d


def box_distance(P: np.ndarray, lo: np.ndarray, hi: np.ndarray, on_top: bool = False) -> np.ndarray:
    """(..., Q) distance from points P (..., 3) to Q axis-aligned boxes (0 inside); ``on_top``: inf
    where the point lies below the box's top."""
    d = np.linalg.norm(np.maximum(np.maximum(lo - P[..., None, :], P[..., None, :] - hi), 0.0), axis=-1)
    return np.where(P[..., None, 2] >= hi[:, 2], d, np.inf) if on_top else d


def apparatus_distance(X: np.ndarray, geo: Geometry, on_top: bool = False, bars: str = "all") -> np.ndarray:
    """(..., K) each joint's distance to the nearest apparatus surface (inf without an apparatus);
    ``on_top``: only surfaces the joint lies on top of; ``bars``: ``all`` surfaces, ``grasp`` the bars
    and rings a hand holds only, ``solid`` every surface but those."""
    out = np.full(X.shape[:-1], np.inf)
    grasp = np.full(len(geo.bar_r), geo.apparatus != "balance_beam")  # the beam's "bar" is its top edge
    keep = {"all": np.ones(len(geo.bar_r), bool), "grasp": grasp, "solid": ~grasp}[bars]
    if keep.any():
        out = np.minimum(out, bar_distance(X, geo.bar_a[keep], geo.bar_b[keep], geo.bar_r[keep], on_top).min(-1))
    if bars == "grasp":
        return out
    if len(geo.box_lo):
        # blocks are axis-aligned in the preset's frame: take the points back into it
        R = _rot(geo.yaw)
        P = (X - geo.shift) @ R
        out = np.minimum(out, box_distance(P, geo.box_lo, geo.box_hi, on_top).min(-1))
    return out


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
