"""Still rings: lift to hang, swings, support, L-sit, press to handstand, cross, salto dismount.

Paper: Section IV's still rings; Section III-C's vertical plane through the rings holds the
swings (centre (n, 3) a few cm off it).
"""

from __future__ import annotations

import numpy as np

from .. import body as B
from ..motion import DISMOUNT, SKILL, WAIT, WALK
from .choreography import TWO_PI, Choreography, across_yaw, dismount_from_circle, flyaway_saltos, lift_to_hang, support_shape

# ====================================================================== still rings
RINGS_Z = 2.8

def rings_routine(c: Choreography) -> None:
    b, rng = c.b, c.rng
    face = rng.choice([-1.0, 1.0])
    yaw = across_yaw(face)
    side_in = -c.layout.judge_side
    under = np.array([0.0, rng.uniform(-0.1, 0.1)])
    entry = c.entry([side_in * 0.8, under[1]], [side_in * rng.uniform(1.8, 2.4), rng.uniform(-1.0, 1.0)])
    b.place(entry, 0.0, float(np.arctan2(under[1] - entry[1], under[0] - entry[0])))
    b.walk_to((side_in * 0.8, under[1]), rng.uniform(1.1, 1.4), 0.0, WALK)
    c.salute()
    b.walk_to(under, 0.8, 0.0, WALK)
    b.stand(0.5, 0.0, B.STAND, WAIT, yaw=yaw)
    grip = np.array([0.0, 0.0, RINGS_Z])
    lift_to_hang(c, grip, rng.uniform(1.0, 1.4))
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
                                  angle_fn=lambda th: support_shape(th, up))
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
                                  angle_fn=lambda th: support_shape(th, up))
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
        b.grip_transition(grip, 1.3, up, yaw, posture=B.SUPPORT, phase=SKILL, angle_fn=lambda th: support_shape(th, up))
        state = "support"
    if state == "support":
        b.grip_transition(grip, 0.9, up, yaw, hang, B.ARMS_UP, SKILL)
    # Dismount: swings growing to the release before a turning point, a flyaway (mostly a double salto).
    c._phase = DISMOUNT
    b.swing(grip, [0.8, 1.2, rng.uniform(1.4, 1.6)], yaw, B.ARMS_UP, DISMOUNT, centre_angle=up)
    b.truncate(int(0.15 * b.fps))
    side = float(np.sign(b.centre[1] - grip[1]) or 1.0)  # still moving up and out on this side
    d = float(np.sign(b.pitch - up) or 1.0)
    dismount_from_circle(c, grip, d, side, (1.1, 1.6), (0.7, 1.1), flyaway_saltos(c))
    c._phase = SKILL
    c.salute()
    c.walk_out(c.outside_point(side_in, rng.uniform(1.5, 2.0)))
    c.pad_to_end(c.outside_point(side_in, 4.0))
