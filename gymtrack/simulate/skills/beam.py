"""Balance beam (and floor-like moves): walks, turns, leaps, jumps, saltos along the 5 m beam.

Paper: Section IV's balance beam; Section III-C's vertical plane is the beam's (moves stay on it
within a few cm) and III-D's heights (the beam top at 1.25 m lifts the target's bottom).
"""

from __future__ import annotations

import numpy as np

from .. import body as B
from ..body import POINT_NAMES
from ..motion import DISMOUNT, MOUNT, SKILL, WAIT, WALK, smoothstep
from .choreography import CROUCH_LIGHT, CROUCH_MID, TWO_PI, Choreography

# ====================================================================== balance beam
BEAM_Z = 1.25
BEAM_HALF = 2.5
ARCH_DEG = 60.0  #: the trunk's arch (back extension) at the walkover's bridge
MAX_SPLIT_DEG = 190.0  #: the widest split between the legs (a gymnast's over-split)
GRIP_Z = 0.025  #: the palm's middle above the surface it presses on
_I = {n: i for i, n in enumerate(POINT_NAMES)}


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

    last = ""
    while c.left > reserve():
        n0 = b.n
        x = b.centre[0]
        h = 1.0 if np.cos(b.yaw) > 0 else -1.0
        room = h * lim - x if h > 0 else x + lim  # metres ahead before the end
        skill = rng.choice(["walk", "leap", "jump", "salto", "walkover", "balance", "turn"], p=[0.22, 0.16, 0.12, 0.14, 0.12, 0.12, 0.12])
        need = {"walk": 1.0, "leap": 1.6, "jump": 0.4, "salto": 0.0, "walkover": 1.6, "balance": 0.0, "turn": 0.0}
        back = skill == "salto"
        if back and (lim - abs(x)) < 0.6 and np.sign(x) == -h:  # no room behind: go on forwards instead
            skill = "walk" if room >= 1.0 else "turn"
        elif not back and room < need[skill]:  # no room ahead: turn round
            skill = "turn"
        if skill == "turn" and last == "turn":  # pivots come one at a time, linked by other elements
            skill = "walk" if room >= 1.0 else "balance"
        last = skill
        if skill == "walk":
            d = min(rng.uniform(0.8, 2.0), room)
            b.walk_to((x + h * d, 0.0), rng.uniform(0.5, 0.9), BEAM_Z, SKILL, lateral=0.015)
        elif skill == "turn":
            full = rng.random() >= 0.8 and room >= 1.6  # a full turn only where the gymnast can go on the same way
            b.turn(np.pi * rng.choice([-1.0, 1.0]) * (2.0 if full else 1.0), rng.uniform(0.9, 1.4), BEAM_Z)
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
            walkover(c, rng.uniform(1.8, 2.4))
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
        if np.cos(b.yaw) * (x_d - b.centre[0]) < 0:  # the end is behind: pivot to face it, then walk (legs apart, no turning)
            b.turn(np.pi * rng.choice([-1.0, 1.0]), rng.uniform(0.9, 1.2), BEAM_Z)
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



def _walkover_angles(P: np.ndarray, start: np.ndarray) -> np.ndarray:
    """(n, A) the walkover's shape by its somersault angle ``P`` (n,) degrees, 0 -> 360: the support
    (left) leg stays vertical while the trunk goes down to the hands (hip flexion about P),
    the lead (right) leg kicks back and over (split handstand), then stays vertical under the
    body as it stands up over it (flexion P - 360); the back arched through the bridge; arms overhead, feet pointed in the air."""
    n = P.size
    a = np.repeat(B.posture_angles(B.STAND)[None], n, 0)
    up = smoothstep(np.clip((P - 300.0) / 60.0, 0.0, 1.0))  # standing up: back to the stand
    # support leg: nearly vertical while the trunk goes down, leaning 12 deg on as the hands reach
    # the beam (P ~ 150) some 0.6-0.8 m ahead, back to a 90 deg split by P = 215
    a[:, 0] = np.interp(P, [0.0, 90.0, 150.0, 215.0, 300.0], [0.0, 88.0, 138.0, 90.0, 90.0]) * (1 - up)
    kick = np.where(P < 180.0, -90.0 * smoothstep(np.clip(P / 120.0, 0.0, 1.0)), np.maximum(P - 360.0, -90.0))
    a[:, 1] = np.maximum(kick, a[:, 0] - MAX_SPLIT_DEG)  # the legs never split wider than a gymnast's split
    a[:, 5] = a[:, 6] = 180.0 * smoothstep(np.clip(P / 60.0, 0.0, 1.0)) * (1 - up)
    a[:, 7] = -17.0 * smoothstep(np.clip(P / 60.0, 0.0, 1.0)) * (1 - up)  # the hands together on the 10 cm beam
    a[:, 8] = 0.0
    a[:, 10] = smoothstep(np.clip(P / 60.0, 0.0, 1.0)) * (1 - up)
    # the back arches over the hands and as the lead foot reaches down (a walkover's bridge), so the
    # foot lands a short step past the hands
    a[:, 11] = -ARCH_DEG * np.sin(np.pi * np.clip((P - 160.0) / 160.0, 0.0, 1.0)) ** 2
    w = smoothstep(np.clip(P / 30.0, 0.0, 1.0))[:, None]  # from the current pose
    return start[None] + w * (a - start[None])


def walkover(c: Choreography, seconds: float) -> None:
    """A front walkover on the beam: the hands, then the feet, on the beam the whole way.

    A walkover passes through a split handstand with the hands on the beam: support on the rear
    foot while the trunk goes down and the lead leg kicks over, on both hands, then on the lead
    foot as the body stands up (FIG Women's Artistic Gymnastics Code of Points 2022-2024, Balance
    Beam, acrobatic elements without flight: walkover forward). Each frame's centre puts the
    current support on the beam: the rear foot's toe where it stood until the palms reach the
    beam, the palms where they reached it until the lead foot comes down, then that foot's toe.
    The contact points are where the body reaches the beam, so the handovers are continuous.
    """
    b = c.b
    n = b.frames_for(seconds)
    tau = b._tau(n)
    pitch = b.pitch + TWO_PI * 0.5 * (tau + smoothstep(tau))  # an even turn over, easing in and out
    a = _walkover_angles(np.degrees(pitch - b.pitch), b.angles)
    yaw, tw = np.full(n, b.yaw), np.full(n, b.twist)
    rel, _ = b.body.oriented(a, yaw, pitch, tw)
    rear, lead = _I["left_toe"], _I["right_toe"]
    pad = b.body.pad[rear]
    rel0, _ = b.body.oriented(b.angles[None], [b.yaw], [b.pitch], [b.twist])
    p_rear = b.centre + rel0[0, rear]
    p_rear[2] = BEAM_Z + pad
    c_foot = p_rear[None] - rel[:, rear]
    palm = b.body.grip_offset(rel)
    k1 = int(np.argmax((c_foot + palm)[:, 2] <= BEAM_Z + GRIP_Z))  # the hands reach the beam
    g = c_foot[k1] + palm[k1]
    g[2] = BEAM_Z + GRIP_Z
    c_hand = g[None] - palm
    k_hs = int(np.argmin(np.abs(pitch - (b.pitch + np.pi))))
    k2 = k_hs + int(np.argmax((c_hand + rel[:, lead])[k_hs:, 2] - pad <= BEAM_Z))  # the lead foot comes down
    p_lead = c_hand[k2] + rel[k2, lead]
    p_lead[2] = BEAM_Z + pad
    c_lead = p_lead[None] - rel[:, lead]
    k = np.arange(n)[:, None]
    cen = np.where(k < k1, c_foot, np.where(k < k2, c_hand, c_lead))
    # the stand at the end: the lowest point on the beam (both feet flat), eased in over the last frames
    c_end = b.body.centre_on_feet(cen[-1:, :2], BEAM_Z, a[-1:], yaw[-1:], pitch[-1:], tw[-1:])[0]
    m = max(1, min(n - k2, b.frames_for(0.2)))
    cen[-m:] += smoothstep(np.arange(1, m + 1) / m)[:, None] * (c_end - cen[-1])[None]
    b.append(cen, yaw, pitch, tw, a, B.ARMS_UP, SKILL)
