"""Building a person's motion as arrays over frames: phases appended one after another.

Paper: the target's 3D centre that the tracker must follow (Section III), in the gymnastics
setting of Section IV: walking in, salute, mount, skills, dismount, salute, walking out.

A :class:`MotionBuilder` holds the state of one body (centre, yaw, pitch, twist, posture
angles) and appends *phases*, each built as whole arrays over its frames (never a Python loop
per frame). A phase starts one frame after the last frame already built, from the state that
frame left, so joins are continuous by construction. Supported phases place the body by its
feet (:meth:`BodyModel.centre_on_feet`) or by its palms on a bar or ring
(:meth:`BodyModel.centre_on_grip`); in ballistic phases the centre of mass follows
``p(t) = p0 + v0 t - g t^2 / 2 e_z`` exactly (:meth:`MotionBuilder.flight`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import body as B
from .grip import GripPhases
from .phases import (DISMOUNT, G, LANDING, MOUNT, OFF_PLANE, PERFORMING, PHASE_NAMES, RUN_UP, SALUTE, SKILL, WAIT, WALK,
                     smoothstep, wrap_angle)

__all__ = ["G", "MAX_LANDING_CARRY", "WALK", "SALUTE", "MOUNT", "SKILL", "DISMOUNT", "LANDING", "OFF_PLANE", "WAIT", "RUN_UP", "PHASE_NAMES",
           "PERFORMING", "smoothstep", "wrap_angle", "Motion", "MotionBuilder"]


#: metres the body carries on over its planted feet while it absorbs a landing (about a foot's
#: length: the centre of mass leans over the feet; farther is a step)
MAX_LANDING_CARRY = 0.25


@dataclass
class Motion:
    """A person's motion over ``n`` frames.

    Attributes
    ----------
    centre: (n, 3) body centre, metres.
    yaw, pitch, twist: (n,) radians (:func:`gymtrack.simulate.body.orientation`).
    angles: (n, A) posture angles, degrees.
    posture: (n,) int8 posture label (:data:`gymtrack.simulate.body.POSTURE_NAMES`).
    phase: (n,) int8 phase label (:data:`PHASE_NAMES`).
    flight: (n,) bool, ballistic frames (only gravity acts).
    """

    centre: np.ndarray
    yaw: np.ndarray
    pitch: np.ndarray
    twist: np.ndarray
    angles: np.ndarray
    posture: np.ndarray
    phase: np.ndarray
    flight: np.ndarray

    def __len__(self) -> int:
        return len(self.centre)

    @property
    def performing(self) -> np.ndarray:
        return np.isin(self.phase, PERFORMING)

    def slice(self, start: int, stop: int) -> "Motion":
        return Motion(*(getattr(self, f)[start:stop] for f in self.__dataclass_fields__))


class MotionBuilder(GripPhases):
    """Appends phases for one body. ``fps`` frames per second; ``rng`` a numpy Generator.

    Phases on the feet and in flight are here; those hanging from a grip come from :class:`GripPhases`."""

    def __init__(self, body: B.BodyModel, fps: float, rng: np.random.Generator):
        self.body = body
        self.fps = float(fps)
        self.rng = rng
        self._chunks: list[dict[str, np.ndarray]] = []
        self._n = 0
        self.centre = np.zeros(3)
        self.yaw = self.pitch = self.twist = 0.0
        self.angles = B.posture_angles(B.STAND)
        self.posture = B.STAND
        self.gait = 0.0
        #: the choreography's elements as they are made: ``{"kind", "start", "end", ...}`` with 0-based
        #: frame indices (:mod:`.elements` turns them into ``gt/elements.json``); bookkeeping only
        self.records: list[dict] = []

    # ------------------------------------------------------------------ bookkeeping
    @property
    def n(self) -> int:
        """Frames built so far."""
        return self._n

    @property
    def time(self) -> float:
        return self._n / self.fps

    @property
    def upright_pitch(self) -> float:
        """The multiple of 2 pi nearest the current pitch (upright after any number of saltos)."""
        return float(np.round(self.pitch / (2 * np.pi)) * 2 * np.pi)

    def fold_twist(self) -> None:
        """When upright (pitch a multiple of 2 pi) a twist is a change of heading: move it to yaw
        so later phases do not unwind it. Leaves the orientation matrix unchanged."""
        if abs(self.pitch - self.upright_pitch) < 1e-6 and self.twist != 0.0:
            self.yaw += self.twist
            self.twist = 0.0

    def record(self, kind: str, start: int, end: int, **info) -> None:
        """Note an element the choreography made over frames ``start..end`` (0-based, inclusive)."""
        self.records.append({"kind": kind, "start": int(start), "end": int(end), **info})

    def frames_for(self, seconds: float) -> int:
        return max(1, int(round(seconds * self.fps)))

    def append(self, centre, yaw, pitch, twist, angles, posture, phase, flight=None) -> None:
        """Append frames given as arrays (n, 3), (n,), (n,), (n,), (n, A), label(s), label(s)."""
        centre = np.asarray(centre, dtype=np.float64).reshape(-1, 3)
        n = centre.shape[0]
        if n == 0:
            return
        full = lambda v, dt: np.broadcast_to(np.asarray(v, dtype=dt), (n,)).copy()  # noqa: E731
        chunk = {
            "centre": centre,
            "yaw": full(yaw, np.float64),
            "pitch": full(pitch, np.float64),
            "twist": full(twist, np.float64),
            "angles": np.broadcast_to(np.asarray(angles, dtype=np.float64), (n, B.N_ANGLES)).copy(),
            "posture": full(posture, np.int8),
            "phase": full(phase, np.int8),
            "flight": np.zeros(n, bool) if flight is None else full(flight, bool),
        }
        self._chunks.append(chunk)
        self._n += n
        self.centre = centre[-1].copy()
        self.yaw, self.pitch, self.twist = float(chunk["yaw"][-1]), float(chunk["pitch"][-1]), float(chunk["twist"][-1])
        self.angles = chunk["angles"][-1].copy()
        self.posture = int(chunk["posture"][-1])

    def build(self) -> Motion:
        """The motion built so far."""
        cat = {k: np.concatenate([c[k] for c in self._chunks]) for k in self._chunks[0]}
        return Motion(**cat)

    # ------------------------------------------------------------------ helpers
    def _tau(self, n: int) -> np.ndarray:
        """(n,) 1/n .. 1: the fraction of a phase of n frames reached at each of its frames."""
        return np.arange(1, n + 1) / n

    def _blend_angles(self, target: np.ndarray, w: np.ndarray) -> np.ndarray:
        return self.angles[None] + w[:, None] * (np.asarray(target, float)[None] - self.angles[None])

    def keyframed_angles(self, n: int, keys: list[tuple[float, np.ndarray]]) -> np.ndarray:
        """(n, A) angles through keyframes ``[(fraction, angles), ...]`` starting from the current
        angles at fraction 0, with minimum-jerk easing between keys."""
        fr = np.array([0.0] + [k[0] for k in keys])
        vals = np.stack([self.angles] + [np.asarray(k[1], float) for k in keys])
        tau = self._tau(n)
        seg = np.clip(np.searchsorted(fr, tau, side="right") - 1, 0, len(fr) - 2)
        span = np.maximum(fr[seg + 1] - fr[seg], 1e-9)
        w = smoothstep((tau - fr[seg]) / span)
        return vals[seg] + w[:, None] * (vals[seg + 1] - vals[seg])

    def place(self, xy, support_z: float, yaw: float, posture: int = B.STAND, phase: int = WALK) -> None:
        """Start the motion: one frame standing on ``support_z`` at ``xy`` facing ``yaw``."""
        a = B.posture_angles(posture)
        self.angles = a
        c = self.body.centre_on_feet(np.asarray(xy, float)[None], support_z, a[None], [yaw], [0.0], [0.0])
        self.append(c, yaw, 0.0, 0.0, a[None], posture, phase)

    # ------------------------------------------------------------------ supported phases
    def stand(self, seconds: float, support_z: float, posture: int = B.STAND, phase: int = WAIT,
              yaw: float | None = None, pitch: float = 0.0, sway: float = 0.004, angles: np.ndarray | None = None) -> None:
        """Stand (or hold a pose) on the feet for ``seconds``; posture and heading ease in."""
        n = self.frames_for(seconds)
        w = smoothstep(np.minimum(self._tau(n) * seconds / min(0.4, seconds), 1.0))
        a = self._blend_angles(B.posture_angles(posture) if angles is None else angles, w)
        yaw1 = self.yaw if yaw is None else self.yaw + wrap_angle(yaw - self.yaw)
        yw = self.yaw + w * (yaw1 - self.yaw)
        pw = self.pitch + w * (self.upright_pitch + pitch - self.pitch)
        tw = self.twist + w * (np.round(self.twist / (2 * np.pi)) * 2 * np.pi - self.twist)
        xy = self.centre[:2] + self._wobble(n, sway)
        c = self.body.centre_on_feet(xy, support_z, a, yw, pw, tw)
        n0, yaw0 = self.n, self.yaw
        self.append(c, yw, pw, tw, a, posture, phase)
        self.record("still", n0, n0 + n - 1)
        if yaw1 != yaw0:  # a turn on the spot
            self.record("turn", n0, n0 + n - 1, degrees=float(np.degrees(yaw1 - yaw0)))

    def _wobble(self, n: int, amp: float) -> np.ndarray:
        """(n, 2) a slow zero-start wobble of amplitude ``amp`` metres (balance, breathing)."""
        if amp <= 0:
            return np.zeros((n, 2))
        f = self.rng.uniform(0.2, 0.6, 2)
        ph = self.rng.uniform(0, 2 * np.pi, 2)
        t = np.arange(1, n + 1)[:, None] / self.fps
        return amp * (np.sin(2 * np.pi * f * t + ph) - np.sin(ph))

    def walk_to(self, xy, speed: float, support_z: float, phase: int = WALK, run: bool = False,
                accel_s: float = 0.5, lateral: float = 0.0) -> None:
        """Walk (or run) in a straight line to ``xy`` at cruising ``speed`` m/s, feet on ``support_z``.

        ``lateral``: amplitude (m) of the side-to-side sway of a walk (a few cm on a beam)."""
        start = self.centre[:2].copy()
        goal = np.asarray(xy, dtype=np.float64)
        d = float(np.linalg.norm(goal - start))
        if d < 1e-3:
            return
        ta = min(accel_s, d / speed / 2)
        T = d / speed + ta  # trapezoid profile: accelerate ta, cruise, decelerate ta
        n = max(2, self.frames_for(T))
        t = self._tau(n) * T
        # distance along the path of a trapezoidal speed profile, with smooth corners
        v = speed * np.minimum(np.minimum(t / ta, 1.0), np.minimum((T - t) / ta, 1.0))
        s = np.cumsum(np.concatenate([[0.0], (v[1:] + v[:-1]) / 2 * np.diff(t)])) + v[0] * t[0] / 2
        s = s / s[-1] * d
        u = (goal - start) / d
        heading = float(np.arctan2(u[1], u[0]))
        yaw1 = self.yaw + wrap_angle(heading - self.yaw)
        wy = smoothstep(np.minimum(t / 0.5, 1.0))
        yaw = self.yaw + wy * (yaw1 - self.yaw)
        stride = (1.25 if not run else 2.2) * self.body.height / 1.7
        gait = self.gait + 2 * np.pi * s / stride
        self.gait = float(gait[-1])
        amp = np.clip(v / speed, 0, 1)
        g = B.gait_angles(gait, run=run)
        base = B.posture_angles(B.STAND)
        a = base[None] + amp[:, None] * (g - base[None])
        a = self.angles[None] + smoothstep(np.minimum(t / 0.3, 1.0))[:, None] * (a - self.angles[None])
        pitch = self.pitch + smoothstep(np.minimum(t / 0.4, 1.0)) * (self.upright_pitch + (0.12 if run else 0.0) * amp - self.pitch)
        side = np.array([-u[1], u[0]])
        sway = lateral * np.sin(gait / 2) * amp
        xy_t = start[None] + s[:, None] * u[None] + sway[:, None] * side[None]
        tw = np.full(n, self.twist)
        c = self.body.centre_on_feet(xy_t, support_z, a, yaw, pitch, tw)
        k = int(min(np.searchsorted(t, 0.5), n - 1))  # the heading turns in the first 0.5 s
        if np.linalg.norm(xy_t[:min(k + self.frames_for(0.3), n - 1) + 1] - start, axis=1).max() < 0.5:
            self.record("turn", self.n, self.n + k, degrees=float(np.degrees(yaw[k] - self.yaw)))  # on the spot (a slow beam walk)
        self.append(c, yaw, pitch, tw, a, B.RUN if run else B.WALK, phase)

    def turn(self, yaw_delta: float, seconds: float, support_z: float, posture: int = B.TURN, phase: int = SKILL) -> None:
        """Turn on the spot by ``yaw_delta`` radians (a pirouette on a beam).

        A pivot turns about the supporting foot, on its ball (FIG Women's Artistic Gymnastics Code
        of Points 2022-2024, Balance Beam, turns: "on one foot", on the ball of the foot): the
        ball of the left foot (the ``TURN`` posture lifts the right leg) keeps its place on the support while the
        body turns over it, balanced: up on the ball of the foot, the support foot drawn under the body's
        middle, so the body turns about the vertical through that foot; its lowest point stays on ``support_z``."""
        n = self.frames_for(seconds)
        tau = self._tau(n)
        pv = B.posture_angles(posture)
        pv[10] = 1.0  # up on the ball of the foot (releve)
        pv[2] = -np.degrees(np.arcsin(0.052 / 0.49))  # the support foot under the body's middle (hip half-width over leg length)
        a = self.keyframed_angles(n, [(0.25, pv), (0.8, pv), (1.0, B.posture_angles(B.STAND))])
        yaw = self.yaw + smoothstep(tau) * yaw_delta
        pitch, tw = np.full(n, self.pitch), np.full(n, self.twist)
        toe, ankle = B.POINT_NAMES.index("left_toe"), B.POINT_NAMES.index("left_ankle")
        ball = lambda r: r[:, ankle, :2] + 0.7 * (r[:, toe, :2] - r[:, ankle, :2])  # noqa: E731 (the metatarsal heads)
        rel0, _ = self.body.oriented(self.angles[None], [self.yaw], [self.pitch], [self.twist])
        rel, _ = self.body.oriented(a, yaw, pitch, tw)
        xy = (self.centre[:2] + ball(rel0)[0])[None] - ball(rel)  # the ball of the pivot foot stays put
        # as the free leg comes down (the last fifth) the feet step back under the line the body stood on:
        # the model stands hip-width, so a half turn about one foot would leave the body 2 hip half-widths aside
        w = smoothstep(np.clip((tau - 0.8) / 0.2, 0.0, 1.0))[:, None]
        side = np.array([-np.sin(yaw[-1]), np.cos(yaw[-1])])
        off = (xy[-1] - self.centre[:2]) @ side
        xy = xy - w * off * side[None]
        c = self.body.centre_on_feet(xy, support_z, a, yaw, pitch, tw)
        self.record("turn", self.n, self.n + n - 1, degrees=float(np.degrees(yaw_delta)))
        self.append(c, yaw, pitch, tw, a, posture, phase)

    def pose_on_feet(self, seconds: float, support_z: float, keys, pitch_keys=None, posture: int = B.BALANCE, phase: int = SKILL,
                     xy_end=None) -> None:
        """A supported pose (balance, squat...) through angle keyframes; optional pitch keyframes
        ``[(fraction, lean)]`` (radians, relative to upright) and a slide of the feet to ``xy_end``."""
        n = self.frames_for(seconds)
        tau = self._tau(n)
        a = self.keyframed_angles(n, keys)
        p = np.full(n, self.pitch)
        if pitch_keys:
            fr = np.array([0.0] + [k[0] for k in pitch_keys])
            pv = np.array([self.pitch] + [self.upright_pitch + k[1] for k in pitch_keys])
            seg = np.clip(np.searchsorted(fr, tau, side="right") - 1, 0, len(fr) - 2)
            p = pv[seg] + smoothstep((tau - fr[seg]) / np.maximum(fr[seg + 1] - fr[seg], 1e-9)) * (pv[seg + 1] - pv[seg])
        xy0 = self.centre[:2]
        xy1 = xy0 if xy_end is None else np.asarray(xy_end, float)
        xy = xy0[None] + smoothstep(tau)[:, None] * (xy1 - xy0)[None]
        c = self.body.centre_on_feet(xy, support_z, a, np.full(n, self.yaw), p, np.full(n, self.twist))
        self.record("still", self.n, self.n + n - 1)  # still where its keyframes hold a pose (balance, salute)
        self.append(c, self.yaw, p, self.twist, a, posture, phase)

    def absorb(self, support_z: float, seconds: float, angles_end, posture: int = B.CROUCH, phase: int = SKILL) -> None:
        """Absorb a landing: the feet are down, the legs bend on into ``angles_end`` while the
        body keeps moving the way it came and slows to rest (ease-out, so the centre's speed
        falls from the impact speed instead of stopping within one frame). The feet stay planted,
        so the body carries on over them by at most :data:`MAX_LANDING_CARRY` (a landing with more
        momentum than that would take a step, which the choreography does not make)."""
        if self.n < 2:
            return
        v_h = self.com_velocity()[:2]  # the centre of mass carries on, not the turning body's box
        n = self.frames_for(seconds)
        T = n / self.fps
        tau = self._tau(n)
        s = 1.0 - (1.0 - tau) ** 2
        a = self._blend_angles(angles_end, s)
        carry = 0.5 * T * v_h
        carry *= min(1.0, MAX_LANDING_CARRY / max(float(np.linalg.norm(carry)), 1e-9))
        xy = self.centre[None, :2] + s[:, None] * carry[None]
        c = self.body.centre_on_feet(xy, support_z, a, np.full(n, self.yaw), np.full(n, self.pitch), np.full(n, self.twist))
        self.append(c, self.yaw, self.pitch, self.twist, a, posture, phase)

    def com_velocity(self) -> np.ndarray:
        """(3,) the centre of mass' velocity over the last frame built (m/s)."""
        two = {k: np.concatenate([c[k][-2:] for c in self._chunks[-2:]])[-2:] for k in ("centre", "angles", "yaw", "pitch", "twist")}
        q = two["centre"] + self.body.com_offset(two["angles"], two["yaw"], two["pitch"], two["twist"])
        return (q[1] - q[0]) * self.fps

    def push(self, support_z: float, seconds: float, angles_end, posture: int = B.STAND, phase: int = SKILL) -> None:
        """Push off: the legs extend into ``angles_end`` speeding up (ease-in), so a flight that
        follows starts from a moving body."""
        n = self.frames_for(seconds)
        s = self._tau(n) ** 2
        a = self._blend_angles(angles_end, s)
        xy = np.repeat(self.centre[None, :2], n, 0)
        c = self.body.centre_on_feet(xy, support_z, a, np.full(n, self.yaw), np.full(n, self.pitch), np.full(n, self.twist))
        self.append(c, self.yaw, self.pitch, self.twist, a, posture, phase)

    # ------------------------------------------------------------------ free transitions
    def transition(self, seconds: float, centre_end, yaw_end=None, pitch_end=None, twist_end=None, angles_end=None,
                   posture: int | None = None, phase: int = SKILL, arc=None, angle_keys=None) -> None:
        """Minimum-jerk move of everything from the current state to the given end state.

        arc: (3,) extra displacement at mid-phase (``sin(pi s)`` profile), e.g. the hump of a
        walkover. angle_keys: keyframes for the posture instead of a straight blend.
        """
        n = self.frames_for(seconds)
        s = smoothstep(self._tau(n))
        c1 = np.asarray(centre_end, dtype=np.float64)
        c = self.centre[None] + s[:, None] * (c1 - self.centre)[None]
        if arc is not None:
            c = c + np.sin(np.pi * s)[:, None] * np.asarray(arc, float)[None]
        yaw = self.yaw + s * ((self.yaw if yaw_end is None else yaw_end) - self.yaw)
        pitch = self.pitch + s * ((self.pitch if pitch_end is None else pitch_end) - self.pitch)
        twist = self.twist + s * ((self.twist if twist_end is None else twist_end) - self.twist)
        if angle_keys is not None:
            a = self.keyframed_angles(n, angle_keys)
        else:
            a = self._blend_angles(self.angles if angles_end is None else angles_end, s)
        self.append(c, yaw, pitch, twist, a, self.posture if posture is None else posture, phase)

    def flight(self, centre_end, n_frames: int, pitch_end: float, twist_end: float | None = None, yaw_end: float | None = None,
               angle_keys=None, posture: int = B.TUCK, phase: int = SKILL) -> np.ndarray:
        """Ballistic flight to ``centre_end`` in exactly ``n_frames`` frames; returns the centre of
        mass' take-off velocity.

        Frames 1..n-1 are in the air (``flight`` True) and the centre of mass follows the parabola
        exactly (the centre moves about it as the body turns and changes shape); frame n
        is the contact (landing or regrasp) at ``centre_end``. Rotations are uniform in time
        (angular momentum is conserved; the shape changes are in ``angle_keys``).
        """
        n = max(2, int(n_frames))
        T = n / self.fps
        t = np.arange(1, n + 1) / self.fps
        tau = t / T
        pitch = self.pitch + tau * (pitch_end - self.pitch)
        twist = self.twist + tau * ((self.twist if twist_end is None else twist_end) - self.twist)
        yaw = self.yaw + tau * ((self.yaw if yaw_end is None else yaw_end) - self.yaw)
        a = self.keyframed_angles(n, angle_keys) if angle_keys else np.repeat(self.angles[None], n, 0)
        # Gravity moves the centre of mass, not the box centre: a body that turns over or changes
        # shape in the air moves its centre about its centre of mass.
        off = self.body.com_offset(a, yaw, pitch, twist)
        off0 = self.body.com_offset(self.angles[None], np.array([self.yaw]), np.array([self.pitch]), np.array([self.twist]))[0]
        q0 = self.centre + off0
        q1 = np.asarray(centre_end, dtype=np.float64) + off[-1]
        gvec = np.array([0.0, 0.0, -G])
        v0 = (q1 - q0) / T - 0.5 * gvec * T
        c = q0[None] + t[:, None] * v0[None] + 0.5 * t[:, None] ** 2 * gvec[None] - off
        c[-1] = centre_end  # the same number up to rounding; make the contact exact
        fl = np.ones(n, bool)
        fl[-1] = False
        self.record("flight", self.n, self.n + n - 2)
        self.append(c, yaw, pitch, twist, a, posture, phase, fl)
        return v0

    def flight_frames(self, z0: float, z1: float, apex: float) -> int:
        """Frames of a flight from height ``z0`` over ``apex`` down (or up) to ``z1``."""
        apex = max(apex, z0 + 0.02, z1 + 0.02)
        t = np.sqrt(2 * (apex - z0) / G) + np.sqrt(2 * (apex - z1) / G)
        return max(3, int(round(t * self.fps)))

    def truncate(self, k: int) -> None:
        """Drop the last ``k`` frames (e.g. to release a swing before its turning point)."""
        while k > 0 and self._chunks:
            last = self._chunks[-1]
            m = len(last["centre"])
            if m <= k:
                self._chunks.pop()
                self._n -= m
                k -= m
            else:
                for key in last:
                    last[key] = last[key][: m - k]
                self._n -= k
                k = 0
        self.records = [dict(r, end=min(r["end"], self._n - 1)) for r in self.records if r["start"] < self._n]
        last = self._chunks[-1]
        self.centre = last["centre"][-1].copy()
        self.yaw, self.pitch, self.twist = float(last["yaw"][-1]), float(last["pitch"][-1]), float(last["twist"][-1])
        self.angles = last["angles"][-1].copy()
        self.posture = int(last["posture"][-1])
