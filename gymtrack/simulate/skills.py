"""The target gymnast's routine on each apparatus: walking in, salute, mount, skills, dismount,
landing, salute, walking out.

Paper: Section III-C (the gymnast's centre keeps to a vertical plane during much of the
routine, with moments off it) and III-D (the performance space; the target's top and bottom
rise above ``h_top`` / ``h_bot`` once the routine starts). Section IV lists the seven apparatus.

Every routine is built from the physics primitives of :mod:`gymtrack.simulate.motion`, with
per-routine randomness (body height, skill choice and order, speeds, heights, rotations):

* balance beam: walks, turns, leaps rising 0.3-0.5 m, jumps, saltos, walkovers and balances
  along the 5 m beam, a springboard mount and a salto dismount off the end;
* pommel horse: circles of ~1 s period and 0.2-0.4 m radius travelling along the horse, flairs,
  scissors, a handstand dismount to the side;
* vault: a 7.5-8.5 m/s run-up of up to 25 m, hurdle, board, pre-flight, table, post-flight peaking
  at 2.4-3.0 m, landing (a second vault if time allows);
* still rings: coach lift to hang (centre ~1.8 m), swings, support, L-sit, press to handstand
  (centre ~3.8 m), cross, swings to a salto dismount;
* horizontal bar and uneven bars: giants (centre circling ~1.0 m around the bar, 1.3-1.6 s a
  turn), casts, releases and regrasps, transitions between the uneven bars, a salto dismount;
* parallel bars: support swings about the shoulders, handstands, walking on the hands, a
  release salto, a moment on one rail, a salto dismount.

Off-plane drift (a few cm on beam and rings, up to 0.5 m on the bars) is added by
:func:`add_drift`, linear in time during flights so that gravity stays the only force there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import distance_transform_edt, gaussian_filter1d

from ..apparatus import Apparatus
from . import body as B
from .motion import (
    DISMOUNT, LANDING, MOUNT, OFF_PLANE, RUN_UP, SALUTE, SKILL, WAIT, WALK, Motion, MotionBuilder, smoothstep, wrap_angle,
)

TWO_PI = 2 * np.pi
CROUCH_LIGHT = np.array([35, 35, 3, 55, 55, 40, 40, 8, 10, 0, 0.6, 15], float)
CROUCH_MID = np.array([55, 55, 4, 80, 80, 55, 55, 9, 10, 0, 0.3, 25], float)
PUSH = np.array([10, 10, 0, 15, 15, 60, 60, 5, 10, 0, 0.8, 5], float)  # legs nearly extended at take-off


@dataclass
class Event:
    """Something other people react to: a coach ``lift`` (mount on bars / rings) or ``spot``."""

    kind: str
    start: int
    stop: int
    xy: tuple[float, float]


@dataclass
class Layout:
    """Where things are around the apparatus (chosen before anyone moves).

    judges_xy: (2,) centre of the judges' table; judge_side: +1 / -1 along the plane normal.
    """

    judges_xy: np.ndarray
    judge_side: float


@dataclass
class Choreography:
    """Shared state of one target routine being built."""

    app: Apparatus
    b: MotionBuilder
    rng: np.random.Generator
    layout: Layout
    end_frame: int
    events: list[Event] = field(default_factory=list)
    _phase: int = SKILL  #: phase label of the jump preparations (mount, skill or dismount)

    # ------------------------------------------------------------------ small helpers
    @property
    def fps(self) -> float:
        return self.b.fps

    @property
    def short(self) -> bool:
        """A short routine (under 25 s): walking in and the opening salute are kept brief."""
        return self.end_frame / self.fps < 25.0

    def entry(self, spot, far) -> np.ndarray:
        """Where the gymnast walks in from: ``far``, or much nearer ``spot`` in a short routine."""
        spot, far = np.asarray(spot, float), np.asarray(far, float)
        return spot + (0.35 if self.short else 1.0) * (far - spot)

    @property
    def left(self) -> float:
        """Seconds left before the routine must end."""
        return (self.end_frame - self.b.n) / self.fps

    def feet_centre(self, xy, support_z: float, angles, yaw: float, pitch: float, twist: float = 0.0) -> np.ndarray:
        return self.b.body.centre_on_feet(np.asarray(xy, float)[None], support_z, np.asarray(angles)[None], [yaw], [pitch], [twist])[0]

    def grip_centre(self, grip, angles, yaw: float, pitch: float, twist: float = 0.0) -> np.ndarray:
        return self.b.body.centre_on_grip(np.asarray(grip, float)[None], np.asarray(angles)[None], [yaw], [pitch], [twist])[0]

    def yaw_to(self, xy) -> float:
        d = np.asarray(xy, float) - self.b.centre[:2]
        return float(np.arctan2(d[1], d[0]))

    def salute(self, support_z: float = 0.0, seconds: float | None = None) -> None:
        """Face the judges, raise the arms, lower them."""
        b = self.b
        yaw = self.yaw_to(self.layout.judges_xy)
        b.stand(0.5, support_z, B.STAND, SALUTE, yaw=yaw)
        hold = self.rng.uniform(0.6, 1.0) if seconds is None else seconds
        if self.short and self.b.n < self.end_frame / 3:
            hold = 0.2
        b.pose_on_feet(hold + 0.4, support_z, [(0.35, B.posture_angles(B.SALUTE)), (1.0, B.posture_angles(B.SALUTE))],
                       posture=B.SALUTE, phase=SALUTE)
        b.pose_on_feet(0.4, support_z, [(1.0, B.posture_angles(B.STAND))], posture=B.SALUTE, phase=SALUTE)

    def jump_prep(self, support_z: float, seconds: float = 0.25) -> None:
        """Bend the knees, then push off (the flight that follows starts from a moving body)."""
        self.b.pose_on_feet(seconds, support_z, [(1.0, CROUCH_LIGHT)], posture=B.CROUCH, phase=self._phase)
        self.b.push(support_z, 0.13, PUSH, posture=B.STAND, phase=self._phase)

    def land(self, support_z: float, seconds: float = 0.7, phase: int = LANDING) -> None:
        """Absorb a landing (the legs bend on into a crouch), stand up, fold any twist into the heading."""
        self.b.fold_twist()
        self.b.absorb(support_z, self.rng.uniform(0.15, 0.2), B.posture_angles(B.CROUCH), phase=phase)
        self.b.pose_on_feet(seconds, support_z, [(1.0, B.posture_angles(B.STAND))], posture=B.STAND, phase=phase)

    def flight_to_floor(self, xy, apex: float, rotation: float, twist: float = 0.0, shape: int = B.TUCK,
                        support_z: float = 0.0, phase: int = DISMOUNT, yaw_end: float | None = None) -> None:
        """A salto (``rotation`` radians of pitch, ``twist`` about the long axis) landing in a crouch at ``xy``."""
        b = self.b
        pitch_end = b.pitch + rotation
        pitch_end = np.round(pitch_end / TWO_PI) * TWO_PI  # land upright
        yaw1 = b.yaw if yaw_end is None else yaw_end
        land = CROUCH_LIGHT  # contact; the legs bend on in land()
        end = self.feet_centre(xy, support_z, land, yaw1, pitch_end, b.twist + twist)
        n = b.flight_frames(b.centre[2], end[2], apex)
        sh = B.posture_angles(shape)
        b.flight(end, n, pitch_end, twist_end=b.twist + twist, yaw_end=yaw1,
                 angle_keys=[(0.3, sh), (0.7, sh), (1.0, land)], posture=shape, phase=phase)

    def walk_out(self, xy, support_z: float = 0.0) -> None:
        self.b.walk_to(xy, self.rng.uniform(1.1, 1.5), support_z, WALK)

    def pad_to_end(self, xy_away) -> None:
        """Fill the remaining frames walking away / standing outside the performance space."""
        b = self.b
        if b.n < self.end_frame:
            rest = (self.end_frame - b.n) / self.fps
            d = np.asarray(xy_away, float) - b.centre[:2]
            dist = float(np.linalg.norm(d))
            walk = min(dist, 1.2 * max(rest - 0.5, 0.0))
            if walk > 0.3:
                b.walk_to(b.centre[:2] + d / dist * walk, 1.2, 0.0, WALK)
            if b.n < self.end_frame:
                b.stand((self.end_frame - b.n) / self.fps, 0.0, B.STAND, WAIT)
        if b.n > self.end_frame:
            b.truncate(b.n - self.end_frame)

    def outside_point(self, side: float, margin: float = 1.5, along: float | None = None) -> np.ndarray:
        """A floor point ``margin`` metres outside the performance space on ``side`` of the plane."""
        s = np.asarray(self.app.performance_space)
        if self.app.along_axis:
            x = self.rng.uniform(s[0] + 0.5, s[3] - 0.5) if along is None else along
            y = (s[4] + margin) if side > 0 else (s[1] - margin)
            return np.array([x, y])
        y = self.rng.uniform(s[1] + 0.5, s[4] - 0.5) if along is None else along
        x = (s[3] + margin) if side > 0 else (s[0] - margin)
        return np.array([x, y])


# ====================================================================== balance beam
BEAM_Z = 1.25
BEAM_HALF = 2.5


def _beam(c: Choreography) -> None:
    b, rng = c.b, c.rng
    h0 = rng.choice([-1.0, 1.0])  # direction of the mount
    e0 = -h0 * BEAM_HALF
    board = np.array([e0 - h0 * 0.9, 0.0])
    entry = c.entry(board, [board[0] - h0 * rng.uniform(0.3, 1.0), -c.layout.judge_side * rng.uniform(1.8, 2.4)])
    b.place(entry, 0.0, float(np.arctan2(board[1] - entry[1], board[0] - entry[0])))
    b.walk_to(board, rng.uniform(1.1, 1.4), 0.0, WALK)
    c.salute()
    # Mount: springboard jump onto the beam end.
    yaw0 = 0.0 if h0 > 0 else np.pi
    b.stand(0.4, 0.0, B.STAND, WAIT, yaw=yaw0)
    c._phase = MOUNT
    c.jump_prep(0.0, 0.3)
    land = CROUCH_LIGHT
    end = c.feet_centre((e0 + h0 * 0.45, 0.0), BEAM_Z, land, b.yaw, b.pitch)
    b.flight(end, b.flight_frames(b.centre[2], end[2], end[2] + rng.uniform(0.2, 0.35)), b.pitch,
             angle_keys=[(0.3, B.posture_angles(B.TUCK) * 0.6), (1.0, land)], posture=B.CROUCH, phase=MOUNT)
    b.absorb(BEAM_Z, 0.12, CROUCH_MID, phase=MOUNT)
    b.pose_on_feet(0.5, BEAM_Z, [(1.0, B.posture_angles(B.STAND))], posture=B.STAND, phase=MOUNT)
    c._phase = SKILL

    lim = BEAM_HALF - 0.35

    def reserve() -> float:  # dismount, landing, salute, and the walk to the nearer end first
        return 6.0 + max(0.0, 1.9 - abs(b.centre[0])) / 0.8

    while c.left > reserve():
        n0 = b.n
        x = b.centre[0]
        h = 1.0 if np.cos(b.yaw) > 0 else -1.0
        room = h * lim - x if h > 0 else x + lim  # metres ahead before the end
        skill = rng.choice(["walk", "leap", "jump", "salto", "walkover", "balance", "turn"], p=[0.22, 0.16, 0.12, 0.14, 0.12, 0.12, 0.12])
        need = {"walk": 1.0, "leap": 1.6, "jump": 0.4, "salto": 0.0, "walkover": 1.3, "balance": 0.0, "turn": 0.0}[skill]
        back = skill == "salto"
        if (not back and room < need) or (back and (lim - abs(x)) < 0.6 and np.sign(x) == -h):
            skill = "turn"
        if skill == "walk":
            d = min(rng.uniform(0.8, 2.0), room)
            b.walk_to((x + h * d, 0.0), rng.uniform(0.5, 0.9), BEAM_Z, SKILL, lateral=0.015)
        elif skill == "turn":
            b.turn(np.pi * rng.choice([-1.0, 1.0]) * (1.0 if rng.random() < 0.8 else 2.0), rng.uniform(0.9, 1.4), BEAM_Z)
        elif skill in ("leap", "jump"):
            c.jump_prep(BEAM_Z, 0.25)
            d = rng.uniform(0.9, min(1.5, room)) if skill == "leap" else rng.uniform(0.0, 0.3)
            shape = B.SPLIT if skill == "leap" else rng.choice([B.TUCK, B.STRADDLE, B.SPLIT])
            end = c.feet_centre((b.centre[0] + h * d, 0.0), BEAM_Z, CROUCH_LIGHT, b.yaw, b.pitch)
            apex = b.centre[2] + rng.uniform(0.3, 0.5)
            sh = B.posture_angles(shape)
            b.flight(end, b.flight_frames(b.centre[2], end[2], apex), b.pitch, angle_keys=[(0.3, sh), (0.7, sh), (1.0, CROUCH_LIGHT)],
                     posture=shape, phase=SKILL)
            b.absorb(BEAM_Z, 0.12, CROUCH_MID, phase=SKILL)
            b.pose_on_feet(0.4, BEAM_Z, [(1.0, B.posture_angles(B.STAND))], posture=B.STAND, phase=SKILL)
        elif skill == "salto":
            c.jump_prep(BEAM_Z, 0.3)
            d = -h * rng.uniform(0.1, 0.4)
            pitch_end = b.pitch - TWO_PI
            end = c.feet_centre((b.centre[0] + d, 0.0), BEAM_Z, CROUCH_LIGHT, b.yaw, pitch_end)
            apex = b.centre[2] + rng.uniform(0.5, 0.7)
            sh = B.posture_angles(rng.choice([B.TUCK, B.TUCK, B.PIKE]))
            b.flight(end, b.flight_frames(b.centre[2], end[2], apex), pitch_end, angle_keys=[(0.3, sh), (0.7, sh), (1.0, CROUCH_LIGHT)],
                     posture=B.TUCK, phase=SKILL)
            b.absorb(BEAM_Z, 0.12, CROUCH_MID, phase=SKILL)
            b.pose_on_feet(0.5, BEAM_Z, [(1.0, B.posture_angles(B.STAND))], posture=B.STAND, phase=SKILL)
        elif skill == "walkover":
            d = rng.uniform(1.0, 1.3)
            pitch_end = b.pitch + TWO_PI
            end = c.feet_centre((x + h * d, 0.0), BEAM_Z, B.posture_angles(B.STAND), b.yaw, pitch_end)
            split_hs = np.array([80, -80, 0, 0, 0, 180, 180, 0, 0, 0, 1, 0], float)
            b.transition(rng.uniform(1.1, 1.5), end, pitch_end=pitch_end, posture=B.ARMS_UP, phase=SKILL, arc=(0.0, 0.0, 0.22),
                         angle_keys=[(0.3, B.posture_angles(B.ARMS_UP)), (0.5, split_hs), (0.75, split_hs), (1.0, B.posture_angles(B.STAND))])
        elif skill == "balance":
            t = rng.uniform(1.5, 2.5)
            bal = B.posture_angles(B.BALANCE)
            b.pose_on_feet(t, BEAM_Z, [(0.25, bal), (0.8, bal), (1.0, B.posture_angles(B.STAND))],
                           pitch_keys=[(0.25, 0.7), (0.8, 0.7), (1.0, 0.0)], posture=B.BALANCE, phase=SKILL)
        if c.left < reserve():  # the skill ran into the time kept for the dismount: undo it
            b.truncate(b.n - n0)
            break

    # Dismount: to the end, turn to face in, back salto off the end.
    h_end = 1.0 if b.centre[0] >= 0 else -1.0
    x_d = h_end * rng.uniform(1.7, 2.1)
    if abs(x_d - b.centre[0]) > 0.05:
        b.walk_to((x_d, 0.0), rng.uniform(0.8, 1.0), BEAM_Z, SKILL, lateral=0.015)
    face_in = 0.0 if h_end < 0 else np.pi
    b.stand(0.5, BEAM_Z, B.STAND, SKILL, yaw=face_in)
    c._phase = DISMOUNT
    c.jump_prep(BEAM_Z, 0.3)
    n_salto = 1 if rng.random() < 0.5 else 2
    c.flight_to_floor((h_end * rng.uniform(3.1, 3.6), 0.0), b.centre[2] + rng.uniform(0.6, 0.9) + 0.25 * (n_salto - 1),
                      -TWO_PI * n_salto, twist=np.pi * rng.choice([0, 0, 1, 2]) if n_salto == 1 else 0.0,
                      shape=rng.choice([B.TUCK, B.PIKE]) if n_salto == 2 else rng.choice([B.TUCK, B.LAYOUT]))
    c.land(0.0)
    c._phase = SKILL
    c.salute()
    c.walk_out(c.outside_point(-c.layout.judge_side, rng.uniform(1.5, 2.5)))
    c.pad_to_end(c.outside_point(-c.layout.judge_side, 4.0))


# ====================================================================== pommel horse
POMMEL_Z = 1.15


def _pommel(c: Choreography) -> None:
    b, rng = c.b, c.rng
    sy = -c.layout.judge_side  # approach from the far side
    x0 = rng.uniform(-0.3, 0.3)
    spot = np.array([x0, sy * 0.85])
    entry = c.entry(spot, [x0 + rng.uniform(-1.0, 1.0), sy * rng.uniform(2.2, 2.8)])
    b.place(entry, 0.0, float(np.arctan2(spot[1] - entry[1], spot[0] - entry[0])))
    b.walk_to(spot, rng.uniform(1.1, 1.4), 0.0, WALK)
    c.salute()
    yaw_in = float(np.arctan2(-sy, 0.0))  # facing the horse
    b.stand(0.4, 0.0, B.STAND, WAIT, yaw=yaw_in)
    # Mount: jump to front support on the pommels.
    grip = np.array([x0, 0.0, POMMEL_Z])
    sup = B.posture_angles(B.SUPPORT)
    c._phase = MOUNT
    c.jump_prep(0.0, 0.25)
    end = c.grip_centre(grip, sup, b.yaw, b.upright_pitch)
    b.flight(end, b.flight_frames(b.centre[2], end[2], end[2] + 0.12), b.pitch, angle_keys=[(1.0, sup)], posture=B.SUPPORT, phase=MOUNT)
    b.hold_grip(grip, 0.4, b.yaw, sup, B.SUPPORT, MOUNT)

    reserve = 6.0
    xc = x0  # the circles' axis along the horse
    phi = float(np.arctan2(sy, 0.0))  # legs start on the approach side
    z_c = POMMEL_Z + 0.28 + rng.uniform(-0.03, 0.03)
    while c.left > reserve:
        n0, saved = b.n, (xc, phi)
        kind = rng.choice(["circles", "flairs", "scissors"], p=[0.55, 0.25, 0.2])
        if kind in ("circles", "flairs"):
            n_c = int(rng.integers(3, 8))
            period = rng.uniform(0.9, 1.1)
            r = rng.uniform(0.2, 0.32) if kind == "circles" else rng.uniform(0.32, 0.4)
            x_to = float(np.clip(xc + rng.uniform(-0.8, 0.8), -0.55, 0.55))
            n = b.frames_for(n_c * period)
            t = np.arange(1, n + 1) / b.fps
            ph = phi + TWO_PI * t / period
            ramp = np.minimum(t / 0.5, 1.0)
            ramp = ramp * ramp * (3 - 2 * ramp)
            ax = xc + (x_to - xc) * np.clip(t / (n / b.fps), 0, 1)
            cen = np.column_stack([ax + r * np.cos(ph), r * np.sin(ph), z_c + 0.03 * np.sin(2 * ph)])
            cen = b.centre[None] + ramp[:, None] * (cen - b.centre[None])
            tilt = np.radians(rng.uniform(72, 82))
            yaw = ph + np.pi
            base = b.upright_pitch
            pitch = b.pitch + ramp * (base + tilt - b.pitch)
            shape = np.array([15, 15, 0 if kind == "circles" else 40, 0, 0, 0, 0, 0, 0, 0, 1, 0], float)
            ang = np.repeat(shape[None], n, 0)
            ang[:, 5] = ang[:, 6] = np.degrees(pitch - base)  # arms stay vertical: shoulder flexion = body tilt
            ang = b.angles[None] + ramp[:, None] * (ang - b.angles[None])
            yaw_u = b.yaw + wrap_angle(yaw[0] - b.yaw) + (yaw - yaw[0])
            yaw_u = b.yaw + ramp * (yaw_u - b.yaw)
            b.append(cen, yaw_u, pitch, b.twist, ang, B.STRADDLE if kind == "flairs" else B.SUPPORT, SKILL)
            xc, phi = x_to, float(ph[-1])
        else:  # scissors: upright support, legs split across the horse, swinging side to side along it
            n_s = int(rng.integers(3, 6))
            period = rng.uniform(0.8, 1.0)
            up = b.upright_pitch
            grip = np.array([xc, 0.0, POMMEL_Z])
            start = c.grip_centre(grip, sup, b.yaw, up)
            b.transition(0.5, start, pitch_end=up, angles_end=sup, posture=B.SUPPORT, phase=SKILL)
            n = b.frames_for(n_s * period)
            t = np.arange(1, n + 1) / b.fps
            sw = np.sin(TWO_PI * t / period) * np.minimum(t / 0.4, 1.0)
            yaw_f = float(np.round((b.yaw - np.pi / 2) / np.pi) * np.pi + np.pi / 2)  # face across the horse
            sc = np.array([45, -45, 20, 0, 0, 0, 0, 0, 0, 0, 1, 0], float)
            ang = np.repeat(sc[None], n, 0)
            ang[:, 0] = 45 * sw  # the legs scissor across the horse with the sway
            ang[:, 1] = -ang[:, 0]
            yaw_a = np.full(n, yaw_f)
            # the legs swing from side to side: the centre sways along the horse
            cen = c.b.body.centre_on_grip(np.broadcast_to(grip, (n, 3)), ang, yaw_a, np.full(n, up), np.zeros(n))
            cen[:, 0] += 0.3 * sw
            w = np.minimum(t / 0.3, 1.0)[:, None]
            cen = b.centre[None] + w * (cen - b.centre[None])
            yaw_a = b.yaw + np.minimum(t / 0.3, 1.0) * (yaw_f - b.yaw + 0.0)
            b.append(cen, yaw_a, up, 0.0, ang, B.SPLIT, SKILL)
            phi = float(np.arctan2(np.sin(b.yaw), np.cos(b.yaw))) + np.pi
        if c.left < reserve:  # ran into the time kept for the dismount: undo
            b.truncate(b.n - n0)
            xc, phi = saved
            break

    # Dismount: up to a handstand over the horse, then down to the side.
    c._phase = DISMOUNT
    grip = np.array([xc, 0.0, POMMEL_Z])
    hs = B.posture_angles(B.ARMS_UP)
    pitch_hs = b.upright_pitch + np.pi
    yaw_d = float(np.round((b.yaw - np.pi / 2) / np.pi) * np.pi + np.pi / 2)  # face across the horse
    top = c.grip_centre(grip, hs, yaw_d, pitch_hs)
    b.transition(rng.uniform(0.8, 1.1), top, pitch_end=pitch_hs, angles_end=hs, posture=B.ARMS_UP, phase=DISMOUNT)
    b.hold_grip(grip, rng.uniform(0.3, 0.7), yaw_d, hs, B.ARMS_UP, DISMOUNT)
    side = float(np.sign(np.sin(yaw_d)) or 1.0)  # pitch on past pi: the feet come down on the +yaw side
    c.flight_to_floor((xc + rng.uniform(-0.3, 0.3), side * rng.uniform(0.75, 0.9)), b.centre[2] + rng.uniform(0.05, 0.2),
                      np.pi, twist=np.pi * rng.choice([0.0, 1.0]), shape=B.LAYOUT)
    c.land(0.0)
    c._phase = SKILL
    c.salute()
    c.walk_out(c.outside_point(side, rng.uniform(1.5, 2.0)))
    c.pad_to_end(c.outside_point(side, 4.0))


# ====================================================================== vault
TABLE_Z = 1.35


def _vault(c: Choreography) -> None:
    b, rng = c.b, c.rng
    s = np.asarray(c.app.performance_space)
    first = True
    while True:
        x_board = -rng.uniform(2.6, 2.9)
        v_max = rng.uniform(7.5, 8.5)
        tau = rng.uniform(0.9, 1.2)
        # run-up length: as long as allowed (up to 25 m), shorter if the routine is short
        t_vault = 7.5  # board to the end of the walk out
        avail = c.left - t_vault - (6.0 if first else 4.0)
        L_max = min(s[0] + 1.0 - (x_board - 2.0), 0.0) * -1.0  # runway start stays inside S_perf
        L = float(np.clip(rng.uniform(15.0, 23.0), 8.0, L_max))
        # time to run L: x(t) = v (t - tau (1 - e^{-t/tau}))
        while L > 8.0 and (L / v_max + tau) > max(avail, 2.0):
            L -= 1.0
        x_start = x_board - 2.0 - L
        if first:
            entry = c.entry([x_start, 0.0], [x_start - rng.uniform(0.0, 0.8), -c.layout.judge_side * rng.uniform(2.2, 3.0)])
            b.place(entry, 0.0, float(np.arctan2(-entry[1], x_start - entry[0])))
            b.walk_to((x_start, 0.0), rng.uniform(1.1, 1.4), 0.0, WALK)
        else:
            b.walk_to((x_start, -c.layout.judge_side * 2.2), rng.uniform(1.4, 1.8), 0.0, WALK)
            b.walk_to((x_start, 0.0), 1.2, 0.0, WALK)
        c.salute()
        b.stand(rng.uniform(0.4, 0.8), 0.0, B.STAND, WAIT, yaw=0.0)
        first = False

        # Run-up (not yet performing, see motion.PERFORMING): v(t) = v_max (1 - exp(-t / tau)).
        t_end = L / v_max + tau
        for _ in range(30):  # Newton on x(t) = L
            xt = v_max * (t_end - tau * (1 - np.exp(-t_end / tau)))
            t_end -= (xt - L) / (v_max * (1 - np.exp(-t_end / tau)))
        n = b.frames_for(t_end)
        t = np.arange(1, n + 1) / b.fps * (t_end / (n / b.fps))
        xs = x_start + v_max * (t - tau * (1 - np.exp(-t / tau)))
        v = v_max * (1 - np.exp(-t / tau))
        stride = 2.0 * b.body.height / 1.7 * (0.6 + 0.4 * v / v_max)
        gait = b.gait + TWO_PI * np.cumsum(np.diff(np.concatenate([[x_start], xs])) / stride)
        ang = B.gait_angles(gait, run=True)
        w = np.minimum(t / 0.3, 1.0)[:, None]
        ang = b.angles[None] + w * (ang - b.angles[None])
        lean = b.upright_pitch + 0.15 * np.minimum(t / 0.5, 1.0)
        yaw = np.full(n, b.yaw)
        cen = b.body.centre_on_feet(np.column_stack([xs, np.zeros(n)]), 0.0, ang, yaw, lean, np.zeros(n))
        b.append(cen, yaw, lean, 0.0, ang, B.RUN, RUN_UP)

        # Hurdle onto the board (a low flight), board contact, pre-flight to the table.
        board_pose = np.array([10, 10, 0, 10, 10, 150, 150, 0, 0, 0, 0.5, 5], float)
        z_board = 0.12
        c_board = c.feet_centre((x_board, 0.0), z_board, board_pose, b.yaw, b.upright_pitch + 0.25)
        b.flight(c_board, b.flight_frames(b.centre[2], c_board[2], max(b.centre[2], c_board[2]) + 0.12),
                 b.upright_pitch + 0.25, angle_keys=[(1.0, board_pose)], posture=B.ARMS_UP, phase=SKILL)
        c_off = c.feet_centre((x_board + 0.45, 0.0), z_board, board_pose, b.yaw, b.pitch + 0.35)
        b.transition(0.13, c_off - np.array([0, 0, 0.05]), pitch_end=b.pitch + 0.35, posture=B.ARMS_UP, phase=SKILL)
        x_hand = rng.uniform(-0.35, -0.1)
        th_c = b.upright_pitch + rng.uniform(2.1, 2.4)
        hs = B.posture_angles(B.ARMS_UP)
        c_table = c.grip_centre((x_hand, 0.0, TABLE_Z), hs, b.yaw, th_c)
        b.flight(c_table, int(round(rng.uniform(0.26, 0.32) * b.fps)), th_c, angle_keys=[(1.0, hs)], posture=B.ARMS_UP, phase=SKILL)
        # Table contact: turn over the hands.
        th_r = b.upright_pitch + np.pi + rng.uniform(0.25, 0.45)
        b.grip_transition((x_hand, 0.0, TABLE_Z), rng.uniform(0.2, 0.25), th_r, b.yaw, hs, B.ARMS_UP, SKILL, linear=True)
        # Post-flight: peak 2.4-3.0 m, land 2.8-4.3 m past the table.
        c._phase = DISMOUNT
        n_salto = int(rng.choice([0, 1, 1, 2]))
        shape = rng.choice([B.TUCK, B.PIKE, B.LAYOUT]) if n_salto < 2 else rng.choice([B.TUCK, B.PIKE])
        apex = rng.uniform(2.4, 3.0)
        base = np.floor(b.pitch / TWO_PI) * TWO_PI
        c.flight_to_floor((rng.uniform(2.8, min(4.3, s[3] - 0.6)), 0.0), max(apex, b.centre[2] + 0.15),
                          base + TWO_PI * (1 + n_salto) - b.pitch,
                          twist=np.pi * rng.choice([0, 1, 2]) if shape == B.LAYOUT else 0.0, shape=shape, phase=DISMOUNT)
        c.land(0.0)
        c._phase = SKILL
        c.salute()
        out = np.array([b.centre[0] + rng.uniform(-0.5, 0.5), c.layout.judge_side * -1 * (s[4] + rng.uniform(1.0, 1.8))])
        c.walk_out(out)
        if c.left < 18.0:
            break
    c.pad_to_end(np.array([b.centre[0] - 2.0, b.centre[1] * 1.8]))


# ====================================================================== across-axis helpers (rings and bars)
def _across_yaw(face: float) -> float:
    """Yaw of a body facing +y (face=+1) or -y (face=-1): its swings are in the y-z plane."""
    return np.pi / 2 if face > 0 else -np.pi / 2


def _lift_to_hang(c: Choreography, grip: np.ndarray, seconds: float) -> None:
    """A coach lifts the gymnast from standing below the grip up to a hang (mount on rings / bars)."""
    b = c.b
    start = b.n
    hang = B.posture_angles(B.ARMS_UP)
    end = c.grip_centre(grip, hang, b.yaw, b.upright_pitch)
    b.transition(0.4, b.centre + np.array([0, 0, 0.0]), angles_end=hang, posture=B.ARMS_UP, phase=WAIT)
    b.transition(seconds, end, pitch_end=b.upright_pitch, angles_end=hang, posture=B.ARMS_UP, phase=MOUNT)
    c.events.append(Event("lift", start, b.n, (float(grip[0]), float(grip[1]))))


def _dismount_from_circle(c: Choreography, grip: np.ndarray, d: float, side_sign: float, reach: tuple[float, float],
                          apex_gain: tuple[float, float], n_salto: int) -> None:
    """Release from a swing / giant on the up-swing and fly to the floor on the side ``side_sign``."""
    b, rng = c.b, c.rng
    land_y = grip[1] + side_sign * rng.uniform(*reach)
    apex = b.centre[2] + rng.uniform(*apex_gain)
    shape = rng.choice([B.TUCK, B.PIKE, B.LAYOUT]) if n_salto <= 1 else rng.choice([B.TUCK, B.PIKE])
    # rotate on in the swing's direction up to the next upright pitch, plus the saltos
    nxt = np.ceil(b.pitch / TWO_PI) * TWO_PI if d > 0 else np.floor(b.pitch / TWO_PI) * TWO_PI
    rot = (nxt - b.pitch) + d * TWO_PI * n_salto
    c.flight_to_floor((grip[0] + rng.uniform(-0.2, 0.2), land_y), apex, rot, twist=np.pi * rng.choice([0, 1, 2]) if shape == B.LAYOUT else 0.0,
                      shape=shape, phase=DISMOUNT)
    c.land(0.0)


# ====================================================================== still rings
RINGS_Z = 2.8


def _ahead(current: float, d: float, rel: float, min_ahead: float = 0.3) -> float:
    """The first pitch past ``current`` in direction ``d`` (+1 / -1) that equals ``d * rel``
    modulo 2 pi, at least ``min_ahead`` radians on."""
    k = np.ceil((d * current + min_ahead - rel) / TWO_PI)
    return float(d * (rel + TWO_PI * k))


def _rings(c: Choreography) -> None:
    b, rng = c.b, c.rng
    face = rng.choice([-1.0, 1.0])
    yaw = _across_yaw(face)
    side_in = -c.layout.judge_side
    under = np.array([0.0, rng.uniform(-0.1, 0.1)])
    entry = c.entry([side_in * 0.8, under[1]], [side_in * rng.uniform(1.8, 2.4), rng.uniform(-1.0, 1.0)])
    b.place(entry, 0.0, float(np.arctan2(under[1] - entry[1], under[0] - entry[0])))
    b.walk_to((side_in * 0.8, under[1]), rng.uniform(1.1, 1.4), 0.0, WALK)
    c.salute()
    b.walk_to(under, 0.8, 0.0, WALK)
    b.stand(0.5, 0.0, B.STAND, WAIT, yaw=yaw)
    grip = np.array([0.0, 0.0, RINGS_Z])
    _lift_to_hang(c, grip, rng.uniform(1.0, 1.4))
    hang = B.posture_angles(B.ARMS_UP)
    sup = B.posture_angles(B.SUPPORT)
    b.hold_grip(grip, 0.6, yaw, hang, B.ARMS_UP, SKILL)
    up = b.upright_pitch
    state = "hang"
    reserve = 9.5
    while c.left > reserve:
        n0, saved = b.n, (state, up)
        if state == "hang":
            kind = rng.choice(["swings", "to_support", "to_handstand"], p=[0.4, 0.4, 0.2])
            if kind == "swings":
                amps = list(np.linspace(0.4, rng.uniform(0.9, 1.4), int(rng.integers(3, 6))))
                b.swing(grip, amps, yaw, B.ARMS_UP, SKILL, centre_angle=up)
                b.swing(grip, [amps[-1] * 0.5, 0.0], yaw, B.ARMS_UP, SKILL, centre_angle=up)
            elif kind == "to_handstand":
                # swing up and through the bottom to a handstand (minimum jerk: the gymnast pulls)
                b.swing(grip, [0.5, 1.0, 1.5], yaw, B.ARMS_UP, SKILL, centre_angle=up)
                d = -float(np.sign(b.pitch - up))
                b.giant(grip, abs(up + d * np.pi - b.pitch) / TWO_PI, d, 0.8, yaw, ramp_in=0.6, ramp_out=0.5)
                state = "handstand"
            else:  # kip / muscle-up to support
                b.grip_transition(grip, rng.uniform(1.0, 1.4), up, yaw, posture=B.SUPPORT, phase=SKILL,
                                  angle_keys=[(0.4, B.posture_angles(B.PIKE)), (1.0, sup)])
                state = "support"
        elif state == "support":
            kind = rng.choice(["l_sit", "press", "cross", "down"], p=[0.3, 0.35, 0.2, 0.15])
            if kind == "l_sit":
                b.hold_grip(grip, rng.uniform(1.8, 2.5), yaw, B.posture_angles(B.L_SIT), B.L_SIT, SKILL)
                b.hold_grip(grip, 0.5, yaw, sup, B.SUPPORT, SKILL)
            elif kind == "press":
                # pitch up to the handstand with the arms kept vertical (shoulder flexion = pitch)
                b.grip_transition(grip, rng.uniform(1.6, 2.2), up + np.pi, yaw, posture=B.ARMS_UP, phase=SKILL,
                                  angle_fn=lambda th: _support_shape(th, up))
                state = "handstand"
            elif kind == "cross":
                b.hold_grip(grip, 1.0, yaw, B.posture_angles(B.CROSS), B.CROSS, SKILL)
                b.hold_grip(grip, rng.uniform(1.5, 2.2), yaw, B.posture_angles(B.CROSS), B.CROSS, SKILL)
                b.hold_grip(grip, 0.8, yaw, sup, B.SUPPORT, SKILL)
            else:
                b.grip_transition(grip, 0.9, up, yaw, hang, B.ARMS_UP, SKILL)
                state = "hang"
        else:  # handstand
            b.hold_grip(grip, rng.uniform(1.5, 2.5), yaw, hang, B.ARMS_UP, SKILL)
            if rng.random() < 0.5:
                b.grip_transition(grip, rng.uniform(1.3, 1.8), up, yaw, posture=B.SUPPORT, phase=SKILL,
                                  angle_fn=lambda th: _support_shape(th, up))
                state = "support"
            else:  # swing down through the hang to the far turning point, then swing out
                d = float(np.sign(b.pitch - up)) if b.pitch != up else 1.0
                b.giant(grip, (np.pi + 1.0) / TWO_PI, d, 0.8, yaw, ramp_in=0.6, ramp_out=0.8)
                up = b.upright_pitch
                b.swing(grip, [0.6, 0.2, 0.0], yaw, B.ARMS_UP, SKILL, centre_angle=up)
                state = "hang"
        if c.left < reserve:  # ran into the time kept for the dismount: undo
            b.truncate(b.n - n0)
            state, up = saved
            break
    if state == "handstand":
        b.grip_transition(grip, 1.3, up, yaw, posture=B.SUPPORT, phase=SKILL, angle_fn=lambda th: _support_shape(th, up))
        state = "support"
    if state == "support":
        b.grip_transition(grip, 0.9, up, yaw, hang, B.ARMS_UP, SKILL)
    # Dismount: swings growing to the release before a turning point, single or double salto.
    c._phase = DISMOUNT
    b.swing(grip, [0.8, 1.2, rng.uniform(1.4, 1.6)], yaw, B.ARMS_UP, DISMOUNT, centre_angle=up)
    b.truncate(int(0.15 * b.fps))
    side = float(np.sign(b.centre[1] - grip[1]) or 1.0)  # still moving up and out on this side
    d = float(np.sign(b.pitch - up) or 1.0)
    _dismount_from_circle(c, grip, d, side, (1.1, 1.6), (0.7, 1.1), int(rng.choice([1, 2])))
    c._phase = SKILL
    c.salute()
    c.walk_out(c.outside_point(side_in, rng.uniform(1.5, 2.0)))
    c.pad_to_end(c.outside_point(side_in, 4.0))


# ====================================================================== horizontal bar and uneven bars
HIGH_BAR_Z = 2.8
UB_LOW = (-0.75, 1.7)
UB_HIGH = (0.75, 2.5)


def _cast_to_handstand(c: Choreography, grip, yaw: float) -> None:
    """From front support, cast (swing the legs back and up) to a handstand: pitch +pi, arms
    kept vertical (shoulder flexion follows the pitch)."""
    b = c.b
    up = b.upright_pitch
    b.grip_transition(grip, c.rng.uniform(0.9, 1.2), up + np.pi, yaw, posture=B.ARMS_UP, phase=SKILL,
                      angle_fn=lambda th: _support_shape(th, up))


def _kip(c: Choreography, grip, yaw: float) -> None:
    """From hang to front support (glide kip)."""
    b = c.b
    up = b.upright_pitch
    b.swing(grip, [0.6], yaw, B.ARMS_UP, SKILL, centre_angle=up)
    b.grip_transition(grip, c.rng.uniform(0.8, 1.1), up, yaw, posture=B.SUPPORT, phase=SKILL,
                      angle_keys=[(0.45, B.posture_angles(B.PIKE)), (1.0, B.posture_angles(B.SUPPORT))])


def _giant_shape(th: np.ndarray) -> np.ndarray:
    """The giant's body shape: straight, arms overhead."""
    return np.repeat(B.posture_angles(B.ARMS_UP)[None], th.size, 0)


def _giant_to(c: Choreography, grip, yaw: float, d: float, rel: float, min_ahead: float = 0.3, phase: int = SKILL,
              omega_top: float | None = None, ramp_out: float = 0.0) -> None:
    """Giants in direction ``d`` up to the pitch ``d * rel`` (mod 2 pi) at least ``min_ahead`` on;
    a giant starting from a handstand starts slowly."""
    b = c.b
    target = _ahead(b.pitch, d, rel, min_ahead)
    w_top = c.rng.uniform(2.3, 3.2) if omega_top is None else omega_top
    at_top = abs(np.cos(b.pitch) + 1.0) < 0.05
    b.giant(grip, abs(target - b.pitch) / TWO_PI, d, w_top, yaw, phase=phase, angle_fn=_giant_shape,
            ramp_in=0.6 if at_top else 0.0, ramp_out=ramp_out)


def _release_regrasp(c: Choreography, grip, yaw: float, d: float) -> None:
    """A release over the bar (hecht / Tkatchev-like): let go 0.8 rad before the handstand, fly
    over the bar with the centre rising 0.3-0.5 m, regrasp 0.8 rad past it and giant on."""
    b, rng = c.b, c.rng
    _giant_to(c, grip, yaw, d, np.pi - 0.8, min_ahead=np.pi)
    th_g = b.pitch + d * 1.6
    arms = B.posture_angles(B.ARMS_UP)
    end = c.grip_centre(grip, arms, yaw, th_g)
    apex = max(b.centre[2], end[2]) + rng.uniform(0.3, 0.5)
    shape = B.posture_angles(rng.choice([B.STRADDLE, B.PIKE, B.LAYOUT]))
    b.flight(end, b.flight_frames(b.centre[2], end[2], apex), th_g, angle_keys=[(0.3, shape), (0.7, shape), (1.0, arms)],
             posture=B.STRADDLE, phase=SKILL)


def _bar_dismount(c: Choreography, grip, yaw: float, d: float, reach: tuple[float, float]) -> None:
    """Giants to the release on the up-swing (1.25-1.45 rad past the bottom), salto to the floor."""
    rng = c.rng
    c._phase = DISMOUNT
    _giant_to(c, grip, yaw, d, rng.uniform(1.25, 1.45), min_ahead=np.pi, phase=DISMOUNT)
    side = float(np.sign(-d * np.sin(yaw)))  # the centre moves this way in y on the up-swing
    _dismount_from_circle(c, grip, d, side, reach, (0.9, 1.2), int(rng.choice([1, 2])))
    c._phase = SKILL


def _horizontal_bar(c: Choreography) -> None:
    b, rng = c.b, c.rng
    face = rng.choice([-1.0, 1.0])
    yaw = _across_yaw(face)
    side_in = -c.layout.judge_side
    xg = rng.uniform(-0.3, 0.3)
    entry = c.entry([side_in * 0.8, 0.0], [side_in * rng.uniform(2.3, 3.0), rng.uniform(-2.0, 2.0)])
    b.place(entry, 0.0, float(np.arctan2(-entry[1], side_in * 0.8 - entry[0])))
    b.walk_to((side_in * 0.8, 0.0), rng.uniform(1.1, 1.4), 0.0, WALK)
    c.salute()
    b.walk_to((xg, 0.0), 0.8, 0.0, WALK)
    b.stand(0.5, 0.0, B.STAND, WAIT, yaw=yaw)
    grip = np.array([xg, 0.0, HIGH_BAR_Z])
    _lift_to_hang(c, grip, rng.uniform(1.0, 1.3))
    _kip(c, grip, yaw)
    _cast_to_handstand(c, grip, yaw)
    d = rng.choice([-1.0, 1.0])
    reserve = 7.0
    while c.left > reserve:
        n0, saved = b.n, (grip.copy(), d)
        kind = rng.choice(["giants", "release", "pirouette"], p=[0.5, 0.3, 0.2])
        if kind == "giants":
            _giant_to(c, grip, yaw, d, np.pi, min_ahead=TWO_PI * float(rng.integers(1, 3)) - 0.5)
        elif kind == "release":
            _release_regrasp(c, grip, yaw, d)
        else:  # giant to the handstand, pirouette: the hands move along the bar, the direction reverses
            _giant_to(c, grip, yaw, d, np.pi, min_ahead=np.pi, ramp_out=0.6)
            new_grip = grip.copy()
            new_grip[0] = np.clip(grip[0] + rng.uniform(-0.3, 0.3), -0.5, 0.5)
            b.hold_grip(grip, rng.uniform(0.5, 0.8), yaw, B.posture_angles(B.ARMS_UP), B.ARMS_UP, SKILL, grip_end=new_grip)
            grip = new_grip
            d = -d
        if c.left < reserve:  # ran into the time kept for the dismount: undo
            b.truncate(b.n - n0)
            grip, d = saved
            break
    _bar_dismount(c, grip, yaw, d, (1.5, 2.1))
    c.salute()
    c.walk_out(c.outside_point(side_in, rng.uniform(1.5, 2.0)))
    c.pad_to_end(c.outside_point(side_in, 4.0))


def _uneven_bars(c: Choreography) -> None:
    b, rng = c.b, c.rng
    yaw = _across_yaw(1.0)  # facing the high bar from the low bar
    side_in = -c.layout.judge_side
    xg = rng.uniform(-0.3, 0.3)
    low = np.array([xg, UB_LOW[0], UB_LOW[1]])
    high = np.array([xg, UB_HIGH[0], UB_HIGH[1]])
    entry = c.entry([xg, -1.6], [side_in * rng.uniform(2.3, 3.0), -rng.uniform(2.0, 2.6)])
    b.place(entry, 0.0, float(np.arctan2(-1.6 - entry[1], xg - entry[0])))
    b.walk_to((xg, -1.6), rng.uniform(1.1, 1.4), 0.0, WALK)
    c.salute()
    b.stand(0.4, 0.0, B.STAND, WAIT, yaw=yaw)
    # Mount: jump to front support on the low bar.
    c._phase = MOUNT
    c.jump_prep(0.0, 0.3)
    sup = B.posture_angles(B.SUPPORT)
    arms = B.posture_angles(B.ARMS_UP)
    end = c.grip_centre(low, sup, yaw, b.upright_pitch)
    b.flight(end, b.flight_frames(b.centre[2], end[2], end[2] + 0.25), b.pitch, angle_keys=[(0.5, CROUCH_LIGHT), (1.0, sup)],
             posture=B.SUPPORT, phase=MOUNT)
    b.hold_grip(low, 0.4, yaw, sup, B.SUPPORT, MOUNT)
    c.events.append(Event("spot", b.n - int(1.2 * b.fps), b.n, (float(xg), float(UB_LOW[0] - 0.5))))
    c._phase = SKILL
    reserve = 7.0

    def low_to_high() -> None:
        _cast_to_handstand(c, low, yaw)
        # fall towards the high bar and fly to it (low-to-high transition), catch in hang
        b.giant(low, 0.2, 1.0, 1.2, yaw, angle_fn=_giant_shape, ramp_in=0.6)
        th_g = b.upright_pitch + rng.uniform(-0.3, 0.1)
        end = c.grip_centre(high, arms, yaw, th_g)
        apex = max(b.centre[2], end[2]) + rng.uniform(0.2, 0.4)
        b.flight(end, b.flight_frames(b.centre[2], end[2], apex), th_g, angle_keys=[(0.4, B.posture_angles(B.PIKE)), (1.0, arms)],
                 posture=B.PIKE, phase=SKILL)
        b.swing(high, [0.8, 0.5], yaw, B.ARMS_UP, SKILL, centre_angle=b.upright_pitch)
        _kip(c, high, yaw)
        _cast_to_handstand(c, high, yaw)

    low_to_high()
    while c.left > reserve:
        n0 = b.n
        kind = rng.choice(["giants", "release", "to_low"], p=[0.45, 0.25, 0.3])
        if kind == "giants":
            _giant_to(c, high, yaw, -1.0, np.pi, min_ahead=TWO_PI * float(rng.integers(1, 3)) - 0.5)
        elif kind == "release":
            _release_regrasp(c, high, yaw, -1.0)
        else:
            # high-to-low: from the handstand fall towards the low bar, let go and drop to support
            # on it; then back up to the high bar
            _giant_to(c, high, yaw, -1.0, np.pi + 0.6, min_ahead=0.3)
            up_t = float(np.floor(b.pitch / TWO_PI) * TWO_PI)
            end = c.grip_centre(low, sup, yaw, up_t)
            apex = max(b.centre[2], end[2]) + rng.uniform(0.1, 0.3)
            b.flight(end, b.flight_frames(b.centre[2], end[2], apex), up_t,
                     angle_keys=[(0.4, B.posture_angles(B.PIKE)), (1.0, sup)], posture=B.PIKE, phase=SKILL)
            b.hold_grip(low, 0.5, yaw, sup, B.SUPPORT, SKILL)
            low_to_high()
        if c.left < reserve:  # ran into the time kept for the dismount: undo
            b.truncate(b.n - n0)
            break
    # Dismount from the high bar away from the low bar (+y): backward giants (d = -1).
    _bar_dismount(c, high, yaw, -1.0, (1.3, 1.7))
    c.salute()
    c.walk_out(c.outside_point(side_in, rng.uniform(1.5, 2.0)))
    c.pad_to_end(c.outside_point(side_in, 4.0))


# ====================================================================== parallel bars
PB_Z = 2.0
PB_HALF = 1.75


def _support_shape(th: np.ndarray, up: float, base: np.ndarray | None = None) -> np.ndarray:
    """Support swing shape: arms stay vertical (shoulder flexion = pitch from upright)."""
    a = np.repeat((B.posture_angles(B.SUPPORT) if base is None else base)[None], th.size, 0)
    a[:, 5] = a[:, 6] = np.degrees(th - up)
    return a


def _parallel_bars(c: Choreography) -> None:
    b, rng = c.b, c.rng
    sx = rng.choice([-1.0, 1.0])  # mount end
    yaw = 0.0 if sx < 0 else np.pi  # facing into the bars
    h = -sx  # heading along the bars
    stand_pt = np.array([sx * (PB_HALF + 0.5), 0.0])
    entry = c.entry(stand_pt, [stand_pt[0] + sx * rng.uniform(0.2, 0.6), -c.layout.judge_side * rng.uniform(1.8, 2.4)])
    b.place(entry, 0.0, float(np.arctan2(-entry[1], stand_pt[0] - entry[0])))
    b.walk_to(stand_pt, rng.uniform(1.1, 1.4), 0.0, WALK)
    c.salute()
    b.stand(0.4, 0.0, B.STAND, WAIT, yaw=yaw)
    c._phase = MOUNT
    c.jump_prep(0.0, 0.3)
    grip = np.array([sx * (PB_HALF - 0.5), 0.0, PB_Z])
    sup = B.posture_angles(B.SUPPORT)
    end = c.grip_centre(grip, sup, yaw, b.upright_pitch)
    b.flight(end, b.flight_frames(b.centre[2], end[2], end[2] + 0.2), b.pitch, angle_keys=[(0.5, CROUCH_LIGHT), (1.0, sup)],
             posture=B.SUPPORT, phase=MOUNT)
    b.hold_grip(grip, 0.4, yaw, sup, B.SUPPORT, MOUNT)
    up = b.upright_pitch
    r_sh = 0.32 * b.body.height  # shoulders to centre in support: the swing's pivot radius
    off_plane_done = False
    reserve = 7.5
    while c.left > reserve:
        n0, saved = b.n, (grip.copy(), up, h, off_plane_done)
        kind = rng.choice(["swings", "handstand", "travel", "l_sit", "salto", "one_rail"], p=[0.3, 0.2, 0.15, 0.1, 0.15, 0.1])
        if kind == "one_rail" and off_plane_done:
            kind = "swings"
        if kind == "swings":
            amps = list(np.linspace(0.5, rng.uniform(1.0, 1.5), int(rng.integers(3, 6))))
            b.swing(grip, amps + [0.3, 0.0], yaw, B.SUPPORT, SKILL, centre_angle=up, angle_fn=lambda th: _support_shape(th, up), radius=r_sh)
        elif kind == "handstand":
            amps = [0.7, 1.3, 2.0]
            b.swing(grip, amps, yaw, B.SUPPORT, SKILL, centre_angle=up, angle_fn=lambda th: _support_shape(th, up), radius=r_sh)
            b.grip_transition(grip, 0.6, up + np.pi, yaw, B.posture_angles(B.ARMS_UP), B.ARMS_UP, SKILL)
            b.hold_grip(grip, rng.uniform(1.0, 2.0), yaw, B.posture_angles(B.ARMS_UP), B.ARMS_UP, SKILL)
            b.swing(grip, [1.5, 0.9, 0.4, 0.0], yaw, B.SUPPORT, SKILL, centre_angle=up, angle_fn=lambda th: _support_shape(th, up),
                    radius=r_sh)
        elif kind == "travel":
            room = PB_HALF - 0.35 - h * grip[0]
            if room < 0.4:
                h = -h
                room = PB_HALF - 0.35 - h * grip[0]
            dist = min(rng.uniform(0.4, 1.0), room)
            g2 = grip + np.array([h * dist, 0.0, 0.0])
            b.hold_grip(grip, dist / rng.uniform(0.3, 0.5), yaw, sup, B.SUPPORT, SKILL, grip_end=g2)
            grip = g2
        elif kind == "l_sit":
            b.hold_grip(grip, rng.uniform(1.5, 2.2), yaw, B.posture_angles(B.L_SIT), B.L_SIT, SKILL)
            b.hold_grip(grip, 0.4, yaw, sup, B.SUPPORT, SKILL)
        elif kind == "salto":
            # swing to the front, let go at the turning point, salto on in the same direction,
            # catch in support a little further along
            b.swing(grip, [0.6, 1.0, 1.3], yaw, B.SUPPORT, SKILL, centre_angle=up, angle_fn=lambda th: _support_shape(th, up), radius=r_sh)
            step = float(min(0.4, max(PB_HALF - 0.3 - abs(grip[0]), 0.0)))
            g2 = grip + np.array([h * step, 0.0, 0.0])
            pitch_end = up + TWO_PI * float(np.sign(b.pitch - up) or 1.0)
            end = c.grip_centre(g2, sup, yaw, pitch_end)
            apex = max(b.centre[2], end[2]) + rng.uniform(0.4, 0.6)
            tuck = B.posture_angles(B.TUCK)
            b.flight(end, b.flight_frames(b.centre[2], end[2], apex), pitch_end, angle_keys=[(0.3, tuck), (0.75, tuck), (1.0, sup)],
                     posture=B.TUCK, phase=SKILL)
            up = b.upright_pitch
            grip = g2
            b.hold_grip(grip, 0.4, yaw, sup, B.SUPPORT, SKILL)
        else:  # a moment on one rail: shift outside the plane and back
            side = rng.choice([-1.0, 1.0])
            g_side = grip + np.array([0.0, side * rng.uniform(0.35, 0.45), 0.0])
            b.hold_grip(grip, 0.8, yaw, sup, B.SUPPORT, OFF_PLANE, grip_end=g_side)
            b.hold_grip(g_side, rng.uniform(1.0, 1.8), yaw, B.posture_angles(B.L_SIT), B.L_SIT, OFF_PLANE)
            b.hold_grip(g_side, 0.8, yaw, sup, B.SUPPORT, OFF_PLANE, grip_end=grip)
            off_plane_done = True
        if c.left < reserve:  # ran into the time kept for the dismount: undo
            b.truncate(b.n - n0)
            grip, up, h, off_plane_done = saved
            break
    # Dismount: swing to handstand, salto off the end.
    c._phase = DISMOUNT
    end_dir = 1.0 if grip[0] >= 0 else -1.0
    b.swing(grip, [0.7, 1.3, 1.9], yaw, B.SUPPORT, DISMOUNT, centre_angle=up, angle_fn=lambda th: _support_shape(th, up), radius=r_sh)
    b.truncate(int(0.1 * b.fps))
    d = float(np.sign(b.pitch - up) or 1.0)
    land_x = float(end_dir * rng.uniform(PB_HALF + 0.3, PB_HALF + 0.6))
    n_salto = int(rng.choice([0, 1]))
    nxt = np.ceil(b.pitch / TWO_PI) * TWO_PI if d > 0 else np.floor(b.pitch / TWO_PI) * TWO_PI
    c.flight_to_floor((land_x, rng.uniform(-0.15, 0.15)), b.centre[2] + rng.uniform(0.3, 0.6), (nxt - b.pitch) + d * TWO_PI * n_salto,
                      shape=rng.choice([B.TUCK, B.PIKE]), phase=DISMOUNT)
    c.land(0.0)
    c._phase = SKILL
    c.salute()
    c.walk_out(c.outside_point(-c.layout.judge_side, rng.uniform(1.5, 2.0)))
    c.pad_to_end(c.outside_point(-c.layout.judge_side, 4.0))


ROUTINES = {
    "balance_beam": _beam,
    "pommel_horse": _pommel,
    "vault": _vault,
    "still_rings": _rings,
    "horizontal_bar": _horizontal_bar,
    "uneven_bars": _uneven_bars,
    "parallel_bars": _parallel_bars,
}

#: Off-plane drift per apparatus: (standard deviation m, correlation time s, clip m).
DRIFT = {
    "balance_beam": (0.02, 1.0, 0.06),
    "pommel_horse": (0.03, 1.0, 0.1),
    "vault": (0.04, 1.5, 0.12),
    "still_rings": (0.025, 1.2, 0.08),
    "horizontal_bar": (0.15, 3.0, 0.45),
    "uneven_bars": (0.15, 3.0, 0.45),
    "parallel_bars": (0.05, 1.5, 0.12),
}


def add_drift(motion: Motion, app: Apparatus, rng: np.random.Generator, fps: float) -> np.ndarray:
    """Add the off-plane drift along the plane normal to the performing frames, in place.

    A smooth random process (Gaussian-filtered noise, std and correlation time per apparatus,
    clipped), faded in and out over 0.5 s at the edges of the performance, and replaced by a
    straight line through every flight (no sideways force in the air). Returns the (n,) drift.
    """
    sigma, corr, clip = DRIFT[app.name]
    n = len(motion)
    noise = gaussian_filter1d(rng.standard_normal(n + 200), corr * fps, mode="reflect")[100:-100]
    noise *= sigma / max(noise.std(), 1e-9)
    drift = clip * np.tanh(noise / clip)
    # fade in and out over 0.5 s inside the performance: zero at its edges, so no jump there
    inside = np.pad(motion.performing, 1)
    env = smoothstep(distance_transform_edt(inside)[1:-1] / (0.5 * fps))
    drift *= env
    fl = motion.flight
    if fl.any():
        idx = np.arange(n)
        edges = np.diff(np.concatenate([[0], fl.astype(np.int8), [0]]))
        starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        for s0, s1 in zip(starts, stops):  # a handful of flights per routine
            a, z = max(s0 - 1, 0), min(s1, n - 1)
            drift[s0:s1] = np.interp(idx[s0:s1], [a, z], [drift[a], drift[z]])
    normal = np.asarray(app.plane_normal, float)
    motion.centre += drift[:, None] * normal[None]
    return drift


def target_routine(app: Apparatus, seconds: float, fps: float, rng: np.random.Generator, body: B.BodyModel,
                   layout: Layout) -> tuple[Motion, list[Event], np.ndarray]:
    """The target gymnast's whole routine on ``app``, exactly ``round(seconds * fps)`` frames.

    Returns the motion (drift included), the events coaches react to and the (n,) drift."""
    b = MotionBuilder(body, fps, rng)
    c = Choreography(app, b, rng, layout, int(round(seconds * fps)))
    ROUTINES[app.name](c)
    motion = b.build()
    drift = add_drift(motion, app, rng, fps)
    return motion, c.events, drift
