"""A crowded routine: a group of gymnasts and coaches within arm's reach beside the apparatus.

Why: the multi-person pose stage (``gymtrack pose --all-tracks``) must lift people standing so
close that their boxes overlap in every view, the case where a top-down model's crop holds two
bodies and may give the other one's pose (:func:`.pose_view.choose_person`). A routine of
:func:`~.routine.simulate_routine` is built first (same seed: the same target, cameras, coaches,
judges and background, bit for bit); the group is added on its own random stream, so every
other routine stays byte-identical.

The group (``size`` people, 1.55-1.90 m): a cluster at the side of the performance space
opposite the judges, inside the tracking space (0.3 m from its edge), each person's floor point at least ``min_gap`` from the others' and at most
``reach`` from a neighbour (a standing adult's arm span reaches ~0.8 m to the side). Each stands
and gestures: every 1-3 s a new arm posture (shoulder flexion 0-120 deg, abduction 6-70 deg,
elbow 10-120 deg: pointing, arms crossed, hands on hips), a turn of the head and body, and now
and then a step of 0.2-0.4 m. The detector and the pose model are the simulator's own, unchanged.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..apparatus import get_apparatus
from . import body as B
from .detector import true_boxes
from .motion import WAIT, Motion, MotionBuilder
from .people import Crowd, Person
from .routine import SimulatedRoutine, _finish, _simulate_scene, check_args
from .venue import FPS
from ..formats.scene import preset_scene

CROWD_STREAM = 0xC0_0D  # spawn key of the group's random stream (the routine's own streams are untouched)


def _group_spots(rng: np.random.Generator, centre: np.ndarray, size: int, min_gap: float, reach: float,
                 area: np.ndarray) -> np.ndarray:
    """(size, 2) floor points inside ``area`` (x0, y0, x1, y1): each within ``reach`` of an earlier
    one and ``min_gap`` from all."""
    pts = [np.clip(np.asarray(centre, float), area[:2], area[2:])]
    for _ in range(10000):
        if len(pts) == size:
            break
        base = pts[int(rng.integers(len(pts)))]
        a = rng.uniform(-np.pi, np.pi)
        q = base + rng.uniform(min_gap, reach) * np.array([np.cos(a), np.sin(a)])
        if np.all((q >= area[:2]) & (q <= area[2:])) and np.linalg.norm(np.asarray(pts) - q, axis=1).min() >= min_gap:
            pts.append(q)
    return np.asarray(pts)


def _gesturing(crowd: Crowd, rng: np.random.Generator, body: B.BodyModel, xy: np.ndarray, look: np.ndarray) -> Motion:
    """Motion of one group member: standing at ``xy`` facing about ``look``, gesturing."""
    b = MotionBuilder(body, crowd.fps, rng)
    yaw0 = float(np.arctan2(look[1] - xy[1], look[0] - xy[0]))
    b.place(xy, 0.0, yaw0, B.STAND, WAIT)
    while b.n < crowd.n:
        a = B.posture_angles(B.STAND).copy()
        a[5], a[6] = rng.uniform(0, 120, 2)  # shoulder flexion, left and right
        a[7] = rng.uniform(6, 70)  # abduction
        a[8] = rng.uniform(10, 120)  # elbow
        a[9] = rng.uniform(-10, 25)  # head
        if rng.random() < 0.2:  # a short step within the group
            step = rng.uniform(0.2, 0.4) * np.array([np.cos(yaw0), np.sin(yaw0)]) * rng.choice([-1.0, 1.0])
            b.walk_to(np.asarray(b.centre[:2]) + step, 0.8, 0.0, WAIT)
        b.stand(rng.uniform(1.0, 3.0), 0.0, B.STAND, WAIT, yaw=yaw0 + rng.normal(0, 0.6), angles=a, sway=0.005)
    b.truncate(b.n - crowd.n)
    return b.build()


def simulate_crowd(apparatus: str, n_cam: int = 4, seed: int = 0, seconds: float | None = None, size: int = 6,
                   min_gap: float = 0.55, reach: float = 0.8) -> SimulatedRoutine:
    """:func:`~.routine.simulate_routine` plus a group of ``size`` people within arm's reach.

    The group members have role ``"gymnast"`` (or ``"coach"``, every third) and person ids after
    everyone else's; they are in every frame. Raises InputError as ``simulate_routine`` does.
    """
    apparatus, n_cam, seed, seconds = check_args(apparatus, n_cam, seed, seconds)
    sc = _simulate_scene(apparatus, seed, seconds)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(CROWD_STREAM,)))
    target = sc.people[0]
    app = get_apparatus(apparatus)
    crowd = Crowd(app, rng, FPS, sc.arrays["alive"].shape[1], sc.layout, sc.rig, target.motion, sc.events)
    crowd._next_id = int(max(p.pid for p in sc.people)) + 1
    # beside the performance space, on the side away from the judges, inside the tracking space
    space, track = np.asarray(app.performance_space, float), np.asarray(preset_scene(apparatus).tracking_space, float)
    side = -sc.layout.judge_side
    if app.along_axis:
        centre = np.array([target.motion.centre[:, 0].mean() + rng.uniform(-1.0, 1.0), (space[4] if side > 0 else space[1]) + side * 0.35])
    else:
        centre = np.array([(space[3] if side > 0 else space[0]) + side * 0.35, rng.uniform(-0.5, 0.5)])
    spots = _group_spots(rng, centre, size, min_gap, reach, track[[0, 1, 3, 4]] + np.array([0.3, 0.3, -0.3, -0.3]))
    look = np.asarray(target.motion.centre[:, :2].mean(axis=0))
    group = []
    for k, xy in enumerate(spots):
        body = B.BodyModel(rng.uniform(1.55, 1.9))
        group.append(Person(crowd._new_id(), "coach" if k % 3 == 2 else "gymnast", body, 0,
                            _gesturing(crowd, rng, body, xy, look)))
    people = sc.people + group
    a = dict(sc.arrays)
    T = a["alive"].shape[1]
    P, K = len(group), B.N_POINTS
    pts, cen, tb = np.full((P, T, K, 3), np.nan), np.full((P, T, 3), np.nan), np.full((P, T, 2), np.nan)
    post = np.full((P, T), -1, np.int8)
    for i, per in enumerate(group):
        m = per.motion
        pts[i], tb[i] = per.body.world_points(m.centre, m.angles, m.yaw, m.pitch, m.twist)
        cen[i], post[i] = m.centre, m.posture
    add = {"person_id": np.array([p.pid for p in group], np.int64), "role": np.array([p.role for p in group]),
           "height": np.array([p.body.height for p in group]), "alive": np.ones((P, T), bool), "centre": cen,
           "top_z": tb[..., 0], "bottom_z": tb[..., 1], "posture": post, "keypoints": pts[:, :, :17].astype(np.float64),
           "body_points": pts}
    for k, v in add.items():
        a[k] = np.concatenate([a[k], v])
    pads = np.array([p.body.pad for p in people])
    boxes = true_boxes(sc.rig, a["body_points"], pads, a["centre"], app)
    unusual_g = np.zeros((P, T))
    sc2 = dataclasses.replace(sc, people=people, arrays=a, tb=boxes, unusual=np.concatenate([sc.unusual, unusual_g]))
    return _finish(sc2, n_cam, None)

