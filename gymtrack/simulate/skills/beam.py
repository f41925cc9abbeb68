"""Balance beam (and floor-like moves): walks, turns, leaps, jumps, saltos along the 5 m beam.

Paper: Section IV's balance beam; Section III-C's vertical plane is the beam's (moves stay on it
within a few cm) and III-D's heights (the beam top at 1.25 m lifts the target's bottom).
"""

from __future__ import annotations

import numpy as np

from .. import body as B
from ..motion import DISMOUNT, MOUNT, SKILL, WAIT, WALK
from .choreography import CROUCH_LIGHT, CROUCH_MID, TWO_PI, Choreography

# ====================================================================== balance beam
BEAM_Z = 1.25
BEAM_HALF = 2.5


def beam_routine(c: Choreography) -> None:
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
