"""BVH: the 3D pose as an animated rig for Blender and animation tools (``shared/formats.md``, "Exports").

The paper's 3D pose (Section III-D, last paragraph) has joints, not rotations; a BVH file needs a
rig with fixed bone lengths and per-frame joint rotations. The rig is built from the track's
**median bone lengths** and the rotations are solved so that the rig's forward kinematics puts
every joint where the 3D pose has it, exactly up to the bone-length differences (where a frame's
bone lengths equal the medians, the only error is the file's rounding: micrometres).

COCO-17 has no spine or neck joints; the hierarchy (Y up, metres, the rest pose a T-pose facing
+Z, the person's left at +X)::

    mid_hip (root: position + rotation; the pelvis frame: left hip axis, up towards mid_shoulder)
    |- left_hip -> left_knee -> left_ankle            (rest: down -Y)
    |- right_hip -> right_knee -> right_ankle
    `- spine (at mid_hip, zero offset) -> mid_shoulder (the shoulder frame: shoulder axis, up from mid_hip)
        |- left_shoulder -> left_elbow -> left_wrist  (rest: out +X)
        |- right_shoulder -> right_elbow -> right_wrist (rest: out -X)
        `- neck (at mid_shoulder, zero offset) -> head (mean of the 5 face joints)
            `- nose, left_eye, right_eye, left_ear, right_ear (the face's median shape in the head frame)

The zero-offset ``spine`` and ``neck`` joints give the torso and the head their own rotation, so
the hips, the shoulders and the head are each placed exactly although the trunk bends. A limb
joint turns by the smallest rotation (in its parent's frame) that points its bone at the next
joint; the pelvis, shoulders and head turn to their joints' frames (the head by a least-squares
fit, Kabsch, of the face). The head is left out when the track lacks a face joint.

Axes: BVH is Y up, so world (x, y, z) is written as (y, z, x), as in the TRC file. Rotations are
``Zrotation Xrotation Yrotation`` (intrinsic, degrees, unwrapped in time); a leaf's End Site
continues its bone by a quarter of its length (drawing only).

Shapes: ``xyz`` (T, J, 3) world metres (complete: gaps filled or cut first); rotations (T, 3, 3).
"""

from __future__ import annotations

import io
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import InputError
from .trc import to_y_up

__all__ = ["BODY_JOINTS", "FACE_JOINTS", "Rig", "Motion", "fit_rig", "solve_motion", "fk_error", "bone_deviation",
           "write_bvh"]

BODY_JOINTS = ("left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
               "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle")
FACE_JOINTS = ("nose", "left_eye", "right_eye", "left_ear", "right_ear")
X, Y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
#: limb bones (joint, child)
_LIMBS = tuple((f"{side}_{a}", f"{side}_{b}") for side in ("left", "right")
               for a, b in (("hip", "knee"), ("knee", "ankle"), ("shoulder", "elbow"), ("elbow", "wrist")))
EPS = 1e-9


@dataclass(frozen=True, eq=False)
class Rig:
    """The fixed-bone-length rig: nodes in depth-first order (a parent before its children).

    names (N,), parent (N,) int (-1 for the root), offset (N, 3) BVH metres from the parent in its
    rest frame; lengths: bone name -> median length (m); face: whether the head is in the rig.
    """

    names: tuple[str, ...]
    parent: np.ndarray
    offset: np.ndarray
    lengths: dict
    face: bool

    def index(self, name: str) -> int:
        return self.names.index(name)


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(n, EPS)


def _frame(x_vec: np.ndarray, up_vec: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations whose columns are x = unit(x_vec), y = up_vec made orthogonal to x, z = x × y."""
    x = _unit(x_vec)
    y = _unit(up_vec - np.sum(up_vec * x, axis=-1, keepdims=True) * x)
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def _swing(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(T, 3, 3) smallest rotations taking the unit rest direction ``r`` (3,) to the directions ``v`` (T, 3)."""
    v = _unit(v)
    w = 1.0 + v @ r
    axis = np.cross(np.broadcast_to(r, v.shape), v)
    opposite = w < 1e-12  # half a turn: about any axis perpendicular to r
    if opposite.any():
        perp = np.cross(r, X if abs(r[0]) < 0.9 else Y)
        axis[opposite], w[opposite] = perp / np.linalg.norm(perp), 0.0
    return Rotation.from_quat(np.column_stack([axis, w])).as_matrix().reshape(-1, 3, 3)


def _kabsch(rest: np.ndarray, now: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations R minimising sum |R rest_k - now_tk|^2 (rest (K, 3), now (T, K, 3), both centred)."""
    H = np.einsum("ki,tkj->tij", rest, now)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.swapaxes(Vt, 1, 2) @ np.swapaxes(U, 1, 2)))
    D = np.zeros((len(H), 3, 3))
    D[:, 0, 0] = D[:, 1, 1] = 1.0
    D[:, 2, 2] = d
    return np.swapaxes(Vt, 1, 2) @ D @ np.swapaxes(U, 1, 2)


def _points(xyz: np.ndarray, joints: Sequence[str]) -> dict[str, np.ndarray]:
    """Joint name -> (T, 3) BVH coordinates, plus the derived mid_hip, mid_shoulder and head."""
    y = to_y_up(xyz)
    p = {n: y[:, k] for k, n in enumerate(joints)}
    p["mid_hip"] = 0.5 * (p["left_hip"] + p["right_hip"])
    p["mid_shoulder"] = 0.5 * (p["left_shoulder"] + p["right_shoulder"])
    p["spine"], p["neck"] = p["mid_hip"], p["mid_shoulder"]  # the zero-offset joints
    if all(n in p for n in FACE_JOINTS):
        p["head"] = np.mean([p[n] for n in FACE_JOINTS], axis=0)
    return p


def _head_frame(p: dict[str, np.ndarray]) -> np.ndarray:
    """The head's own frame from the face joints only (x ear to ear, z towards the nose)."""
    x = p["left_ear"] - p["right_ear"]
    fwd = _unit(p["nose"] - p["head"])
    f = _frame(x, np.cross(fwd, _unit(x)))  # up = forward x left
    return f


def _median_length(a: np.ndarray, b: np.ndarray) -> float:
    d = np.linalg.norm(a - b, axis=-1)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else float("nan")


def fit_rig(xyz: np.ndarray, joints: Sequence[str]) -> Rig:
    """The rig of one track from its joints ``xyz`` (T, J, 3) (NaN allowed): median bone lengths,
    and the face's median shape in the head frame. Raises InputError when a body joint is never
    estimated (named)."""
    joints = tuple(joints)
    have = {n for k, n in enumerate(joints) if np.isfinite(xyz[:, k]).all(-1).any()}
    missing = [n for n in BODY_JOINTS if n not in have]
    if missing:
        raise InputError(f"a BVH rig needs {', '.join(BODY_JOINTS)}; never estimated in this track: {', '.join(missing)}",
                         field="--format")
    face = all(n in have for n in FACE_JOINTS)
    p = _points(xyz, joints)
    L = {f"{a}-{b}": _median_length(p[a], p[b]) for a, b in _LIMBS}
    L["hips"] = _median_length(p["left_hip"], p["right_hip"])
    L["shoulders"] = _median_length(p["left_shoulder"], p["right_shoulder"])
    L["trunk"] = _median_length(p["mid_hip"], p["mid_shoulder"])
    nodes: list[tuple[str, str | None, np.ndarray]] = [("mid_hip", None, np.zeros(3))]
    for side, s in (("left", 1.0), ("right", -1.0)):
        nodes += [(f"{side}_hip", "mid_hip", s * 0.5 * L["hips"] * X),
                  (f"{side}_knee", f"{side}_hip", -L[f"{side}_hip-{side}_knee"] * Y),
                  (f"{side}_ankle", f"{side}_knee", -L[f"{side}_knee-{side}_ankle"] * Y)]
    nodes += [("spine", "mid_hip", np.zeros(3)), ("mid_shoulder", "spine", L["trunk"] * Y)]
    for side, s in (("left", 1.0), ("right", -1.0)):
        nodes += [(f"{side}_shoulder", "mid_shoulder", s * 0.5 * L["shoulders"] * X),
                  (f"{side}_elbow", f"{side}_shoulder", s * L[f"{side}_shoulder-{side}_elbow"] * X),
                  (f"{side}_wrist", f"{side}_elbow", s * L[f"{side}_elbow-{side}_wrist"] * X)]
    if face:
        L["neck"] = _median_length(p["mid_shoulder"], p["head"])
        ok = np.isfinite(np.stack([p[n] for n in FACE_JOINTS], 1)).all(axis=(1, 2))
        q = {n: v[ok] for n, v in p.items()}
        F = _head_frame(q)  # (T', 3, 3)
        nodes += [("neck", "mid_shoulder", np.zeros(3)), ("head", "neck", L["neck"] * Y)]
        for n in FACE_JOINTS:  # the face's shape: median of each joint in the head frame
            nodes.append((n, "head", np.median(np.einsum("tji,tj->ti", F, q[n] - q["head"]), axis=0)))
    names = tuple(n for n, _, _ in nodes)
    parent = np.array([-1 if par is None else names.index(par) for _, par, _ in nodes])
    return Rig(names, parent, np.array([o for _, _, o in nodes]), L, face)


@dataclass(frozen=True, eq=False)
class Motion:
    """The rig's motion over T frames: root (T, 3) BVH metres, local (T, N, 3, 3) rotations,
    world (T, N, 3, 3) rotations, fk (T, N, 3) the nodes' positions by forward kinematics."""

    root: np.ndarray
    local: np.ndarray
    world: np.ndarray
    fk: np.ndarray


def solve_motion(rig: Rig, xyz: np.ndarray, joints: Sequence[str]) -> Motion:
    """Per-frame rotations of ``rig`` that put its joints on ``xyz`` (T, J, 3), complete.

    Root to leaves: each bone points from where the rig has put its joint (forward kinematics so
    far) at the pose's next joint, so a bone length that differs from the rig's moves that joint
    along the bone and the error does not build up sideways down the chain."""
    p = _points(xyz, joints)
    T, N = len(xyz), len(rig.names)
    G = np.broadcast_to(np.eye(3), (T, N, 3, 3)).copy()
    fk = np.zeros((T, N, 3))
    i = rig.index

    def place(node: str, rot: np.ndarray) -> None:
        """Give ``node`` the world rotation ``rot`` and place its children."""
        k = i(node)
        G[:, k] = rot
        for c in np.flatnonzero(rig.parent == k):
            fk[:, c] = fk[:, k] + rot @ rig.offset[c]

    def aim(node: str, child: str) -> None:
        par = G[:, rig.parent[i(node)]]
        d = np.einsum("tji,tj->ti", par, p[child] - fk[:, i(node)])  # in the parent's frame
        place(node, par @ _swing(_unit(rig.offset[i(child)]), d))

    fk[:, 0] = p["mid_hip"]
    place("mid_hip", _frame(p["left_hip"] - p["right_hip"], p["mid_shoulder"] - p["mid_hip"]))
    aim("spine", "mid_shoulder")
    place("mid_shoulder", _frame(p["left_shoulder"] - p["right_shoulder"], p["mid_shoulder"] - p["mid_hip"]))
    for a, b in _LIMBS:
        aim(a, b)
    if rig.face:
        aim("neck", "head")
        rest = rig.offset[[i(n) for n in FACE_JOINTS]]
        now = np.stack([p[n] - fk[:, i("head")] for n in FACE_JOINTS], axis=1)
        place("head", _kabsch(rest - rest.mean(0), now - now.mean(1, keepdims=True)))
    for k in range(N):  # leaves keep their parent's frame (no rotation of their own)
        if k not in rig.parent:
            G[:, k] = G[:, rig.parent[k]]
    local = G.copy()
    for k in range(1, N):
        local[:, k] = np.swapaxes(G[:, rig.parent[k]], -1, -2) @ G[:, k]
    return Motion(p["mid_hip"], local, G, fk)


def fk_error(rig: Rig, motion: Motion, xyz: np.ndarray, joints: Sequence[str]) -> np.ndarray:
    """(T, J) distance (m) between the rig's joints and ``xyz`` (NaN for joints not in the rig)."""
    y = to_y_up(xyz)
    err = np.full(xyz.shape[:2], np.nan)
    for k, n in enumerate(joints):
        if n in rig.names:
            err[:, k] = np.linalg.norm(motion.fk[:, rig.index(n)] - y[:, k], axis=-1)
    return err


def bone_deviation(rig: Rig, xyz: np.ndarray, joints: Sequence[str]) -> np.ndarray:
    """(T,) the largest difference (m) in a frame between a bone's length and the rig's (median) one."""
    p = _points(xyz, joints)
    dev = np.zeros(len(xyz))
    for k in range(1, len(rig.names)):
        L = np.linalg.norm(rig.offset[k])
        if L > 0:
            d = np.linalg.norm(p[rig.names[k]] - p[rig.names[rig.parent[k]]], axis=-1)
            dev = np.maximum(dev, np.abs(d - L))
    return dev


def _euler(local: np.ndarray) -> np.ndarray:
    """(T, N, 3, 3) -> (T, N, 3) intrinsic ZXY degrees, unwrapped in time."""
    T, N = local.shape[:2]
    with warnings.catch_warnings():  # gimbal lock: the angles still give the same matrix
        warnings.filterwarnings("ignore", message="Gimbal lock", category=UserWarning)
        e = Rotation.from_matrix(local.reshape(-1, 3, 3)).as_euler("ZXY", degrees=True).reshape(T, N, 3)
    return np.degrees(np.unwrap(np.radians(e), axis=0)) if T > 1 else e


def _xyz(v: np.ndarray) -> str:
    return " ".join(f"{round(float(x), 6) + 0.0:.6f}" for x in v)  # + 0.0: no "-0.000000"


def write_bvh(path: str | Path, rig: Rig, motion: Motion, fps: float) -> Path:
    """Write the BVH file of ``rig`` and ``motion``."""
    path = Path(path)
    N = len(rig.names)
    children = [[c for c in range(N) if rig.parent[c] == k] for k in range(N)]
    out: list[str] = ["HIERARCHY"]

    def node(k: int, depth: int) -> None:
        tab = "\t" * depth
        out.append(f"{tab}{'ROOT' if k == 0 else 'JOINT'} {rig.names[k]}")
        out.append(f"{tab}{{")
        out.append(f"{tab}\tOFFSET {_xyz(rig.offset[k])}")
        out.append(f"{tab}\tCHANNELS " + ("6 Xposition Yposition Zposition " if k == 0 else "3 ")
                   + "Zrotation Xrotation Yrotation")
        for c in children[k]:
            node(c, depth + 1)
        if not children[k]:
            out.extend([f"{tab}\tEnd Site", f"{tab}\t{{",
                    f"{tab}\t\tOFFSET {_xyz(0.25 * rig.offset[k])}", f"{tab}\t}}"])
        out.append(f"{tab}}}")

    node(0, 0)
    T = len(motion.root)
    out += ["MOTION", f"Frames: {T}", f"Frame Time: {1.0 / fps:.8f}"]
    order = []  # the channels' order in a frame line: the nodes in the file's (depth-first) order
    stack = [0]
    while stack:
        k = stack.pop()
        order.append(k)
        stack.extend(reversed(children[k]))
    values = np.concatenate([motion.root, _euler(motion.local)[:, order].reshape(T, -1)], axis=1)
    buf = io.StringIO()
    np.savetxt(buf, values, fmt="%.6f", delimiter=" ")
    with open(path, "w", newline="") as fh:
        fh.write("\n".join(out) + "\n" + buf.getvalue())
    return path
