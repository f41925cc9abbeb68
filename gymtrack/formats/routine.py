"""A routine folder: calibration + scene + one detection file per camera, checked together.

Paper: the inputs of the whole pipeline (Section III): synchronised multi-camera boxes
(III-A), the calibrated projection matrices (III-B) and the gymnastics domain knowledge
(performance space, vertical plane, identification heights; III-B to III-D). Layout
(``shared/formats.md``)::

    <routine>/
      cameras.yaml            (or any calibration gymtrack reads, see formats.calibration)
      scene.yaml
      detections/<camera>.txt one MOTChallenge file per camera, named after the camera
      keypoints/, videos/     optional
      gt/                     optional ground truth (persons_3d.csv, boxes_2d/, keypoints_3d.csv)

Real projects are read as they come: the calibration may be any file (``calibration=``, the CLI's
``--calibration FILE``) or a Pose2Sim project's ``Calib*.toml`` (:mod:`.pose2sim`); the 2D poses
any folder (``keypoints=``) or Pose2Sim's ``pose/``. A routine with 2D poses and no
``detections/`` gets its person boxes from the poses' joints (:mod:`.pose_boxes`), and says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..detections import Detections
from ..errors import RoutineError
from ..geometry.camera import Rig
from ..poses import Poses2D
from .calibration import CalibrationReport, find_calibration, read_calibration
from .keypoints import KeypointsReport, read_keypoints
from .motchallenge import ReadReport, read_detections
from .pose2sim import find_keypoints_folder, find_project_calibration
from .pose_boxes import PoseBoxes, boxes_from_poses
from .scene import Scene, load_scene

#: Ground-truth files the simulator writes under ``gt/`` (key -> relative path).
GT_FILES: dict[str, str] = {
    "persons_3d": "persons_3d.csv",
    "boxes_2d": "boxes_2d",
    "keypoints_3d": "keypoints_3d.csv",
}


@dataclass(frozen=True, eq=False)
class Routine:
    """A validated routine folder.

    Attributes
    ----------
    path: the folder.
    rig: the cameras, in calibration order (the camera index of every array).
    scene: the validated ``scene.yaml``.
    detections: boxes of all cameras, sorted by (frame, camera); ``camera`` indexes ``rig``.
    reports: one :class:`ReadReport` per camera, rig order.
    calibration_path: the calibration file or folder read.
    calibration_report: what reading the calibration left out or guessed.
    has_gt: the folder has a ``gt/`` sub-folder.
    gt: key of :data:`GT_FILES` -> path, for the ground-truth files present.
    ignored: files in ``detections/`` that are not ``.txt`` (listed, not read).
    shifted_out: boxes that scene.yaml's ``frame_offsets`` moved before frame 0 (left out, warned).
    keypoints_path: the 2D poses' folder (given, ``keypoints/`` or Pose2Sim's ``pose/``), None if none.
    poses: the 2D poses, when they were read to make boxes (no ``detections/``); else None.
    keypoints_report: what reading them found (camera mapping, skeleton), when read.
    pose_boxes: the boxes made from the poses, when there is no ``detections/``.
    """

    path: Path
    rig: Rig
    scene: Scene
    detections: Detections
    reports: tuple[ReadReport, ...]
    calibration_path: Path
    calibration_report: CalibrationReport
    has_gt: bool = False
    gt: dict[str, Path] = field(default_factory=dict)
    ignored: tuple[Path, ...] = ()
    shifted_out: int = 0
    keypoints_path: Path | None = None
    poses: Poses2D | None = None
    keypoints_report: KeypointsReport | None = None
    pose_boxes: PoseBoxes | None = None

    @property
    def camera_names(self) -> tuple[str, ...]:
        return self.rig.names

    def detection_path(self, camera: str) -> Path:
        return self.path / "detections" / f"{camera}.txt"

    def gap_warnings(self) -> list[str]:
        """One message per detection file whose longest pause between frames with boxes exceeds
        an hour at the scene's fps (:meth:`ReadReport.gap_warning`): a wrong frame number, likely."""
        return [w for r in self.reports if (w := r.gap_warning(self.scene.fps)) is not None]

    def gt_boxes_path(self, camera: str) -> Path | None:
        """``gt/boxes_2d/<camera>.txt`` when present."""
        p = self.path / "gt" / "boxes_2d" / f"{camera}.txt"
        return p if p.is_file() else None


def _calibration_path(path: Path, calibration: str | Path | None) -> Path:
    if calibration is not None:
        c = Path(calibration)
        if not c.exists():
            raise RoutineError("calibration not found (--calibration)", source=c)
        return c
    try:
        return find_calibration(path, error=RoutineError)
    except RoutineError as err:
        if "several" in err.problem:
            raise
        found = find_project_calibration(path)
        if found is None:
            raise RoutineError(err.problem + "; or a Pose2Sim calibration/Calib*.toml; or give --calibration FILE",
                               source=path) from None
        return found


def load_routine(path: str | Path, calibration_format: str | None = None, calibration: str | Path | None = None,
                 keypoints: str | Path | None = None, skeleton=None, **calibration_options) -> Routine:
    """Read and cross-check a routine folder.

    Parameters
    ----------
    path: the routine folder.
    calibration_format, calibration_options: passed to
        :func:`~gymtrack.formats.calibration.read_calibration` (e.g. ``units="mm"`` for a
        ``calibration.toml``).
    calibration: the calibration file (any name; default: found in the folder, or a Pose2Sim
        project's ``Calib*.toml``).
    keypoints: the 2D poses' folder (default ``keypoints/``, else ``pose/``).
    skeleton: the poses' skeleton when they are read here (no ``detections/``).

    Raises RoutineError (naming the file or camera and saying how to fix it) for: a missing
    folder, scene.yaml or calibration; no ``detections/`` and no 2D poses; a detection file whose
    camera the calibration lacks; a calibration camera with no detection file. Errors inside a
    file (calibration, scene, detections, keypoints) come as that file's own error type.
    """
    path = Path(path)
    if not path.is_dir():
        raise RoutineError("routine folder not found", source=path)
    scene_path = path / "scene.yaml"
    if not scene_path.is_file():
        raise RoutineError(
            "missing scene.yaml: write one with at least 'apparatus: <preset>' or 'performance_space' (see shared/formats.md)",
            source=scene_path,
        )
    calib_path = _calibration_path(path, calibration)
    rig, calib_report = read_calibration(calib_path, calibration_format, **calibration_options)
    scene = load_scene(scene_path)
    kp_path = Path(keypoints) if keypoints is not None else find_keypoints_folder(path)
    if keypoints is not None and not kp_path.exists():
        raise RoutineError("no 2D keypoints there (--keypoints): give the folder of the pose files", source=kp_path)

    gt_dir = path / "gt"
    gt = {k: gt_dir / rel for k, rel in GT_FILES.items() if (gt_dir / rel).exists()}
    common = dict(path=path, rig=rig, scene=scene, calibration_path=calib_path, calibration_report=calib_report,
                  has_gt=gt_dir.is_dir(), gt=gt, keypoints_path=kp_path)
    det_dir = path / "detections"
    if not det_dir.is_dir():
        if kp_path is None:
            raise RoutineError(
                f"missing detections/ folder: add one MOTChallenge file per camera ({', '.join(n + '.txt' for n in rig.names)}), "
                "or 2D poses (keypoints/ or pose/, or --keypoints DIR) to derive the boxes from",
                source=det_dir,
            )
        report = KeypointsReport()
        poses, shifted_out = apply_frame_offsets(read_keypoints(kp_path, rig.names, skeleton=skeleton, report=report),
                                                 scene.frame_offsets, rig.names, scene_path)
        made = boxes_from_poses(poses)
        return Routine(detections=made.detections, reports=made.reports(report.sources), poses=poses,
                       keypoints_report=report, pose_boxes=made, shifted_out=shifted_out, **common)
    files = sorted(p for p in det_dir.iterdir() if p.is_file())
    txt = {p.stem: p for p in files if p.suffix == ".txt"}
    ignored = tuple(p for p in files if p.suffix != ".txt")
    for stem, p in txt.items():
        if stem not in rig.names:
            raise RoutineError(
                f"detection file for camera {stem!r}, which the calibration ({calib_path.name}) does not have; "
                f"its cameras are {', '.join(rig.names)}: rename or remove the file",
                source=p,
            )
    missing = [n for n in rig.names if n not in txt]
    if missing:
        raise RoutineError(
            f"camera {missing[0]!r} of the calibration has no detection file detections/{missing[0]}.txt"
            + (f" (nor do {', '.join(missing[1:])})" if len(missing) > 1 else "")
            + "; if the camera saw nothing, add an empty file",
            source=det_dir, field=missing[0],
        )
    parts, reports = [], []
    for i, name in enumerate(rig.names):
        d, r = read_detections(txt[name], i, rig.names)
        parts.append(d)
        reports.append(r)
    detections, shifted_out = apply_frame_offsets(Detections.concat(parts), scene.frame_offsets, rig.names, scene_path)
    return Routine(detections=detections, reports=tuple(reports), ignored=ignored, shifted_out=shifted_out, **common)


def apply_frame_offsets(rows, offsets: dict[str, int], names: tuple[str, ...], source: Path | None = None):
    """``frame_offsets`` of scene.yaml applied to (N,) rows with ``frame`` and ``camera`` columns
    (:class:`Detections` or :class:`~gymtrack.poses.Poses2D`): a camera's frame ``f`` becomes
    ``f - offset``. Returns the shifted rows sorted by (frame, camera) and how many fell before
    frame 0 (left out, with a warning). An offset naming a camera the rig lacks is a RoutineError."""
    import dataclasses
    import warnings

    import numpy as np

    from ..errors import GymtrackWarning

    for cam in offsets:
        if cam not in names:
            raise RoutineError(f"frame_offsets names camera {cam!r}, which the calibration lacks "
                               f"(cameras: {', '.join(names)})", source=source, field=f"frame_offsets.{cam}")
    by_cam = np.array([offsets.get(n, 0) for n in names], dtype=np.int64)
    if not by_cam.any():
        return (rows.sorted() if isinstance(rows, Detections) else rows), 0
    frame = rows.frame - by_cam[rows.camera]
    keep = np.flatnonzero(frame >= 0)
    out = int(len(frame) - len(keep))
    if out:
        warnings.warn(f"frame_offsets moved {out} rows before frame 0; they are left out", GymtrackWarning, stacklevel=2)
    order = keep[np.lexsort((rows.camera[keep], frame[keep]))]
    if isinstance(rows, Detections):
        shifted = Detections(frame, rows.camera, rows.box, rows.score, rows.track_id, rows.camera_names)
        return shifted.select(order), out
    cols = {n: getattr(rows, n)[order] for n in ("camera", "track_id", "keypoints", "bbox")}
    return dataclasses.replace(rows, frame=frame[order], **cols), out

