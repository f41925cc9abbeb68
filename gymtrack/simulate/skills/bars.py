"""Horizontal bar, uneven bars and parallel bars: giants, casts, releases, supports, dismounts.

Paper: Section IV's bar apparatus; Section III-C's plane holds the giants (centre circling
~1.0 m around the bar) with up to 0.5 m of off-plane drift (:func:`add_drift`).
"""

from __future__ import annotations

import numpy as np

from .. import body as B
from ..motion import DISMOUNT, MAX_LANDING_CARRY, MOUNT, SKILL, WAIT, WALK, smoothstep
from .choreography import (CROUCH_LIGHT, TWO_PI, Choreography, Event, across_yaw, dismount_from_circle, flyaway_saltos, lift_to_hang,
                           pitch_ahead, support_shape)

# ====================================================================== horizontal bar and uneven bars
HIGH_BAR_Z = 2.8
UB_LOW = (-0.75, 1.7)
UB_HIGH = (0.75, 2.5)
UB_PIKE_DEG = 70.0
UB_ARCH_HIP_DEG, UB_ARCH_TRUNK_DEG = 20.0, 35.0  #: an arch: hip hyperextension and back extension


def _through_bars(c: Choreography, n0: int, clearance: float = 0.02, skip_last: int = 0) -> bool:
    """Whether a limb of the frames built since ``n0`` (less the last ``skip_last``) passes through a
    bar, or within ``clearance`` of its surface (the palms and wrists, which hold it, apart): a
    flight that would is flown another way."""
    b = c.b
    k = b.n - n0 - skip_last
    ch = b.build().slice(n0, n0 + k)
    pts, _ = b.body.world_points(ch.centre, ch.angles, ch.yaw, ch.pitch, ch.twist)
    s = np.linspace(0.0, 0.8, 5)[None, None, :, None]  # along each limb, short of its end (a wrist on the bar)
    i, j = np.array([5, 6, 7, 8, 11, 12, 13, 14, 5, 6]), np.array([7, 8, 9, 10, 13, 14, 15, 16, 11, 12])
    q = (pts[:, i, None] + s * (pts[:, j, None] - pts[:, i, None])).reshape(k, -1, 3)
    for bar in c.app.bars:
        a, e = np.asarray(bar.start, float), np.asarray(bar.end, float)
        t = np.clip(((q - a) @ (e - a)) / ((e - a) @ (e - a)), 0.0, 1.0)
        if (np.linalg.norm(q - (a + t[..., None] * (e - a)), axis=-1) <= bar.radius + clearance).any():
            return True
    return False


def _cast_to_handstand(c: Choreography, grip, yaw: float) -> None:
    """From front support, cast (swing the legs back and up) to a handstand: pitch +pi, arms
    kept vertical (shoulder flexion follows the pitch)."""
    b = c.b
    up = b.upright_pitch
    b.grip_transition(grip, c.rng.uniform(0.9, 1.2), up + np.pi, yaw, posture=B.ARMS_UP, phase=SKILL,
                      angle_fn=lambda th: support_shape(th, up))


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


def _giant_clear_low_bar(c: Choreography, grip, yaw: float):
    """The body's shape along a giant on the uneven bars' high bar: a straight body reaches 1.1 x its
    height past the hands, further than the low bar (1.7 m away), so through the lower half of the
    circle the gymnast either pikes (up to :data:`UB_PIKE_DEG`) or arches (hips and trunk extended,
    as far as a gymnast's back allows) round the low bar -- the pike where it keeps the legs 8 cm
    clear of the bar, else whichever keeps them further from it. Returns ``angle_fn(pitch) -> (n, A)``."""
    low = np.array([grip[0], UB_LOW[0], UB_LOW[1]])

    def shape(th: np.ndarray) -> np.ndarray:
        straight = _giant_shape(th)
        lo, hi = np.cos(np.radians(175.0)), np.cos(np.radians(95.0))  # bending over the slow top of the circle, fully bent below the bar
        w = smoothstep(np.clip((np.cos(th) - lo) / (hi - lo), 0.0, 1.0))
        pike, arch = straight.copy(), straight.copy()
        pike[:, 0] = pike[:, 1] = UB_PIKE_DEG * w
        arch[:, 0] = arch[:, 1] = -UB_ARCH_HIP_DEG * w
        arch[:, 11] = -UB_ARCH_TRUNK_DEG * w
        n = th.size
        gap = []
        for a in (pike, arch):
            cen = c.b.body.centre_on_grip(np.broadcast_to(np.asarray(grip, float), (n, 3)), a, np.full(n, yaw), th, np.zeros(n))
            pts, _ = c.b.body.world_points(cen, a, np.full(n, yaw), th, np.zeros(n))
            gap.append(np.linalg.norm(pts[:, 11:17, 1:] - low[None, None, 1:], axis=-1).min(axis=1))  # hips, knees, ankles
        # one shape for the whole giant (no jump between them): the pike where it clears the bar
        return pike if gap[0].min() >= min(gap[1].min(), 0.08) else arch

    return shape


def _giant_to(c: Choreography, grip, yaw: float, d: float, rel: float, min_ahead: float = 0.3, phase: int = SKILL,
              omega_top: float | None = None, ramp_out: float = 0.0) -> None:
    """Giants in direction ``d`` up to the pitch ``d * rel`` (mod 2 pi) at least ``min_ahead`` on;
    a giant starting from a handstand starts slowly."""
    b = c.b
    target = pitch_ahead(b.pitch, d, rel, min_ahead)
    w_top = c.rng.uniform(2.3, 3.2) if omega_top is None else omega_top
    at_top = abs(np.cos(b.pitch) + 1.0) < 0.05
    shape = _giant_clear_low_bar(c, grip, yaw) if c.app.name == "uneven_bars" and grip[2] == UB_HIGH[1] else _giant_shape
    b.giant(grip, abs(target - b.pitch) / TWO_PI, d, w_top, yaw, phase=phase, angle_fn=shape,
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
    dismount_from_circle(c, grip, d, side, reach, (0.9, 1.2), flyaway_saltos(c))
    c._phase = SKILL


def horizontal_bar_routine(c: Choreography) -> None:
    b, rng = c.b, c.rng
    face = rng.choice([-1.0, 1.0])
    yaw = across_yaw(face)
    side_in = -c.layout.judge_side
    xg = rng.uniform(-0.3, 0.3)
    entry = c.entry([side_in * 0.8, 0.0], [side_in * rng.uniform(2.3, 3.0), rng.uniform(-2.0, 2.0)])
    b.place(entry, 0.0, float(np.arctan2(-entry[1], side_in * 0.8 - entry[0])))
    b.walk_to((side_in * 0.8, 0.0), rng.uniform(1.1, 1.4), 0.0, WALK)
    c.salute()
    b.walk_to((xg, 0.0), 0.8, 0.0, WALK)
    b.stand(0.5, 0.0, B.STAND, WAIT, yaw=yaw)
    grip = np.array([xg, 0.0, HIGH_BAR_Z])
    lift_to_hang(c, grip, rng.uniform(1.0, 1.3))
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


def uneven_bars_routine(c: Choreography) -> None:
    b, rng = c.b, c.rng
    yaw = across_yaw(1.0)  # facing the high bar from the low bar
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
        th0 = b.pitch

        def pike_past_high(th: np.ndarray) -> np.ndarray:  # the legs pike under the high bar as the body falls towards it
            a = _giant_shape(th)
            a[:, 0] = a[:, 1] = 75.0 * smoothstep(np.clip(np.abs(th - th0) / (0.3 * TWO_PI), 0.0, 1.0))
            return a

        b.giant(low, 0.2, 1.0, 1.2, yaw, angle_fn=pike_past_high, ramp_in=0.6)
        th_g = b.upright_pitch + rng.uniform(-0.3, 0.1)
        end = c.grip_centre(high, arms, yaw, th_g)
        gain = rng.uniform(0.2, 0.4)
        n0 = b.n
        for hold in (0.4, 0.6, 0.75, 0.85, 0.92):  # keep the pike until the legs are past the high bar
            b.flight(end, b.flight_frames(b.centre[2], end[2], max(b.centre[2], end[2]) + gain), th_g,
                     angle_keys=[(0.4, B.posture_angles(B.PIKE)), (hold, B.posture_angles(B.PIKE)), (1.0, arms)], posture=B.PIKE, phase=SKILL)
            if not _through_bars(c, n0) or hold == 0.92:
                break
            b.truncate(b.n - n0)
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
PB_SPACING = 0.47
RAIL_CLEAR = 0.15  #: metres: a joint's distance from the rails' top and end that clears them (flesh, off-plane drift)


def _on_rails(angles: np.ndarray, height: float) -> np.ndarray:
    """``angles`` with the shoulder abduction that puts the palms on the rails, 0.47 m apart (the
    shoulders 0.11 H off the middle, the arm to the palm 0.38 H): the hands hold the rails."""
    a = angles.copy()
    a[7] = np.degrees(np.arcsin(np.clip((PB_SPACING / 2 - 0.11 * height) / (0.38 * height), -1.0, 1.0)))
    return a


def _dismount_off_the_end(c: Choreography, end_dir: float, up: float) -> None:
    """A salto off the end of the parallel bars that clears the rails: released above them, the body
    comes down below the rails' top only past their end (the gymnast flies off the end of the bars,
    FIG Men's Artistic Gymnastics Code of Points 2022-2024, parallel bars, element group V, dismounts).
    A flight that would bring a joint down between or onto the rails is flown higher and longer."""
    b, rng = c.b, c.rng
    d = float(np.sign(b.pitch - up) or 1.0)
    n_salto = int(rng.choice([0, 1]))
    shape = rng.choice([B.TUCK, B.PIKE])
    nxt = np.ceil(b.pitch / TWO_PI) * TWO_PI if d > 0 else np.floor(b.pitch / TWO_PI) * TWO_PI
    far = c.app.performance_space[3] - MAX_LANDING_CARRY - 0.05  # landed, the body carries on over its feet
    land_x = float(end_dir * min(rng.uniform(PB_HALF + 0.5, PB_HALF + 0.8), far))
    gain = rng.uniform(0.3, 0.6)
    y_land = rng.uniform(-0.05, 0.05)
    n0 = b.n
    for attempt in range(8):
        c.flight_to_floor((land_x, y_land), b.centre[2] + gain, (nxt - b.pitch) + d * TWO_PI * n_salto, shape=shape, phase=DISMOUNT)
        last = b._chunks[-1]
        pts, _ = b.body.world_points(last["centre"], last["angles"], last["yaw"], last["pitch"], last["twist"])
        low = pts[:, :17, 2] < PB_Z + RAIL_CLEAR
        within = np.abs(pts[:, :17, 0]) < PB_HALF + RAIL_CLEAR
        low[: b.frames_for(0.15), 9:11] = False  # the wrists leave the rails at the release
        if not (low & within).any() or attempt == 7:
            return
        b.truncate(b.n - n0)
        gain, land_x = gain + 0.1, end_dir * min(abs(land_x) + 0.15, far)


def parallel_bars_routine(c: Choreography) -> None:
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
    sup, hs, lsit = (_on_rails(B.posture_angles(p), b.body.height) for p in (B.SUPPORT, B.ARMS_UP, B.L_SIT))
    end = c.grip_centre(grip, sup, yaw, b.upright_pitch)
    # the arms come to support before the hands meet the rails, from above: a jump that would bring
    # the body near a rail's end on the way up is jumped higher
    n0 = b.n
    for gain in (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7):
        b.flight(end, b.flight_frames(b.centre[2], end[2], end[2] + gain), b.pitch, angle_keys=[(0.35, CROUCH_LIGHT), (0.75, sup), (1.0, sup)],
                 posture=B.SUPPORT, phase=MOUNT)
        # clear of the rails by the contract's contact distance until the hands come down on them
        if not _through_bars(c, n0, clearance=0.0, skip_last=2) or gain == 0.7:
            break
        b.truncate(b.n - n0)
    b.hold_grip(grip, 0.4, yaw, sup, B.SUPPORT, MOUNT)
    up = b.upright_pitch
    r_sh = 0.32 * b.body.height  # shoulders to centre in support: the swing's pivot radius
    reserve = 7.5
    while c.left > reserve:
        n0, saved = b.n, (grip.copy(), up, h)
        kind = rng.choice(["swings", "handstand", "travel", "l_sit", "salto"], p=[0.35, 0.2, 0.17, 0.11, 0.17])
        if kind == "swings":
            amps = list(np.linspace(0.5, rng.uniform(1.0, 1.5), int(rng.integers(3, 6))))
            b.swing(grip, amps + [0.3, 0.0], yaw, B.SUPPORT, SKILL, centre_angle=up, angle_fn=lambda th: support_shape(th, up, sup), radius=r_sh)
        elif kind == "handstand":
            amps = [0.7, 1.3, 2.0]
            b.swing(grip, amps, yaw, B.SUPPORT, SKILL, centre_angle=up, angle_fn=lambda th: support_shape(th, up, sup), radius=r_sh)
            b.grip_transition(grip, 0.6, up + np.pi, yaw, hs, B.ARMS_UP, SKILL)
            b.hold_grip(grip, rng.uniform(1.0, 2.0), yaw, hs, B.ARMS_UP, SKILL)
            b.swing(grip, [1.5, 0.9, 0.4, 0.0], yaw, B.SUPPORT, SKILL, centre_angle=up, angle_fn=lambda th: support_shape(th, up, sup),
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
            b.hold_grip(grip, rng.uniform(1.5, 2.2), yaw, lsit, B.L_SIT, SKILL)
            b.hold_grip(grip, 0.4, yaw, sup, B.SUPPORT, SKILL)
        elif kind == "salto":
            # swing to the front, let go at the turning point, salto on in the same direction,
            # catch in support a little further along
            b.swing(grip, [0.6, 1.0, 1.3], yaw, B.SUPPORT, SKILL, centre_angle=up, angle_fn=lambda th: support_shape(th, up, sup), radius=r_sh)
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
        if c.left < reserve:  # ran into the time kept for the dismount: undo
            b.truncate(b.n - n0)
            grip, up, h = saved
            break
    # Dismount: walk on the hands to the end, swing up, salto off the end.
    c._phase = DISMOUNT
    end_dir = 1.0 if grip[0] >= 0 else -1.0
    g_end = np.array([end_dir * (PB_HALF - 0.35), grip[1], grip[2]])
    if abs(g_end[0] - grip[0]) > 0.05:
        b.hold_grip(grip, abs(g_end[0] - grip[0]) / 0.4, yaw, sup, B.SUPPORT, DISMOUNT, grip_end=g_end)
        grip = g_end
    b.swing(grip, [0.7, 1.3, 1.9], yaw, B.SUPPORT, DISMOUNT, centre_angle=up, angle_fn=lambda th: support_shape(th, up, sup), radius=r_sh)
    b.truncate(int(0.1 * b.fps))
    _dismount_off_the_end(c, end_dir, up)
    c.land(0.0)
    c._phase = SKILL
    c.salute()
    c.walk_out(c.outside_point(-c.layout.judge_side, rng.uniform(1.5, 2.0)))
    c.pad_to_end(c.outside_point(-c.layout.judge_side, 4.0))
