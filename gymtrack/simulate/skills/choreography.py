"""The shared state of a target routine being built, and moves several apparatus use.

Paper: Section III-C (the gymnast's centre keeps to a vertical plane during much of the routine)
and III-D (the target's top and bottom rise above ``h_top`` / ``h_bot`` once the routine starts).
:class:`Choreography` wraps a :class:`~gymtrack.simulate.motion.MotionBuilder` (centres (n, 3) per frame);
the across-axis helpers (hang, circle dismount, the next pitch, support swings) serve the rings and the bars.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...apparatus import Apparatus
from .. import body as B
from ..motion import DISMOUNT, LANDING, MOUNT, SALUTE, SKILL, WAIT, WALK, MotionBuilder, smoothstep

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
        if support_z == 0.0:  # a landing on the floor (the contact frame is the flight's last); no steps
            self.b.record("landing", self.b.n - 1, self.b.n - 1, steps=0)
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



# ====================================================================== across-axis helpers (rings and bars)
def across_yaw(face: float) -> float:
    """Yaw of a body facing +y (face=+1) or -y (face=-1): its swings are in the y-z plane."""
    return np.pi / 2 if face > 0 else -np.pi / 2


def lift_to_hang(c: Choreography, grip: np.ndarray, seconds: float) -> None:
    """A coach lifts the gymnast from standing below the grip up to a hang (mount on rings / bars)."""
    b = c.b
    start = b.n
    hang = B.posture_angles(B.ARMS_UP)
    end = c.grip_centre(grip, hang, b.yaw, b.upright_pitch)
    # the arms go up with the feet still on the floor (the box centre rises with the hands)
    n = b.frames_for(0.4)
    a = b._blend_angles(hang, smoothstep(b._tau(n)))
    a[:, 10] = 0.0  # feet flat until the coach lifts
    yaw, pitch, tw = np.full(n, b.yaw), np.full(n, b.pitch), np.full(n, b.twist)
    b.append(b.body.centre_on_feet(np.repeat(b.centre[None, :2], n, 0), 0.0, a, yaw, pitch, tw), yaw, pitch, tw, a, B.ARMS_UP, WAIT)
    b.transition(seconds, end, pitch_end=b.upright_pitch, angles_end=hang, posture=B.ARMS_UP, phase=MOUNT)
    c.events.append(Event("lift", start, b.n, (float(grip[0]), float(grip[1]))))


#: Flyaway dismounts by saltos counted from the hang to the stand, as the rules count them (FIG Men's
#: Artistic Gymnastics Code of Points 2022-2024, horizontal bar and rings, element group V
#: "dismounts"; FIG Women's Code of Points 2022-2024, uneven bars, dismounts): the double salto
#: backward (tucked, piked or stretched) is the common dismount, the single flyaway a simpler one,
#: the triple salto backward a rare elite dismount on the men's apparatus and not met on uneven bars.
FLYAWAY_SALTOS = {"horizontal_bar": ((1, 2, 3), (0.15, 0.75, 0.10)), "still_rings": ((1, 2, 3), (0.10, 0.82, 0.08)),
                  "uneven_bars": ((1, 2), (0.30, 0.70))}


def flyaway_saltos(c: Choreography) -> int:
    """Saltos (hang to stand) of a flyaway dismount on the routine's apparatus (:data:`FLYAWAY_SALTOS`)."""
    k, p = FLYAWAY_SALTOS[c.app.name]
    return int(c.rng.choice(k, p=p))


def dismount_from_circle(c: Choreography, grip: np.ndarray, d: float, side_sign: float, reach: tuple[float, float],
                          apex_gain: tuple[float, float], saltos: int) -> None:
    """Release from a swing / giant on the up-swing and fly to the floor on the side ``side_sign``:
    a flyaway of ``saltos`` saltos counted from the last hang (pitch a multiple of 2 pi) to the
    stand, as the rules count it (much of the first salto's rotation is made before the release)."""
    b, rng = c.b, c.rng
    land_y = grip[1] + side_sign * rng.uniform(*reach)
    apex = b.centre[2] + rng.uniform(*apex_gain) + 0.3 * max(saltos - 2, 0)  # a triple needs more height
    shape = rng.choice([B.TUCK, B.PIKE, B.LAYOUT]) if saltos <= 2 else B.TUCK
    hang = np.floor(b.pitch / TWO_PI) * TWO_PI if d > 0 else np.ceil(b.pitch / TWO_PI) * TWO_PI
    rot = hang + d * TWO_PI * saltos - b.pitch
    c.flight_to_floor((grip[0] + rng.uniform(-0.2, 0.2), land_y), apex, rot, twist=np.pi * rng.choice([0, 1, 2]) if shape == B.LAYOUT else 0.0,
                      shape=shape, phase=DISMOUNT)
    c.land(0.0)



def pitch_ahead(current: float, d: float, rel: float, min_ahead: float = 0.3) -> float:
    """The first pitch past ``current`` in direction ``d`` (+1 / -1) that equals ``d * rel``
    modulo 2 pi, at least ``min_ahead`` radians on."""
    k = np.ceil((d * current + min_ahead - rel) / TWO_PI)
    return float(d * (rel + TWO_PI * k))


def support_shape(th: np.ndarray, up: float, base: np.ndarray | None = None) -> np.ndarray:
    """Support swing shape: arms stay vertical (shoulder flexion = pitch from upright)."""
    a = np.repeat((B.posture_angles(B.SUPPORT) if base is None else base)[None], th.size, 0)
    a[:, 5] = a[:, 6] = np.degrees(th - up)
    return a
