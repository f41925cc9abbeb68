"""Simulating a whole routine: orchestration, the in-memory result, and writing the folder.

Paper: Section IV-A. The paper's dataset (seven apparatus, 20 routines each, evaluated with
``n_cam`` = 2, 3 and 4 valid views) is private; this module makes routines of the same kind
with ground truth, in the routine-folder layout of ``shared/formats.md``.

Order of work for one routine (each step has its own random stream spawned from the seed, so a
seed gives the same files bit for bit, and ``n_cam = 2, 3, 4`` of one seed are the same
performance seen with fewer views):

1. layout (judges' table), 2. the target's routine (:mod:`.skills`), 3. the cameras, aimed so
that the target's performance fits every view (:mod:`.venue`), 4. coaches, judges and the
background crowd (:mod:`.people`), 5. true boxes and the detector (:mod:`.detector`). Suites of
routines are :mod:`.suite`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from ..apparatus import APPARATUS_NAMES, Apparatus, get_apparatus
from ..detections import Detections
from ..errors import InputError
from ..formats.scene import preset_scene, save_scene
from ..scene import Scene
from ..geometry.camera import Rig
from . import body as B
from .detector import DetectorParams, TrueBoxes, detect, true_boxes
from .elements import ground_truth_elements
from .lengths import MAX_SECONDS, MIN_SECONDS, check_seconds  # noqa: F401  (MIN/MAX: re-exported)
from .motion import PERFORMING, PHASE_NAMES
from .people import Crowd, Person, judges_layout
from .skills import Event, Layout, target_routine
from .venue import FPS, make_rig

#: Default routine length in seconds (a vault is short by nature).
DEFAULT_SECONDS = {name: (20.0 if name == "vault" else 60.0) for name in APPARATUS_NAMES}
TARGET_ID = 1
#: Background walking lanes (people entering and leaving), per apparatus.
WALKER_SLOTS = (3, 7)


@dataclass(eq=False)
class SimulatedRoutine:
    """One simulated routine, in memory.

    Arrays are indexed ``[camera, person, frame]`` (C, P, T) or ``[person, frame]`` (P, T); the
    target is person row 0 with id :data:`TARGET_ID`. Frame numbers (``frames``) are 1-based,
    as written to the files.

    Attributes
    ----------
    apparatus, n_cam, seed, seconds, fps: what was simulated.
    rig: the four cameras (cam0/cam1 the square-on opposite pair); scene: the preset scene.
    frames: (T,) int64 frame numbers 1..T.
    person_id: (P,) int64; role: (P,) str; height: (P,) metres.
    alive: (P, T) bool, the person exists at that frame.
    centre: (P, T, 3) body centre (centre of the padded 3D body box), NaN where not alive.
    top_z, bottom_z: (P, T) top and bottom of the body, NaN where not alive.
    posture: (P, T) int8 posture label (:data:`gymtrack.simulate.body.POSTURE_NAMES`), -1 absent.
    keypoints: (P, T, 17, 3) COCO-17 joints, NaN where not alive.
    true_boxes: projections into every view (:class:`~gymtrack.simulate.detector.TrueBoxes`).
    detections: the detector's boxes (``track_id`` -1), frames 1-based.
    det_person: (N,) int64 person id each detection came from, -1 for false positives.
    target_views: (C,) bool, the views allowed to detect the target (``n_cam``).
    phase, flight: (T,) the target's phase label (:data:`gymtrack.simulate.motion.PHASE_NAMES`)
        and ballistic-flight flag.
    drift: (T,) the target's added off-plane drift, metres.
    body_points: (P, T, 26, 3) every body point (:data:`~.body.POINT_NAMES`), NaN where not alive.
    elements: the target's elements as the choreography made them (:mod:`.elements`, ``gt/elements.json``).
    """

    apparatus: str
    n_cam: int
    seed: int
    seconds: float
    fps: float
    rig: Rig
    scene: Scene
    frames: np.ndarray
    person_id: np.ndarray
    role: np.ndarray
    height: np.ndarray
    alive: np.ndarray
    centre: np.ndarray
    top_z: np.ndarray
    bottom_z: np.ndarray
    posture: np.ndarray
    keypoints: np.ndarray
    true_boxes: TrueBoxes
    detections: Detections
    det_person: np.ndarray
    target_views: np.ndarray
    phase: np.ndarray
    flight: np.ndarray
    drift: np.ndarray
    events: list[Event] = field(default_factory=list)
    layout: Layout | None = None
    rig_info: dict = field(default_factory=dict)
    dropped_at_border: int = 0
    body_points: np.ndarray | None = None
    elements: dict | None = None

    # ------------------------------------------------------------------ target
    target_id: int = TARGET_ID

    @property
    def app(self) -> Apparatus:
        return get_apparatus(self.apparatus)

    @property
    def n_frames(self) -> int:
        return int(self.frames.size)

    @property
    def target_centre(self) -> np.ndarray:
        """(T, 3) the target's centre."""
        return self.centre[0]

    @property
    def performing(self) -> np.ndarray:
        """(T,) bool, the target is performing (mount to landing)."""
        return np.isin(self.phase, PERFORMING)

    @property
    def gt_box(self) -> np.ndarray:
        """(C, P, T, 4) true boxes, centre form."""
        return self.true_boxes.xywh

    @property
    def gt_visible(self) -> np.ndarray:
        """(C, P, T) the ground-truth ``visible`` flag."""
        return self.true_boxes.visible

    def target_detected(self) -> np.ndarray:
        """(T, C) bool: the detector found the target in that view at that frame."""
        out = np.zeros((self.n_frames, len(self.rig)), bool)
        m = self.det_person == self.target_id
        out[self.detections.frame[m] - 1, self.detections.camera[m].astype(np.int64)] = True
        return out

    def ground_truth(self):
        """The ground truth as :class:`gymtrack.formats.ground_truth.GroundTruth` (what ``gt/`` holds)."""
        from ..formats.ground_truth import GroundTruth

        pi, ti = np.nonzero(self.alive)
        order = np.lexsort((self.person_id[pi], ti))
        pi, ti = pi[order], ti[order]
        c, bp, bt = self._box_rows()
        return GroundTruth(
            camera_names=self.rig.names,
            frame=self.frames[ti], person_id=self.person_id[pi], role=self.role[pi], xyz=self.centre[pi, ti],
            top_z=self.top_z[pi, ti], bottom_z=self.bottom_z[pi, ti], phase=(pi == 0) & self.performing[ti],
            box_frame=self.frames[bt], box_camera=c.astype(np.int16), box_person=self.person_id[bp],
            box=self.gt_box[c, bp, bt], box_visible=self.gt_visible[c, bp, bt],
            image_size=np.array([cam.size for cam in self.rig]),
        )

    def _box_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(camera, person row, frame index) of every true box written to ``gt/boxes_2d``: the
        person exists, is in front of the camera and the box overlaps the image."""
        tb = self.true_boxes
        ok = np.isfinite(tb.depth) & (tb.inside > 0) & self.alive[None]
        c, p, t = np.nonzero(ok)
        order = np.lexsort((self.person_id[p], t, c))
        return c[order], p[order], t[order]

    def __repr__(self) -> str:
        return (f"SimulatedRoutine({self.apparatus!r}, n_cam={self.n_cam}, seed={self.seed}, {self.n_frames} frames, "
                f"{self.person_id.size} persons, {len(self.detections)} detections)")

    def summary(self) -> dict:
        """Counts a person (or suite.json) wants to see."""
        det = self.target_detected()[self.performing]
        hist = np.bincount(det.sum(axis=1), minlength=len(self.rig) + 1) / max(len(det), 1)
        return {
            "apparatus": self.apparatus,
            "n_cam": self.n_cam,
            "seed": self.seed,
            "seconds": self.seconds,
            "frames": self.n_frames,
            "persons": int(self.person_id.size),
            "detections": self.detections.counts_per_camera(),
            "false_positives": int(np.count_nonzero(self.det_person < 0)),
            "dropped_at_border": self.dropped_at_border,
            "target_views": [n for n, v in zip(self.rig.names, self.target_views) if v],
            "target_views_detected_fraction": {str(k): round(float(v), 4) for k, v in enumerate(hist)},
        }

    # ------------------------------------------------------------------ writing
    def write(self, out: str | Path, plot: bool = False) -> Path:
        """Write the routine folder (``shared/formats.md``) to ``out``; returns the folder.

        ``cameras.yaml``, ``scene.yaml``, ``detections/<camera>.txt`` (ids -1), and ``gt/``:
        ``persons_3d.csv`` (every person every frame they exist; a 9th column ``phase`` is 1 on
        the target's performing frames), ``boxes_2d/<camera>.txt`` (true boxes overlapping the
        image, visible 0/1), ``keypoints_3d.csv`` (COCO-17 joints of every person, mm) and
        ``simulation.json`` (what was simulated), ``elements.json`` (the target's elements as the
        choreography made them). ``plot``: also ``plot_top.png`` and
        ``plot_side.png`` (needs matplotlib).
        """
        from ..formats.calibration import write_native
        from ..formats.motchallenge import write_mot, write_mot_gt

        out = Path(out)
        (out / "detections").mkdir(parents=True, exist_ok=True)
        (out / "gt" / "boxes_2d").mkdir(parents=True, exist_ok=True)
        write_native(self.rig, out / "cameras.yaml")
        save_scene(self.scene, out / "scene.yaml")
        d = self.detections
        for c, name in enumerate(self.rig.names):
            m = d.camera == c
            write_mot(out / "detections" / f"{name}.txt", d.frame[m], d.track_id[m], d.box[m], conf=d.score[m])
        c, p, t = self._box_rows()
        for ci, name in enumerate(self.rig.names):
            m = c == ci
            write_mot_gt(out / "gt" / "boxes_2d" / f"{name}.txt", self.frames[t[m]], self.person_id[p[m]],
                         self.gt_box[ci, p[m], t[m]], self.gt_visible[ci, p[m], t[m]])
        self._write_persons(out / "gt" / "persons_3d.csv")
        self._write_keypoints(out / "gt" / "keypoints_3d.csv")
        meta = {
            **self.summary(),
            "target_id": self.target_id,
            "fps": self.fps,
            "cameras": self.rig_info,
            "judges_xy": None if self.layout is None else [round(float(v), 4) for v in self.layout.judges_xy],
            "persons_by_role": {r: [int(i) for i in self.person_id[self.role == r]] for r in ("target", "coach", "judge", "gymnast", "spectator")},
            "heights_m": {int(i): round(float(h), 4) for i, h in zip(self.person_id, self.height)},
            "events": [{"kind": e.kind, "first_frame": int(e.start) + 1, "last_frame": int(e.stop)} for e in self.events],
            "phase_names": list(PHASE_NAMES),
            "keypoints_3d": "every person, frames where alive",
        }
        (out / "gt" / "simulation.json").write_text(json.dumps(meta, indent=1) + "\n")
        if self.elements is not None:
            from ..formats.elements import write_elements

            write_elements(out / "gt" / "elements.json", self.elements)
        if plot:
            from .plot import plot_routine

            plot_routine(self, out)
        return out

    def _write_persons(self, path: Path) -> None:
        pi, ti = np.nonzero(self.alive)
        order = np.lexsort((self.person_id[pi], ti))
        pi, ti = pi[order], ti[order]
        xyz = self.centre[pi, ti]
        phase = ((pi == 0) & self.performing[ti]).astype(np.int64)
        rows = np.empty((pi.size, 9), dtype=object)
        rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3:6] = self.frames[ti], self.person_id[pi], self.role[pi], xyz
        rows[:, 6], rows[:, 7], rows[:, 8] = self.top_z[pi, ti], self.bottom_z[pi, ti], phase
        with open(path, "w") as fh:
            fh.write("frame,person_id,role,x,y,z,top_z,bottom_z,phase\n")
            np.savetxt(fh, rows, fmt="%d,%d,%s,%.4f,%.4f,%.4f,%.4f,%.4f,%d")

    def _write_keypoints(self, path: Path) -> None:
        # every person (a crop may hold anyone) where alive, to the mm: a 25 s routine ~7 MB
        pi, ti = np.nonzero(self.alive)
        order = np.lexsort((self.person_id[pi], ti))
        pi, ti = np.repeat(pi[order], 17), np.repeat(ti[order], 17)
        ji = np.tile(np.arange(17), pi.size // 17)
        rows = np.empty((ti.size, 6), dtype=object)
        rows[:, 0], rows[:, 1] = self.frames[ti], self.person_id[pi]
        rows[:, 2], rows[:, 3:6] = np.asarray(B.COCO_JOINTS, dtype=object)[ji], self.keypoints[pi, ti, ji]
        with open(path, "w") as fh:
            fh.write("frame,person_id,joint,x,y,z\n")
            np.savetxt(fh, rows, fmt="%d,%d,%s,%.3f,%.3f,%.3f")


# ====================================================================== simulation
@dataclass
class _Scene:
    """Everything of a routine except the detector's output (shared by n_cam = 2, 3, 4)."""

    apparatus: str
    seed: int
    seconds: float
    rig: Rig
    rig_info: dict
    layout: Layout
    people: list[Person]
    events: list[Event]
    arrays: dict
    tb: TrueBoxes
    unusual: np.ndarray
    blind: int
    det_seed: np.random.SeedSequence


def check_args(apparatus: str, n_cam: int | None, seed, seconds) -> tuple[str, int | None, int, float]:
    """Validated ``(apparatus, n_cam, seed, seconds)``; InputError naming the argument otherwise."""
    if apparatus not in APPARATUS_NAMES:
        raise InputError(f"unknown apparatus {apparatus!r}; choose one of {', '.join(APPARATUS_NAMES)}", field="apparatus")
    if n_cam is not None and n_cam not in (2, 3, 4):
        raise InputError(f"n_cam must be 2, 3 or 4 (views that can detect the target), got {n_cam!r}", field="n_cam")
    try:
        seed = int(seed)
    except (TypeError, ValueError):
        raise InputError(f"seed must be a whole number, got {seed!r}", field="seed") from None
    if seed < 0:
        raise InputError(f"seed must be >= 0, got {seed}", field="seed")
    seconds = check_seconds(apparatus, DEFAULT_SECONDS[apparatus] if seconds is None else float(seconds))
    return apparatus, n_cam, seed, seconds


def _simulate_scene(apparatus: str, seed: int, seconds: float) -> _Scene:
    app = get_apparatus(apparatus)
    fps = FPS
    T = int(round(seconds * fps))
    ss = np.random.SeedSequence(seed)
    s_layout, s_target, s_venue, s_people, s_det, s_ncam = ss.spawn(6)
    layout = judges_layout(app, np.random.default_rng(s_layout))

    # The target.
    rng_t = np.random.default_rng(s_target)
    body = B.BodyModel(rng_t.uniform(1.45, 1.75))
    motion, events, drift, records = target_routine(app, seconds, fps, rng_t, body, layout)
    target = Person(TARGET_ID, "target", body, 0, motion)

    # Cameras aimed at the target's performance (for the vault, the table end of the runway).
    pts, _ = body.world_points(motion.centre, motion.angles, motion.yaw, motion.pitch, motion.twist)
    perf = pts[motion.performing][::3].reshape(-1, 3)
    if apparatus == "vault":
        perf = perf[perf[:, 0] > -6.0]
    rig, rig_info = make_rig(app, np.random.default_rng(s_venue), perf)

    # Everybody else.
    rng_p = np.random.default_rng(s_people)
    crowd = Crowd(app, rng_p, fps, T, layout, rig, motion, events)
    crowd.add_coaches()
    crowd.add_judges()
    crowd.add_spectators()
    crowd.add_walkers(int(rng_p.integers(WALKER_SLOTS[0], WALKER_SLOTS[1] + 1)))
    people = [target] + crowd.people

    # Per-frame arrays of everyone.
    P, K = len(people), B.N_POINTS
    points = np.full((P, T, K, 3), np.nan)
    centre = np.full((P, T, 3), np.nan)
    topbot = np.full((P, T, 2), np.nan)
    posture = np.full((P, T), -1, np.int8)
    inverted = np.zeros((P, T))
    alive = np.zeros((P, T), bool)
    pads = np.zeros((P, K))
    for i, per in enumerate(people):
        m = per.motion
        sl = slice(per.start, per.start + len(m))
        pt, tb_ = per.body.world_points(m.centre, m.angles, m.yaw, m.pitch, m.twist)
        points[i, sl], centre[i, sl], topbot[i, sl] = pt, m.centre, tb_
        posture[i, sl] = m.posture
        inverted[i, sl] = (1 - B.body_axis(m.yaw, m.pitch)[:, 2]) / 2
        alive[i, sl] = True
        pads[i] = per.body.pad
    tb = true_boxes(rig, points, pads, centre, app)
    unusual = np.where(posture >= 0, B.UNUSUAL[np.clip(posture, 0, None)], 0.0)
    unusual = np.clip(unusual + 0.6 * inverted, 0.0, 1.0)
    blind = int(np.random.default_rng(s_ncam).integers(0, 4))
    arrays = {
        "person_id": np.array([p.pid for p in people], np.int64),
        "role": np.array([p.role for p in people]),
        "height": np.array([p.body.height for p in people]),
        "alive": alive, "centre": centre, "top_z": topbot[..., 0], "bottom_z": topbot[..., 1], "posture": posture,
        "keypoints": points[:, :, :17].astype(np.float64),
        "phase": motion.phase, "flight": motion.flight,
        "drift": drift, "body_points": points,
        "elements": ground_truth_elements(records, motion.yaw, motion.pitch, motion.twist, points[0, :, :17], app, fps, TARGET_ID),
    }
    return _Scene(apparatus, seed, seconds, rig, rig_info, layout, people, events, arrays, tb, unusual, blind, s_det)


def _target_views(n_cam: int, blind: int) -> np.ndarray:
    v = np.ones(4, bool)
    if n_cam == 3:
        v[blind] = False
    elif n_cam == 2:
        v[2:] = False
    return v


def _finish(sc: _Scene, n_cam: int, params: DetectorParams | None) -> SimulatedRoutine:
    a = sc.arrays
    views = _target_views(n_cam, sc.blind)
    # the detector's random stream is the same for every n_cam (a copy of one seed sequence)
    rng = np.random.default_rng(np.random.SeedSequence(sc.det_seed.entropy, spawn_key=sc.det_seed.spawn_key))
    out = detect(sc.rig, sc.tb, sc.unusual, 0, views, FPS, rng, params or DetectorParams())
    T = a["alive"].shape[1]
    dets = Detections.from_arrays(out.frame_index + 1, out.camera, out.box, sc.rig.names, score=out.score)
    det_person = np.where(out.person >= 0, a["person_id"][np.clip(out.person, 0, None)], -1)
    return SimulatedRoutine(
        apparatus=sc.apparatus, n_cam=n_cam, seed=sc.seed, seconds=sc.seconds, fps=FPS, rig=sc.rig,
        scene=preset_scene(sc.apparatus, fps=FPS),
        frames=np.arange(1, T + 1, dtype=np.int64),
        person_id=a["person_id"], role=a["role"], height=a["height"], alive=a["alive"], centre=a["centre"],
        top_z=a["top_z"], bottom_z=a["bottom_z"], posture=a["posture"], keypoints=a["keypoints"], true_boxes=sc.tb,
        detections=dets, det_person=det_person.astype(np.int64), target_views=views, phase=a["phase"], flight=a["flight"],
        drift=a["drift"], events=sc.events, layout=sc.layout, rig_info=sc.rig_info, dropped_at_border=out.dropped_at_border,
        body_points=a["body_points"], elements=a["elements"],
    )


def simulate_routine(apparatus: str, n_cam: int = 4, seed: int = 0, seconds: float | None = None, out: str | Path | None = None,
                     plot: bool = False, detector: DetectorParams | None = None) -> SimulatedRoutine:
    """Simulate one routine with ground truth.

    Parameters
    ----------
    apparatus: one of :data:`gymtrack.apparatus.APPARATUS_NAMES`.
    n_cam: views that can detect the target: 4 all, 3 one view blind to it, 2 only the
        opposite pair cam0/cam1 (other people are detected in every view).
    seed: the routine's seed; the same seed gives the same routine bit for bit, and the same
        performance for every ``n_cam``.
    seconds: length; default :data:`DEFAULT_SECONDS` (60 s, vault 20 s); from what the apparatus's
        routine needs (:mod:`.lengths`; a vault: 5 s, one vault) to an hour. Every
        apparatus fits walking in, mount, skills, dismount and landing into 20 s; shorter
        routines (uneven bars under ~20 s, rings and horizontal bar under ~15 s) end before the
        dismount.
    out: if given, the routine folder is written there (:meth:`SimulatedRoutine.write`).
    plot: with ``out``, also write a top view and a side view PNG.
    detector: detector model parameters (default :class:`DetectorParams`).

    Raises InputError for an unknown apparatus, an ``n_cam`` other than 2-4, a negative seed or a
    length out of range.
    """
    apparatus, n_cam, seed, seconds = check_args(apparatus, n_cam, seed, seconds)
    sim = _finish(_simulate_scene(apparatus, seed, seconds), n_cam, detector)
    if out is not None:
        sim.write(out, plot=plot)
    return sim


def simulate_n_cams(apparatus: str, seed: int = 0, seconds: float | None = None, n_cams: Sequence[int] = (2, 3, 4),
                    detector: DetectorParams | None = None) -> dict[int, SimulatedRoutine]:
    """One performance seen with several ``n_cam`` settings: ``{n_cam: SimulatedRoutine}``.

    The same as calling :func:`simulate_routine` once per ``n_cam`` with the same seed (bit for
    bit), but the scene (motion, cameras, people, true boxes) is built only once.
    """
    apparatus, _, seed, seconds = check_args(apparatus, None, seed, seconds)
    for n in n_cams:
        check_args(apparatus, n, seed, seconds)
    sc = _simulate_scene(apparatus, seed, seconds)
    return {int(n): _finish(sc, int(n), detector) for n in n_cams}
