"""Vault: run-up, hurdle, board, pre-flight, table, post-flight, landing.

Paper: Section IV's vault; the flights (centre peaking at 2.4-3.0 m) test Section III-D's
identification heights and Section III-C's plane along the runway.
"""

from __future__ import annotations

import numpy as np

from .. import body as B
from ..motion import DISMOUNT, RUN_UP, SKILL, WAIT, WALK
from .choreography import TWO_PI, Choreography

# ====================================================================== vault
TABLE_Z = 1.35


#: Shortest run-up (m); a routine under CLIP_SECONDS is one vault from the start of its run-up
#: (a short approach, down to CLIP_RUN_UP m), leaving VAULT_AFTER_RUN_UP s for the board, table,
#: post-flight and landing.
MIN_RUN_UP = 8.0
CLIP_SECONDS = 10.0
CLIP_RUN_UP = 5.0
VAULT_AFTER_RUN_UP = 3.0


def _run_time(L: float, v_max: float, tau: float) -> float:
    """Seconds to run L metres from standing: x(t) = v_max (t - tau (1 - e^{-t/tau})) (Newton)."""
    t = L / v_max + tau
    for _ in range(30):
        t -= (v_max * (t - tau * (1 - np.exp(-t / tau))) - L) / (v_max * (1 - np.exp(-t / tau)))
    return float(t)


def vault_routine(c: Choreography) -> None:
    b, rng = c.b, c.rng
    s = np.asarray(c.app.performance_space)
    first = True
    clip = c.end_frame / c.fps < CLIP_SECONDS  # a clip of one vault: no walk in, no salute before it
    while True:
        x_board = -rng.uniform(2.6, 2.9)
        v_max = rng.uniform(7.5, 8.5)
        tau = rng.uniform(0.9, 1.2)
        # run-up length: as long as allowed (up to 25 m), shorter if the routine is short
        t_vault = 7.5  # board to the end of the walk out
        avail = c.left - t_vault - (6.0 if first else 4.0)
        L_max = min(s[0] + 1.0 - (x_board - 2.0), 0.0) * -1.0  # runway start stays inside S_perf
        L = float(np.clip(rng.uniform(15.0, 23.0), MIN_RUN_UP, L_max))
        if clip:  # the run-up takes what standing ready, the vault and its landing leave
            avail = c.left - 0.25 - VAULT_AFTER_RUN_UP
        # time to run L: x(t) = v (t - tau (1 - e^{-t/tau}))
        while not clip and L > MIN_RUN_UP and (L / v_max + tau) > max(avail, 2.0):
            L -= 1.0
        while clip and L > CLIP_RUN_UP and _run_time(L, v_max, tau) > avail:
            L -= 0.5
        x_start = x_board - 2.0 - L
        if clip:
            b.place((x_start, 0.0), 0.0, 0.0)
            b.stand(0.2, 0.0, B.STAND, WAIT, yaw=0.0)
            first = False
        elif first:
            entry = c.entry([x_start, 0.0], [x_start - rng.uniform(0.0, 0.8), -c.layout.judge_side * rng.uniform(2.2, 3.0)])
            b.place(entry, 0.0, float(np.arctan2(-entry[1], x_start - entry[0])))
            b.walk_to((x_start, 0.0), rng.uniform(1.1, 1.4), 0.0, WALK)
        else:
            b.walk_to((x_start, -c.layout.judge_side * 2.2), rng.uniform(1.4, 1.8), 0.0, WALK)
            b.walk_to((x_start, 0.0), 1.2, 0.0, WALK)
        if not clip:
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
