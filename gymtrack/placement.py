"""The apparatus preset laid on the scene: its bars and blocks in world coordinates, and distances to them.

Paper: Section III-C (the apparatus and its vertical plane). The preset's geometry
(:mod:`gymtrack.apparatus`) is turned about z so that its plane normal is the scene's first
plane's normal, shifted along that normal onto the plane, and along the plane so that its centre
lies under the scene's focus. Used by the analysis (what the body
touches, :mod:`gymtrack.analysis.support`) and by the tracker (where a body can be held up,
:mod:`gymtrack.tracking.reach`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .apparatus import Apparatus, get_apparatus
from .scene import Scene

__all__ = ["Geometry", "EXTRA_BLOCKS", "scene_geometry", "yaw_rotation", "bar_distance", "box_distance", "apparatus_distance"]

#: surfaces the presets leave out that the body lands on or pushes from (preset frame, lo/hi corners):
#: the vault's springboard (its place varies, 2-3 m before the table; 0.12 m high), and the
#: pommel horse's top up to the pommels' height along the whole horse (the hands work on the
#: pommels and on the body beside them; pommels are set 0.40-0.45 m apart)
EXTRA_BLOCKS: dict[str, tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...]] = {
    "vault": (((-3.4, -0.35, 0.0), (-2.0, 0.35, 0.12)),),
    "pommel_horse": (((-0.8, -0.175, 1.03), (0.8, 0.175, 1.15)),),
}


@dataclass(frozen=True)
class Geometry:
    """The scene's surfaces in world coordinates.

    bar_a, bar_b: (B, 3) bar ends; bar_r: (B,) radii; box_lo, box_hi: (Q, 3) block corners
    (blocks, mats and :data:`EXTRA_BLOCKS`; axis-aligned in the preset's frame, which is turned by
    ``yaw`` about z and then moved by ``shift`` (3,) into the world).
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


def yaw_rotation(yaw: float) -> np.ndarray:
    """(3, 3) the turn by ``yaw`` radians about z."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def scene_geometry(scene: Scene) -> Geometry:
    """The apparatus preset of ``scene`` placed on its plane (no apparatus: floor only): turned
    about z so that its plane normal is the scene's first plane's normal, shifted across the plane
    onto it and, along it, so that the preset's focus (1.5 m over the apparatus centre) falls
    under the scene's ``focus`` (a scene in its own frame, ``docs/your-own-data.md`` Option 2)."""
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
    R = yaw_rotation(yaw)
    if scene.focus is not None:  # along the plane, the apparatus centre is under the focus (the presets' convention)
        along = np.asarray(scene.focus, float) - R @ np.asarray(app.focus, float)
        along[2] = 0.0
        if normal is not None:
            along -= normal * float(np.dot(along, normal))  # (across it, the plane says where)
        shift = shift + along
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
        R = yaw_rotation(geo.yaw)
        P = (X - geo.shift) @ R
        out = np.minimum(out, box_distance(P, geo.box_lo, geo.box_hi, on_top).min(-1))
    return out


