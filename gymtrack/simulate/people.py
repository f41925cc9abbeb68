"""Everyone in the hall besides the target: coaches, judges, other gymnasts and spectators.

Paper: Section III-D. Coaches (assistants) may step into the performance space to protect or
lift the gymnast, so several 3D tracklets can be inside ``S_perf`` and the target must be told
apart by its height pattern (Eq. 13); the detector also sees judges and people in the
background in every view, which the cross-view association must not mix up with the target.

* coaches (1-2): stand just outside the performance space, walk in to lift the gymnast to the
  rings / bar, spot mounts, dismounts and some skills from inside it, then walk back;
* judges (2-4): seated at a table outside the performance space, facing the apparatus;
* spectators: seated on benches or standing further out; gymnasts and spectators walking
  through the hall in the background (they enter and leave, so they exist for part of the
  routine only).

Every person has the same body model as the target (:mod:`gymtrack.simulate.body`) in a
standing, walking or sitting posture, so their boxes are projections of their 3D extent too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..apparatus import Apparatus
from ..geometry.camera import Rig
from . import body as B
from .motion import DISMOUNT, LANDING, WAIT, WALK, Motion, MotionBuilder
from .skills import Event, Layout

ROLES = ("target", "coach", "judge", "gymnast", "spectator")


@dataclass
class Person:
    """One simulated person.

    pid: person id (the target is 1); role: one of :data:`ROLES`; body: its body model;
    start: first frame index (0-based) the person exists; motion: its motion, ``len(motion)``
    frames from ``start``.
    """

    pid: int
    role: str
    body: B.BodyModel
    start: int
    motion: Motion


def _grown(space, margin: float) -> np.ndarray:
    s = np.asarray(space, dtype=np.float64).copy()
    s[:2] -= margin
    s[3:5] += margin
    return s


def _in_rect(xy: np.ndarray, rect: np.ndarray) -> np.ndarray:
    xy = np.atleast_2d(xy)
    return (xy[:, 0] >= rect[0]) & (xy[:, 0] <= rect[3]) & (xy[:, 1] >= rect[1]) & (xy[:, 1] <= rect[4])


def _segment_clear(a, b, rect, cams_xy, cam_clear: float) -> bool:
    """Whether the floor segment a-b stays out of ``rect`` and ``cam_clear`` metres from every camera."""
    s = np.linspace(0.0, 1.0, 40)[:, None]
    p = np.asarray(a)[None] + s * (np.asarray(b) - np.asarray(a))[None]
    if _in_rect(p, rect).any():
        return False
    d = np.linalg.norm(p[:, None, :] - cams_xy[None], axis=-1)
    return bool(d.min() > cam_clear)


class Crowd:
    """Builds the other people of one routine around ``app``, given the target's motion."""

    def __init__(self, app: Apparatus, rng: np.random.Generator, fps: float, n_frames: int, layout: Layout,
                 rig: Rig, target: Motion, events: list[Event]):
        self.app, self.rng, self.fps, self.n = app, rng, fps, n_frames
        self.layout, self.rig, self.target, self.events = layout, rig, target, events
        self.cams_xy = rig.centres[:, :2]
        self.space = np.asarray(app.performance_space, dtype=np.float64)
        self.people: list[Person] = []
        self._next_id = 2

    def _new_id(self) -> int:
        pid = self._next_id
        self._next_id += 1
        return pid

    # ------------------------------------------------------------------ plans of standing points
    def _follow_plan(self, body: B.BodyModel, plan: list[tuple[int, int, np.ndarray, int, float | None]], start_xy,
                     speed: float, end: int) -> Motion:
        """Motion through a plan of ``(arrive, leave, xy, posture, yaw)`` stops: stand at each stop
        from ``arrive`` to ``leave`` (frames), walk between stops, stand at the last one until
        ``end``. Walking starts as late as the walking speed allows, so arrivals are on time."""
        b = MotionBuilder(body, self.fps, self.rng)
        start_xy = np.asarray(start_xy, float)
        first_yaw = plan[0][4] if plan and plan[0][4] is not None else self.rng.uniform(-np.pi, np.pi)
        b.place(start_xy, 0.0, first_yaw, B.STAND, WAIT)
        for arrive, leave, xy, posture, yaw in plan:
            xy = np.asarray(xy, float)
            d = float(np.linalg.norm(xy - b.centre[:2]))
            t_walk = d / speed + 0.5 if d > 0.05 else 0.0
            depart = max(b.n, arrive - int(round(t_walk * self.fps)))
            if depart > b.n:
                self._idle(b, (depart - b.n) / self.fps)
            if d > 0.05:
                b.walk_to(xy, speed, 0.0, WALK)
            hold = max(leave - b.n, 1)
            if posture == B.STAND:
                self._idle(b, hold / self.fps, yaw=yaw)
            else:
                a = B.posture_angles(posture)
                b.stand(min(0.6, hold / self.fps), 0.0, posture, WAIT, yaw=yaw, angles=a)
                if b.n < leave:
                    b.stand((leave - b.n) / self.fps, 0.0, posture, WAIT, yaw=yaw, angles=a)
                b.stand(0.5, 0.0, B.STAND, WAIT)
            if b.n >= end:
                break
        if b.n < end:
            self._idle(b, (end - b.n) / self.fps)
        if b.n > end:
            b.truncate(b.n - end)
        return b.build()

    def _idle(self, b: MotionBuilder, seconds: float, yaw: float | None = None, posture: int = B.STAND) -> None:
        """Stand around: small weight shifts, now and then a look elsewhere."""
        left = seconds
        first = True
        while left > 1e-6:
            chunk = min(left, self.rng.uniform(1.5, 4.0))
            y = yaw if (first and yaw is not None) else (b.yaw + self.rng.normal(0, 0.3) if yaw is None else yaw + self.rng.normal(0, 0.15))
            b.stand(chunk, 0.0, posture, WAIT, yaw=y, sway=0.01)
            left -= chunk
            first = False

    # ------------------------------------------------------------------ coaches
    def _home(self, side: float, k: int) -> np.ndarray:
        s = self.space
        if self.app.along_axis:
            x = np.clip(self.target.centre[:, 0].mean() + self.rng.uniform(-1.5, 1.5), s[0] + 0.5, s[3] - 0.5)
            if self.app.name == "vault":
                x = self.rng.uniform(-1.0, 3.0)
            return np.array([x, (s[4] if side > 0 else s[1]) + side * self.rng.uniform(0.4, 1.0)])
        y = self.rng.uniform(-1.0, 1.0)
        return np.array([(s[3] if side > 0 else s[0]) + side * self.rng.uniform(0.4, 1.0), y])

    def _free_spot_near(self, frames: slice, near: np.ndarray, dist: tuple[float, float]) -> np.ndarray:
        """A floor point ``dist`` metres from ``near`` that keeps 0.7 m from the target during ``frames``."""
        tc = self.target.centre[frames, :2]
        best, best_d = None, -1.0
        for _ in range(30):
            a = self.rng.uniform(-np.pi, np.pi)
            p = near + self.rng.uniform(*dist) * np.array([np.cos(a), np.sin(a)])
            p = np.clip(p, self.space[[0, 1]] - 0.5, self.space[[3, 4]] + 0.5)
            dmin = float(np.linalg.norm(tc - p, axis=1).min()) if len(tc) else 9.0
            if dmin > 0.7:
                return p
            if dmin > best_d:
                best, best_d = p, dmin
        return best

    def add_coaches(self) -> None:
        rng, fps = self.rng, self.fps
        n_coach = int(rng.integers(1, 3))
        sides = [-self.layout.judge_side, self.layout.judge_side]
        tm = self.target
        perf = np.flatnonzero(tm.performing)
        dis = np.flatnonzero(np.isin(tm.phase, (DISMOUNT, LANDING)))
        for k in range(n_coach):
            body = B.BodyModel(rng.uniform(1.65, 1.9))
            home = self._home(sides[k], k)
            stops: list[tuple[int, int, np.ndarray, int, float | None]] = []
            if k == 0:
                for ev in self.events:
                    if ev.kind == "lift":
                        off = np.array([0.45, 0.0]) if not self.app.along_axis else np.array([0.0, 0.45])
                        spot = np.asarray(ev.xy) + off * rng.choice([-1.0, 1.0])
                        stops.append((ev.start - int(0.3 * fps), ev.stop + int(rng.uniform(0.5, 1.5) * fps), spot, B.SALUTE,
                                      float(np.arctan2(ev.xy[1] - spot[1], ev.xy[0] - spot[0]))))
                    else:
                        spot = self._free_spot_near(slice(ev.start, ev.stop), np.asarray(ev.xy), (0.6, 1.0))
                        stops.append((ev.start, ev.stop + int(fps), spot, B.STAND, None))
                if dis.size:  # spot the dismount from near the landing
                    d0, d1 = int(dis[0]), int(dis[-1])
                    land = tm.centre[d1, :2]
                    spot = self._free_spot_near(slice(max(d0 - int(fps), 0), d1 + 1), land, (0.8, 1.4))
                    stops.append((d0 - int(0.5 * fps), d1 + int(rng.uniform(0.5, 1.5) * fps), spot, B.STAND, None))
            # random visits into the performance space (adjusting mats, spotting a skill)
            if perf.size:
                n_vis = rng.poisson(len(perf) / fps / 25.0)
                for _ in range(int(n_vis)):
                    f0 = int(rng.integers(perf[0], max(perf[-1] - int(3 * fps), perf[0] + 1)))
                    f1 = f0 + int(rng.uniform(2.0, 5.0) * fps)
                    spot = self._free_spot_near(slice(f0, f1), tm.centre[f0, :2], (1.0, 1.8))
                    stops.append((f0, f1, spot, B.STAND, None))
            stops.sort(key=lambda s: s[0])
            plan: list[tuple[int, int, np.ndarray, int, float | None]] = []
            last_leave = 0
            for arrive, leave, xy, post, yaw in stops:
                if arrive < last_leave + int(1.0 * fps):  # overlapping visits: merge into the earlier one
                    continue
                # go home in between if there is time
                if plan and arrive - last_leave > int(4.0 * fps):
                    mid = last_leave + int(1.5 * fps)
                    plan.append((mid, mid + int(1.0 * fps), home, B.STAND, None))
                plan.append((arrive, leave, xy, post, yaw))
                last_leave = leave
            plan.append((last_leave + int(2 * fps), self.n, home, B.STAND, None))
            motion = self._follow_plan(body, plan, home, rng.uniform(1.2, 1.6), self.n)
            self.people.append(Person(self._new_id(), "coach", body, 0, motion))

    # ------------------------------------------------------------------ judges
    def add_judges(self) -> None:
        rng = self.rng
        n_j = int(rng.integers(2, 5))
        J = np.asarray(self.layout.judges_xy, float)
        axis = np.array([1.0, 0.0]) if self.app.along_axis else np.array([0.0, 1.0])
        spacing = rng.uniform(1.0, 1.4)
        for k in range(n_j):
            body = B.BodyModel(rng.uniform(1.55, 1.85))
            xy = J + (k - (n_j - 1) / 2) * spacing * axis
            look = np.array([0.0, 0.0]) if self.app.name != "vault" else np.array([0.5, 0.0])
            yaw = float(np.arctan2(look[1] - xy[1], look[0] - xy[0]))
            b = MotionBuilder(body, self.fps, rng)
            sit = B.posture_angles(B.SIT)
            b.place(xy, 0.0, yaw, B.SIT, WAIT)
            b.angles = sit
            while b.n < self.n:
                a = sit.copy()
                a[9] = rng.uniform(-5, 30)  # look up at the gymnast / down at the score sheet
                a[8] = rng.uniform(50, 90)
                a[11] = rng.uniform(0, 20)
                b.stand(rng.uniform(1.0, 4.0), 0.0, B.SIT, WAIT, yaw=yaw + rng.normal(0, 0.15), angles=a, sway=0.0)
            b.truncate(b.n - self.n)
            self.people.append(Person(self._new_id(), "judge", body, 0, b.build()))

    # ------------------------------------------------------------------ background
    def _arena(self) -> np.ndarray:
        """Where the background people move: around the performance space (for the vault only its
        table end: the far end of the 25 m runway is out of most views)."""
        margin = 4.5 if self.app.name != "vault" else 3.5
        arena = _grown(self.space, margin)
        if self.app.name == "vault":
            arena[0] = max(arena[0], -12.0)
        return arena

    def _free_point(self, arena: np.ndarray, keep_out: np.ndarray) -> np.ndarray:
        for _ in range(200):
            p = self.rng.uniform(arena[[0, 1]], arena[[3, 4]])
            if not _in_rect(p, keep_out)[0] and np.linalg.norm(self.cams_xy - p, axis=1).min() > 2.5:
                return p
        return p

    def _edge_point(self, arena: np.ndarray) -> np.ndarray:
        """Where walkers enter and leave the hall: a floor point out of every camera's view (people
        do not pop up in the middle of an image), on a rectangle well outside the arena."""
        hall = _grown(arena, 7.0)
        x0, y0, x1, y1 = hall[0], hall[1], hall[3], hall[4]
        for _ in range(60):
            side = self.rng.integers(0, 4)
            u = self.rng.random()
            p = np.array([[x0 + u * (x1 - x0), y0], [x0 + u * (x1 - x0), y1], [x0, y0 + u * (y1 - y0)], [x1, y0 + u * (y1 - y0)]][side])
            body = np.array([[p[0], p[1], 0.0], [p[0], p[1], 1.8]])
            seen = any(np.any((cam.depth(body) > 0) & cam.in_image(cam.project(body), margin=100.0)) for cam in self.rig)
            if not seen and np.linalg.norm(self.cams_xy - p, axis=1).min() > 2.0:
                return p
        return p

    def add_spectators(self) -> None:
        """Seated and standing spectators at the edge of the hall, present all along."""
        rng = self.rng
        arena = self._arena()
        keep_out = _grown(self.space, 0.8)
        n_s = int(rng.integers(2, 6))
        edge = int(rng.integers(0, 4))  # the bench runs along one edge of the hall
        u0 = rng.uniform(0.25, 0.75)
        for k in range(n_s):
            body = B.BodyModel(rng.uniform(1.5, 1.9))
            seated = rng.random() < 0.6
            if seated:
                u = u0 + (k - n_s / 2) * 0.75 / max(arena[3] - arena[0], arena[4] - arena[1])
                x0, y0, x1, y1 = arena[0] + 0.3, arena[1] + 0.3, arena[3] - 0.3, arena[4] - 0.3
                xy = np.array([[x0 + u * (x1 - x0), y0], [x0 + u * (x1 - x0), y1], [x0, y0 + u * (y1 - y0)], [x1, y0 + u * (y1 - y0)]][edge])
            else:
                xy = self._free_point(arena, keep_out)
            if np.linalg.norm(self.cams_xy - xy, axis=1).min() < 2.5:
                xy = self._free_point(arena, keep_out)
            yaw = float(np.arctan2(-xy[1], -xy[0]))
            b = MotionBuilder(body, self.fps, rng)
            post = B.SIT if seated else B.STAND
            b.place(xy, 0.0, yaw, post, WAIT)
            while b.n < self.n:
                b.stand(rng.uniform(2.0, 5.0), 0.0, post, WAIT, yaw=yaw + rng.normal(0, 0.3), sway=0.0 if seated else 0.01)
            b.truncate(b.n - self.n)
            self.people.append(Person(self._new_id(), "spectator", body, 0, b.build()))

    def add_walkers(self, slots: int) -> None:
        """``slots`` lanes of background people: each enters at the arena edge, walks to one to
        three points (standing a while at some), leaves; then the next one comes."""
        rng, fps = self.rng, self.fps
        arena = self._arena()
        keep_out = _grown(self.space, 0.5)
        for _ in range(slots):
            f = int(rng.uniform(-20.0, 5.0) * fps)  # some are already inside when the routine starts
            while f < self.n:
                body = B.BodyModel(rng.uniform(1.45, 1.9))
                role = "gymnast" if rng.random() < 0.6 else "spectator"
                pts = [self._edge_point(arena)]
                for _k in range(int(rng.integers(1, 4))):
                    for _try in range(20):
                        q = self._free_point(arena, keep_out)
                        if _segment_clear(pts[-1], q, keep_out, self.cams_xy, 1.5):
                            break
                    pts.append(q)
                for _try in range(20):
                    e = self._edge_point(arena)
                    if _segment_clear(pts[-1], e, keep_out, self.cams_xy, 1.5):
                        break
                pts.append(e)
                speed = rng.uniform(0.9, 1.5)
                b = MotionBuilder(body, fps, rng)
                b.place(pts[0], 0.0, float(np.arctan2(*(pts[1] - pts[0])[::-1])), B.STAND, WALK)
                for q in pts[1:-1]:
                    b.walk_to(q, speed, 0.0, WALK)
                    if rng.random() < 0.5:
                        self._idle(b, rng.uniform(2.0, 10.0))
                b.walk_to(pts[-1], speed, 0.0, WALK)
                m = b.build()
                lo, hi = max(0, -f), min(len(m), self.n - f)
                if hi > lo:
                    self.people.append(Person(self._new_id(), role, body, f + lo, m.slice(lo, hi)))
                f += len(m) + int(rng.uniform(1.0, 8.0) * fps)


def judges_layout(app: Apparatus, rng: np.random.Generator) -> Layout:
    """Where the judges' table stands: outside the performance space, on one side of the plane."""
    s = np.asarray(app.performance_space)
    side = float(rng.choice([-1.0, 1.0]))
    gap = rng.uniform(2.0, 3.2)
    if app.name == "vault":
        xy = np.array([rng.uniform(0.0, 3.0), (s[4] + gap) * side])
    elif app.along_axis:
        xy = np.array([rng.uniform(-1.5, 1.5), (s[4] if side > 0 else -s[1]) * side + gap * side])
    else:
        xy = np.array([(s[3] if side > 0 else -s[0]) * side + gap * side, rng.uniform(-1.5, 1.5)])
    return Layout(judges_xy=xy, judge_side=side)

