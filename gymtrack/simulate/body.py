"""The simulated human body: a COCO-17 skeleton posed per frame, and its 3D extent.

Paper: Section III-A and III-D. A detector boxes the *visible extent of the body*, not a point;
the tracker triangulates box centres and box tops / bottoms (Eq. 13). So the simulator needs the
body's 3D extent for every posture (standing, tucked, piked, inverted, split, laid out, sitting),
and the box in each view is the projection of that extent. Two opposite views then see box
centres that are *different* 3D points, the failure the paper's plane fallback fixes.

Model: 17 COCO joints plus 9 helper points (head top, head centre, chest, hand tips, toes and
heels), each with a padding radius for flesh. A posture is a vector of joint angles
(:data:`ANGLE_NAMES`); forward kinematics gives the points in the body frame (x front, y left,
z up, feet on ``z = 0`` when standing). The body frame is turned into the world by yaw
(heading about world z), pitch (rotation about the body's left axis; positive tips the head
towards the front, a forward salto adds +2 pi) and twist (about the body's long axis).

The *centre* of a body is the centre of the axis-aligned 3D box of its padded points; ``top_z``
and ``bottom_z`` are that box's top and bottom. This is the point a box-centre triangulation
with many views converges to, so it is what the ground truth reports. The centre of mass
(:meth:`BodyModel.com_offset`) is another point: the one gravity moves on a parabola in flight.
"""

from __future__ import annotations

import numpy as np

from ..segments import com_weights

#: COCO-17 joint names, in COCO order (the first 17 body points).
COCO_JOINTS: tuple[str, ...] = (
    "nose", "left_eye", "right_eye", "left_ear", "right_ear",
    "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
    "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle",
)
#: Helper points after the 17 joints (extent only, not written as keypoints).
EXTRA_POINTS: tuple[str, ...] = (
    "head_top", "head_centre", "chest", "left_hand", "right_hand", "left_toe", "right_toe", "left_heel", "right_heel",
)
POINT_NAMES = COCO_JOINTS + EXTRA_POINTS
N_POINTS = len(POINT_NAMES)
_I = {n: i for i, n in enumerate(POINT_NAMES)}
_COM = com_weights()  # the analysis' centre-of-mass weights, by COCO joint name
_COM_IDX = np.array([_I[n] for n in _COM])
_COM_W = np.array(list(_COM.values()))

#: Flesh radius of every point, metres, for a 1.70 m body (scaled with height).
_PAD_170 = np.array(
    [0.02, 0.02, 0.02, 0.03, 0.03,        # nose, eyes, ears
     0.05, 0.05, 0.04, 0.04, 0.03, 0.03,  # shoulders, elbows, wrists
     0.08, 0.08, 0.05, 0.05, 0.04, 0.04,  # hips, knees, ankles
     0.0, 0.09, 0.10, 0.01, 0.01,         # head top, head centre, chest, hand tips
     0.015, 0.015, 0.02, 0.02],           # toes, heels
)

#: Posture angles, degrees. Flexion rotates a limb from hanging down towards the front.
ANGLE_NAMES: tuple[str, ...] = (
    "hip_left", "hip_right", "hip_abduction", "knee_left", "knee_right",
    "shoulder_left", "shoulder_right", "shoulder_abduction", "elbow", "head", "point_feet", "trunk",
)
N_ANGLES = len(ANGLE_NAMES)

# Posture labels (what the detector model and the tests know about a frame).
STAND, WALK, RUN, SALUTE, SIT, CROUCH, TUCK, PIKE, STRADDLE, LAYOUT, ARMS_UP, SPLIT, SUPPORT, L_SIT, CROSS, BALANCE, TURN = range(17)
POSTURE_NAMES: tuple[str, ...] = (
    "stand", "walk", "run", "salute", "sit", "crouch", "tuck", "pike", "straddle", "layout", "arms_up", "split",
    "support", "l_sit", "cross", "balance", "turn",
)
#: Postures in which a body is upright and its extent is the usual standing box.
UPRIGHT_POSTURES = (STAND, WALK, SALUTE)
#: How unusual a posture looks to a person detector trained on pedestrians (0 = ordinary).
UNUSUAL = np.array([0.0, 0.0, 0.2, 0.1, 0.2, 0.5, 0.9, 0.8, 0.8, 0.6, 0.5, 0.7, 0.5, 0.7, 0.7, 0.5, 0.4])

#: Angle vectors of the static postures (degrees, :data:`ANGLE_NAMES` order).
POSTURES: dict[int, np.ndarray] = {
    STAND:    np.array([0, 0, 0, 0, 0, 0, 0, 6, 10, 0, 0, 0], float),
    WALK:     np.array([0, 0, 0, 5, 5, 0, 0, 6, 15, 0, 0, 0], float),
    RUN:      np.array([0, 0, 0, 40, 40, 0, 0, 8, 90, 0, 0, 10], float),
    SALUTE:   np.array([0, 0, 0, 0, 0, 165, 165, 25, 0, -10, 0, 0], float),
    SIT:      np.array([90, 90, 8, 90, 90, 35, 35, 6, 70, 10, 0, 10], float),
    CROUCH:   np.array([70, 70, 5, 105, 105, 70, 70, 10, 10, 0, 0, 35], float),
    TUCK:     np.array([135, 135, 5, 145, 145, 70, 70, 5, 80, 25, 1, 0], float),
    PIKE:     np.array([150, 150, 0, 0, 0, 140, 140, 5, 0, 20, 1, 0], float),
    STRADDLE: np.array([95, 95, 40, 0, 0, 90, 90, 30, 0, 0, 1, 0], float),
    LAYOUT:   np.array([0, 0, 0, 0, 0, 0, 0, 8, 0, 0, 1, 0], float),
    ARMS_UP:  np.array([0, 0, 0, 0, 0, 180, 180, 0, 0, 0, 1, 0], float),
    SPLIT:    np.array([95, -75, 0, 0, 0, 60, 60, 80, 0, 0, 1, 0], float),
    SUPPORT:  np.array([0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0], float),
    L_SIT:    np.array([90, 90, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0], float),
    CROSS:    np.array([0, 0, 0, 0, 0, 0, 0, 90, 0, 0, 1, 0], float),
    BALANCE:  np.array([0, -80, 0, 0, 0, 90, 90, 85, 0, 0, 0, 0], float),
    TURN:     np.array([0, 60, 0, 0, 110, 150, 150, 10, 30, 0, 0, 0], float),
}

# Segment lengths as fractions of body height (anthropometric tables, rounded).
_ANKLE_H, _SHANK, _THIGH, _HIP_W = 0.039, 0.246, 0.245, 0.052
_SHOULDER_H, _SHOULDER_W = 0.818, 0.11
_UPPER_ARM, _FOREARM, _HAND = 0.186, 0.146, 0.108
_HEEL, _TOE = 0.04, 0.11
_GRIP = 0.05  # wrist to the middle of the palm, where a bar is held


def posture_angles(label: int) -> np.ndarray:
    """(A,) angle vector of a static posture label."""
    return POSTURES[label].copy()


def gait_angles(phase: np.ndarray, run: bool = False) -> np.ndarray:
    """(n, A) angles of walking (or running) at gait phases ``phase`` (n,) radians."""
    phase = np.asarray(phase, dtype=np.float64)
    a = np.repeat(POSTURES[RUN if run else WALK][None], phase.size, axis=0)
    s = np.sin(phase)
    hip, knee, arm = (45.0, 95.0, 45.0) if run else (25.0, 40.0, 20.0)
    a[:, 0] = hip * s
    a[:, 1] = -hip * s
    a[:, 3] += knee * np.clip(np.sin(phase - 1.2), 0, None) ** 2
    a[:, 4] += knee * np.clip(np.sin(phase - 1.2 + np.pi), 0, None) ** 2
    a[:, 5] = -arm * s
    a[:, 6] = arm * s
    return a


def _limb(flex: np.ndarray, abd: np.ndarray, side: float) -> np.ndarray:
    """(n, 3) unit direction of a limb flexed by ``flex`` and abducted by ``abd`` (radians)."""
    return np.stack([np.sin(flex) * np.cos(abd), side * np.sin(abd) * np.ones_like(flex), -np.cos(flex) * np.cos(abd)], axis=-1)


def _rot_y(angle: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations about y by ``angle`` (n,) radians (z turns towards x)."""
    c, s = np.cos(angle), np.sin(angle)
    z, o = np.zeros_like(angle), np.ones_like(angle)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def _rot_z(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    z, o = np.zeros_like(angle), np.ones_like(angle)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def orientation(yaw: np.ndarray, pitch: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """(n, 3, 3) body-to-world rotations ``Rz(yaw) Ry(pitch) Rz(twist)``; angles (n,) radians."""
    return _rot_z(np.asarray(yaw, float)) @ _rot_y(np.asarray(pitch, float)) @ _rot_z(np.asarray(twist, float))


def body_axis(yaw: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """(n, 3) world direction from feet to head for yaw and pitch (n,) radians."""
    yaw, pitch = np.asarray(yaw, float), np.asarray(pitch, float)
    return np.stack([np.sin(pitch) * np.cos(yaw), np.sin(pitch) * np.sin(yaw), np.cos(pitch)], axis=-1)


class BodyModel:
    """One person's body of height ``height`` metres.

    All methods are vectorised over frames: ``angles`` (n, A) degrees, ``yaw``/``pitch``/
    ``twist`` (n,) radians.
    """

    def __init__(self, height: float):
        self.height = float(height)
        self.pad = _PAD_170 * (self.height / 1.70)

    # ---------------------------------------------------------------- body frame
    def local_points(self, angles: np.ndarray) -> np.ndarray:
        """(n, N_POINTS, 3) points in the body frame for posture angles (n, A) degrees."""
        deg = np.atleast_2d(np.asarray(angles, dtype=np.float64))
        a = np.radians(deg)
        w = np.clip(deg[:, 10:11], 0.0, 1.0)  # point_feet: a 0..1 blend, not an angle
        n, H = a.shape[0], self.height
        P = np.zeros((n, N_POINTS, 3))
        hip_c = np.array([0.0, 0.0, (_ANKLE_H + _SHANK + _THIGH) * H])
        # Legs.
        for side, hip_i, knee_i, ankle_i, toe_i, heel_i, fa, ka in (
            (1.0, "left_hip", "left_knee", "left_ankle", "left_toe", "left_heel", 0, 3),
            (-1.0, "right_hip", "right_knee", "right_ankle", "right_toe", "right_heel", 1, 4),
        ):
            hip = hip_c + np.array([0.0, side * _HIP_W * H, 0.0])
            thigh = _limb(a[:, fa], a[:, 2], side)
            knee = hip + _THIGH * H * thigh
            shank = _limb(a[:, fa] - a[:, ka], a[:, 2], side)
            ankle = knee + _SHANK * H * shank
            # Foot: flat (perpendicular to the shank) blending to pointed (along the shank).
            flat = _limb(a[:, fa] - a[:, ka] + np.pi / 2, a[:, 2] * 0, side)
            foot = (1 - w) * flat + w * shank
            foot /= np.linalg.norm(foot, axis=-1, keepdims=True)
            P[:, _I[hip_i]] = hip
            P[:, _I[knee_i]] = knee
            P[:, _I[ankle_i]] = ankle
            P[:, _I[toe_i]] = ankle + _TOE * H * foot + _ANKLE_H * H * shank * (1 - w)
            P[:, _I[heel_i]] = ankle - _HEEL * H * foot * (1 - w) + _ANKLE_H * H * shank * (1 - w) * 0.5
        # Upper body: built upright about the hip centre, then leaned forward by `trunk`.
        up = np.zeros((n, 9, 3))
        sh_h = (_SHOULDER_H * H) - hip_c[2]
        neck = np.array([0.0, 0.0, sh_h])
        for k, (side, fa) in enumerate(((1.0, 5), (-1.0, 6))):
            sh = neck + np.array([0.0, side * _SHOULDER_W * H, 0.0])
            ua = _limb(a[:, fa], a[:, 7], side)
            elbow = sh + _UPPER_ARM * H * ua
            fa_dir = _limb(a[:, fa] + a[:, 8], a[:, 7], side)
            wrist = elbow + _FOREARM * H * fa_dir
            up[:, k] = sh
            up[:, 2 + k] = elbow
            up[:, 4 + k] = wrist
            up[:, 6 + k] = wrist + _HAND * H * fa_dir
        up[:, 8] = np.array([0.03 * H, 0.0, 0.72 * H - hip_c[2]])  # chest
        head = np.array([
            [0.055, 0.0, 0.100], [0.045, 0.020, 0.115], [0.045, -0.020, 0.115],
            [0.0, 0.045, 0.105], [0.0, -0.045, 0.105], [0.0, 0.0, 0.182], [-0.01, 0.0, 0.115],
        ]) * H
        hr = _rot_y(a[:, 9])  # head nods forward about the neck
        head_pts = neck + np.einsum("nij,kj->nki", hr, head)
        tr = _rot_y(a[:, 11])
        up = np.einsum("nij,nkj->nki", tr, up)
        head_pts = np.einsum("nij,nkj->nki", tr, head_pts)
        up += hip_c
        head_pts += hip_c
        for k, name in enumerate(("left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
                                  "left_hand", "right_hand", "chest")):
            P[:, _I[name]] = up[:, k]
        for k, name in enumerate(("nose", "left_eye", "right_eye", "left_ear", "right_ear", "head_top", "head_centre")):
            P[:, _I[name]] = head_pts[:, k]
        return P

    # ---------------------------------------------------------------- world frame
    def oriented(self, angles, yaw, pitch, twist) -> tuple[np.ndarray, np.ndarray]:
        """Posed points relative to the body centre.

        Returns
        -------
        rel: (n, N_POINTS, 3) world-oriented points minus the centre of their padded 3D box.
        half: (n, 3) half-extent of that box (so ``top_z = centre_z + half[:, 2]``).
        """
        R = orientation(yaw, pitch, twist)
        Q = np.einsum("nij,nkj->nki", R, self.local_points(angles))
        lo = (Q - self.pad[None, :, None]).min(axis=1)
        hi = (Q + self.pad[None, :, None]).max(axis=1)
        c = (lo + hi) / 2
        return Q - c[:, None, :], (hi - lo) / 2

    def com_offset(self, angles, yaw, pitch, twist) -> np.ndarray:
        """(n, 3) the centre of mass relative to the centre: de Leva's segments on the COCO joints
        (:func:`gymtrack.segments.com_weights`, the analysis' own weights)."""
        rel, _ = self.oriented(angles, yaw, pitch, twist)
        return np.einsum("k,nkd->nd", _COM_W, rel[:, _COM_IDX])

    def grip_offset(self, rel: np.ndarray) -> np.ndarray:
        """(n, 3) the point between the palms, relative to the centre, from ``rel`` of :meth:`oriented`."""
        wl, wr = rel[:, _I["left_wrist"]], rel[:, _I["right_wrist"]]
        hl, hr = rel[:, _I["left_hand"]], rel[:, _I["right_hand"]]
        f = _GRIP / _HAND
        return 0.5 * ((wl + f * (hl - wl)) + (wr + f * (hr - wr)))

    def centre_on_feet(self, xy: np.ndarray, support_z, angles, yaw, pitch, twist) -> np.ndarray:
        """(n, 3) centres that put the body's lowest point on ``support_z`` at horizontal ``xy`` (n, 2)."""
        _, half = self.oriented(angles, yaw, pitch, twist)
        z = np.asarray(support_z, dtype=np.float64) + half[:, 2]
        return np.column_stack([np.asarray(xy, float).reshape(-1, 2), np.broadcast_to(z, (half.shape[0],))])

    def centre_on_grip(self, grip: np.ndarray, angles, yaw, pitch, twist) -> np.ndarray:
        """(n, 3) centres that put the palms on ``grip`` (n, 3), e.g. a bar or a ring."""
        rel, _ = self.oriented(angles, yaw, pitch, twist)
        return np.asarray(grip, dtype=np.float64) - self.grip_offset(rel)

    def grip_radius(self, angles: np.ndarray) -> float:
        """Distance from the palms to the body centre in a posture (A,), e.g. the giant's radius."""
        rel, _ = self.oriented(np.asarray(angles)[None], np.zeros(1), np.zeros(1), np.zeros(1))
        return float(np.linalg.norm(self.grip_offset(rel)[0]))

    def world_points(self, centre, angles, yaw, pitch, twist) -> tuple[np.ndarray, np.ndarray]:
        """(n, N_POINTS, 3) world points and (n, 2) ``[top_z, bottom_z]`` for centres (n, 3)."""
        rel, half = self.oriented(angles, yaw, pitch, twist)
        centre = np.asarray(centre, dtype=np.float64)
        pts = centre[:, None, :] + rel
        return pts, np.column_stack([centre[:, 2] + half[:, 2], centre[:, 2] - half[:, 2]])
