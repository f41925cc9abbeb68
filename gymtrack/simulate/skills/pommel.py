"""Pommel horse: circles, flairs, scissors travelling along the horse, a handstand dismount.

Paper: Section IV's pommel horse; Section III-C's vertical plane holds the circles' centre only
approximately (radius 0.2-0.4 m), one of the moments off the plane.
"""

from __future__ import annotations

import numpy as np

from .. import body as B
from ..motion import DISMOUNT, MOUNT, SKILL, WAIT, WALK, wrap_angle
from .choreography import TWO_PI, Choreography

# ====================================================================== pommel horse
POMMEL_Z = 1.15


def pommel_routine(c: Choreography) -> None:
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
