"""Phases that hang from a grip: giants, pendulum swings, holds and turns about a bar or rings.

Paper: the bar and ring skills of Section IV's apparatus, where the centre circles the grip in a
vertical plane (Section III-C). :class:`GripPhases` is a mixin of
:class:`~gymtrack.simulate.motion.MotionBuilder`: each method appends whole arrays over a phase's
frames (pitch (n,), posture angles (n, A), centre (n, 3) from
:meth:`~gymtrack.simulate.body.BodyModel.centre_on_grip`).
"""

from __future__ import annotations

import numpy as np

from . import body as B
from .phases import G, SKILL, smoothstep


class GripPhases:
    """Swinging about a grip; relies on the builder's state and bookkeeping (``append``, ``_tau``...)."""

    def _grip_phase(self, grip: np.ndarray, pitch: np.ndarray, yaw: float, angles: np.ndarray, posture: int, phase: int) -> None:
        n = len(pitch)
        yaw_a = np.full(n, yaw)
        tw = np.full(n, self.twist)
        c = self.body.centre_on_grip(np.broadcast_to(grip, (n, 3)), angles, yaw_a, pitch, tw)
        self.record("grip", self.n, self.n + n - 1)  # the hands hold the bar or rings (circles are counted on these runs)
        self.append(c, yaw_a, pitch, tw, angles, posture, phase)

    def giant(self, grip, turns: float, direction: float, omega_top: float, yaw: float, posture: int = B.ARMS_UP,
              phase: int = SKILL, angle_fn=None, ramp_in: float = 0.0, ramp_out: float = 0.0) -> None:
        """Circles about a bar held at ``grip`` (3,): ``turns`` turns, ``direction`` +1 / -1.

        The body pitch (its angle about the bar, 0 = hanging, pi = handstand) follows energy
        conservation of a physical pendulum, ``w^2 = w_top^2 + 2 g d / (d^2 + k^2) (1 + cos a)``,
        so the body is slow over the bar and fast under it, as in a real giant swing.
        ``angle_fn(pitch) -> (n, A)`` may shape the body along the circle (pike at the bottom...).
        ``ramp_in`` / ``ramp_out`` (radians): start from rest / come to rest over that angle
        (out of a handstand or a swing's turning point, into a turning point); the speed never
        exceeds the energy-conserving one.
        """
        a_post = B.posture_angles(posture)
        d = self.body.grip_radius(a_post)
        k2 = (0.45 * 2.28 * self.body.height / 1.7) ** 2 / 3  # radius of gyration^2 of a straight body about its centre
        th0 = self.pitch
        th1 = th0 + direction * 2 * np.pi * turns
        grid = np.linspace(th0, th1, 4000)
        w = np.sqrt(omega_top**2 + 2 * G * d / (d * d + k2) * (1 + np.cos(grid)))
        if ramp_in > 0:
            w = w * np.sqrt(np.clip(np.abs(grid - th0) / ramp_in, 0.03, 1.0))
        if ramp_out > 0:
            w = w * np.sqrt(np.clip(np.abs(th1 - grid) / ramp_out, 0.03, 1.0))
        dt = np.abs(np.diff(grid)) / (0.5 * (w[1:] + w[:-1]))
        tg = np.concatenate([[0.0], np.cumsum(dt)])
        n = int(np.floor(tg[-1] * self.fps))
        if n < 1:
            return
        th = np.interp(np.arange(1, n + 1) / self.fps, tg, grid)
        ang = np.repeat(a_post[None], n, 0) if angle_fn is None else angle_fn(th)
        # ease the posture in over the first 0.3 s
        wgt = smoothstep(np.minimum(np.arange(1, n + 1) / (0.3 * self.fps), 1.0))
        ang = self.angles[None] + wgt[:, None] * (ang - self.angles[None])
        self.record("giant", self.n, self.n + n - 1, grip=[float(v) for v in grip], direction=float(np.sign(direction)))
        self._grip_phase(np.asarray(grip, float), th, yaw, ang, posture, phase)

    def swing(self, grip, amplitudes, yaw: float, posture: int = B.ARMS_UP, phase: int = SKILL, centre_angle: float = 0.0,
              angle_fn=None, radius: float | None = None) -> None:
        """Pendulum swings about ``grip`` (3,): the body turns from its current pitch through the
        turning points ``centre_angle + A_1, centre_angle - A_2, centre_angle + A_3, ...``
        (``amplitudes`` in radians; start with a negative amplitude to swing the other way
        first). Each half swing lasts half the period of a physical pendulum (pivot to centre
        ``radius``, default the palms-to-centre distance of ``posture``) with the
        large-amplitude correction; the speed is zero at the turning points.
        ``angle_fn(pitch) -> (n, A)`` shapes the body along the swing (support swings keep the
        arms vertical with it)."""
        a_post = B.posture_angles(posture)
        d = self.body.grip_radius(a_post) if radius is None else radius
        k2 = (0.45 * 2.28 * self.body.height / 1.7) ** 2 / 3
        T0 = 2 * np.pi * np.sqrt((d * d + k2) / (G * d))
        tps = [self.pitch] + [centre_angle + (A if i % 2 == 0 else -A) for i, A in enumerate(amplitudes)]
        parts = []
        for a0, a1 in zip(tps[:-1], tps[1:]):
            A = min(max(abs(a0 - centre_angle), abs(a1 - centre_angle)), 2.5)
            T = T0 * (1 + A * A / 16 + 11 * A**4 / 3072)
            n = self.frames_for(T / 2)
            s = np.arange(1, n + 1) / n
            parts.append(a0 + (a1 - a0) * (1 - np.cos(np.pi * s)) / 2)
        th = np.concatenate(parts)
        n = th.size
        wgt = smoothstep(np.minimum(np.arange(1, n + 1) / (0.3 * self.fps), 1.0))
        target = np.repeat(a_post[None], n, 0) if angle_fn is None else angle_fn(th)
        ang = self.angles[None] + wgt[:, None] * (target - self.angles[None])
        self._grip_phase(np.asarray(grip, float), th, yaw, ang, posture, phase)

    def hold_grip(self, grip, seconds: float, yaw: float, angles=None, posture: int | None = None, phase: int = SKILL,
                  grip_end=None) -> None:
        """Hold a pose on the grip (handstand, L-sit, cross); the grip may slide to ``grip_end``
        (walking on the hands along parallel bars, shifting the hands along a bar)."""
        n = self.frames_for(seconds)
        s = smoothstep(self._tau(n))
        g0 = np.asarray(grip, float)
        g = g0[None] + (s[:, None] * (np.asarray(grip_end, float) - g0)[None] if grip_end is not None else 0.0)
        w = smoothstep(np.minimum(self._tau(n) * seconds / min(0.4, seconds), 1.0))
        a = self._blend_angles(self.angles if angles is None else angles, w)
        sway = self._wobble(n, 0.01)[:, 0] * 0.5
        th = np.full(n, self.pitch) + sway
        yaw_a = np.full(n, yaw)
        tw = np.full(n, self.twist)
        c = self.body.centre_on_grip(np.broadcast_to(g, (n, 3)), a, yaw_a, th, tw)
        self.record("still", self.n, self.n + n - 1)  # a held pose: handstand, L-sit, cross, support
        self.record("grip", self.n, self.n + n - 1)
        self.append(c, yaw_a, th, tw, a, self.posture if posture is None else posture, phase)

    def grip_transition(self, grip, seconds: float, pitch_end: float, yaw: float, angles_end=None, posture: int | None = None,
                        phase: int = SKILL, angle_keys=None, angle_fn=None, linear: bool = False) -> None:
        """Turn about the grip to ``pitch_end`` with minimum jerk (kips, casts, presses), or at a
        constant rate (``linear``: a short contact such as the vault's repulsion off the table).
        ``angle_fn(pitch) -> (n, A)`` shapes the body by its pitch (arms kept vertical...)."""
        n = self.frames_for(seconds)
        s = self._tau(n) if linear else smoothstep(self._tau(n))
        th = self.pitch + s * (pitch_end - self.pitch)
        if angle_fn is not None:
            a = angle_fn(th)
        elif angle_keys is not None:
            a = self.keyframed_angles(n, angle_keys)
        else:
            a = self._blend_angles(self.angles if angles_end is None else angles_end, s)
        self._grip_phase(np.asarray(grip, float), th, yaw, a, self.posture if posture is None else posture, phase)
