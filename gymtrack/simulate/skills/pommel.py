"""Pommel horse: circles, flairs, scissors travelling along the horse, a handstand dismount.

Paper: Section IV's pommel horse; Section III-C's vertical plane holds the circles' centre only
approximately (radius 0.2-0.4 m), one of the moments off the plane.
"""

from __future__ import annotations

import numpy as np

from .. import body as B
from ..motion import DISMOUNT, MOUNT, SKILL, WAIT, WALK, smoothstep, wrap_angle
from .choreography import TWO_PI, Choreography

# ====================================================================== pommel horse
POMMEL_Z = 1.15
HORSE_TOP = 1.03  #: the leather between the pommels (1.15 m less the 0.12 m pommels)
HANDS_Z = HORSE_TOP + 0.025  #: the palms' middle on the leather
HANDS_HALF = 0.15  #: each hand's palm this far from the grip's middle: inside the 0.35 m-wide horse
SPLIT_DEG = 78.0  #: scissors: each leg's hip flexion (+/-) about which the split swings: the horse stays between the legs
SCISSOR_DEG = 15.0
LEAN_DEG = 12.0  #: the shoulders lean away from the legs over the support


def _hands_in(height: float) -> float:
    """Shoulder abduction (deg, negative: in) that brings the palms of arms hanging under the
    shoulders to :data:`HANDS_HALF` from the middle (shoulders 0.11 H, arm to the palm 0.38 H off it)."""
    return float(np.degrees(np.arcsin(np.clip((HANDS_HALF - 0.11 * height) / (0.38 * height), -1.0, 1.0))))


def _grip_turn(b, grip, seconds: float, yaw_end: float, pitch_end: float, angles_end, posture: int, phase: int,
               shape_span: tuple[float, float] = (0.0, 1.0)) -> None:
    """Turn about the hands on the horse (yaw and pitch together, minimum jerk), the palms kept on
    ``grip``; the body's shape changes over the ``shape_span`` fractions of the phase (the legs
    open before they come down past the horse, close once they are above it)."""
    n = b.frames_for(seconds)
    tau = b._tau(n)
    s = smoothstep(tau)
    yaw = b.yaw + s * (b.yaw + wrap_angle(yaw_end - b.yaw) - b.yaw)
    pitch = b.pitch + s * (pitch_end - b.pitch)
    tw = np.full(n, b.twist)
    a = b._blend_angles(angles_end, smoothstep(np.clip((tau - shape_span[0]) / (shape_span[1] - shape_span[0]), 0.0, 1.0)))
    cen = b.body.centre_on_grip(np.broadcast_to(np.asarray(grip, float), (n, 3)), a, yaw, pitch, tw)
    b.append(cen, yaw, pitch, tw, a, posture, phase)


def pommel_routine(c: Choreography) -> None:
    b, rng = c.b, c.rng
    sy = -c.layout.judge_side  # approach from the far side
    x0 = rng.uniform(-0.05, 0.05)  # the hands on the leather between the pommels (0.45 m apart)
    spot = np.array([x0, sy * 0.85])
    entry = c.entry(spot, [x0 + rng.uniform(-1.0, 1.0), sy * rng.uniform(2.2, 2.8)])
    b.place(entry, 0.0, float(np.arctan2(spot[1] - entry[1], spot[0] - entry[0])))
    b.walk_to(spot, rng.uniform(1.1, 1.4), 0.0, WALK)
    c.salute()
    yaw_in = float(np.arctan2(-sy, 0.0))  # facing the horse
    b.stand(0.4, 0.0, B.STAND, WAIT, yaw=yaw_in)
    # Mount: jump to front support on the pommels.
    grip = np.array([x0, 0.0, HANDS_Z])
    sup = B.posture_angles(B.SUPPORT)
    sup[7] = _hands_in(b.body.height)
    sup[5] = sup[6] = 25.0  # front support: the hands ahead of the shoulders, the hips against the horse's side, not in it
    c._phase = MOUNT
    c.jump_prep(0.0, 0.25)
    end = c.grip_centre(grip, sup, b.yaw, b.upright_pitch)
    b.flight(end, b.flight_frames(b.centre[2], end[2], end[2] + 0.12), b.pitch, angle_keys=[(1.0, sup)], posture=B.SUPPORT, phase=MOUNT)
    b.hold_grip(grip, 0.4, b.yaw, sup, B.SUPPORT, MOUNT)

    reserve = 6.0
    xc = x0  # the circles' axis along the horse
    phi = float(np.arctan2(sy, 0.0))  # legs start on the approach side
    while c.left > reserve:
        n0, saved = b.n, (xc, phi)
        kind = rng.choice(["circles", "flairs", "scissors"], p=[0.55, 0.25, 0.2])
        if kind in ("circles", "flairs"):
            n_c = int(rng.integers(3, 8))
            period = rng.uniform(0.9, 1.1)
            n = b.frames_for(n_c * period)
            t = np.arange(1, n + 1) / b.fps
            ramp = np.minimum(t / 0.5, 1.0)
            ramp = ramp * ramp * (3 - 2 * ramp)
            ph = phi + np.cumsum(TWO_PI / period * ramp ** 2) / b.fps  # the legs rise first, then sweep round
            tilt = np.radians(rng.uniform(72, 82))
            yaw = ph + np.pi
            base = b.upright_pitch
            pitch = b.pitch + ramp * (base + tilt - b.pitch)
            shape = np.array([15, 15, 0 if kind == "circles" else 40, 0, 0, 0, 0, 0, 0, 0, 1, 0], float)
            ang = np.repeat(shape[None], n, 0)
            # arms vertical (shoulder flexion = body tilt), the shoulders leaning away from the legs,
            # the hands drawn in to hold the 0.35 m-wide horse
            ang[:, 5] = ang[:, 6] = np.degrees(pitch - base) - LEAN_DEG * ramp
            ang[:, 7] = _hands_in(b.body.height) * ramp
            ang = b.angles[None] + ramp[:, None] * (ang - b.angles[None])
            yaw_u = b.yaw + wrap_angle(yaw[0] - b.yaw) + (yaw - yaw[0])
            yaw_u = b.yaw + ramp * (yaw_u - b.yaw)
            cen = b.body.centre_on_grip(np.broadcast_to(grip, (n, 3)), ang, yaw_u, pitch, np.full(n, b.twist))
            b.append(cen, yaw_u, pitch, b.twist, ang, B.STRADDLE if kind == "flairs" else B.SUPPORT, SKILL)
            phi = float(ph[-1])
        else:  # scissors: upright support facing across the horse, the legs split across it (one each side), scissoring
            n_s = int(rng.integers(3, 6))
            period = rng.uniform(0.8, 1.0)
            up = b.upright_pitch
            grip = np.array([xc, 0.0, HANDS_Z])
            yaw_f = float(np.round((b.yaw - np.pi / 2) / np.pi) * np.pi + np.pi / 2)  # face across the horse
            sc = np.array([SPLIT_DEG, -SPLIT_DEG, 20, 0, 0, 0, 0, _hands_in(b.body.height), 0, 0, 1, 0], float)
            _grip_turn(b, grip, 0.6, yaw_f, up, sc, B.SPLIT, SKILL, shape_span=(0.0, 0.4))  # the hands stay on the horse
            n = b.frames_for(n_s * period)
            t = np.arange(1, n + 1) / b.fps
            sw = np.sin(TWO_PI * t / period) * np.minimum(t / 0.4, 1.0)
            ang = np.repeat(sc[None], n, 0)
            ang[:, 0] = SPLIT_DEG + SCISSOR_DEG * sw  # the split swings, never closing over the horse
            ang[:, 1] = -(SPLIT_DEG - SCISSOR_DEG * sw)
            yaw_a = np.full(n, b.yaw)
            cen = b.body.centre_on_grip(np.broadcast_to(grip, (n, 3)), ang, yaw_a, np.full(n, up), np.full(n, b.twist))
            b.append(cen, yaw_a, up, b.twist, ang, B.SPLIT, SKILL)
            phi = float(np.arctan2(np.sin(b.yaw), np.cos(b.yaw))) + np.pi
        if c.left < reserve:  # ran into the time kept for the dismount: undo
            b.truncate(b.n - n0)
            xc, phi = saved
            break

    # Dismount: up to a handstand over the horse, then down to the side.
    c._phase = DISMOUNT
    grip = np.array([xc, 0.0, HANDS_Z])
    hs = B.posture_angles(B.ARMS_UP)
    hs[7] = _hands_in(b.body.height)
    pitch_hs = b.upright_pitch + np.pi
    yaw_d = float(np.round((b.yaw - np.pi / 2) / np.pi) * np.pi + np.pi / 2)  # face across the horse
    _grip_turn(b, grip, rng.uniform(0.8, 1.1), yaw_d, pitch_hs, hs, B.ARMS_UP, DISMOUNT, shape_span=(0.35, 1.0))  # the hands stay on the horse
    b.hold_grip(grip, rng.uniform(0.3, 0.7), yaw_d, hs, B.ARMS_UP, DISMOUNT)
    side = float(np.sign(np.sin(yaw_d)) or 1.0)  # pitch on past pi: the feet come down on the +yaw side
    c.flight_to_floor((xc + rng.uniform(-0.3, 0.3), side * rng.uniform(0.75, 0.9)), b.centre[2] + rng.uniform(0.05, 0.2),
                      np.pi, twist=np.pi * rng.choice([0.0, 1.0]), shape=B.LAYOUT)
    c.land(0.0)
    c._phase = SKILL
    c.salute()
    c.walk_out(c.outside_point(side, rng.uniform(1.5, 2.0)))
    c.pad_to_end(c.outside_point(side, 4.0))
