"""The 3D viewer: a Rerun recording (``.rrd``) of a routine and the tracker's outputs on it.

Paper: Section III as a whole, in one picture: the calibrated cameras (III-B, ``P_c = K_c [R_c |
t_c]``), the performance space ``S_perf`` and the apparatus plane (III-B, III-C), every 3D track
with the way its position was found (triangulation, plane, interpolated; III-B/C), the target
(III-D) and its 3D skeleton, and per view the detections, the tracks' boxes, ``b_buf`` and the 2D
keypoints. Ground truth, when the routine has ``gt/``, is its own entity (``world/gt``).

Entities (world z up, timeline ``frame`` = the files' frame numbers)::

    world                          view coordinates (right hand, z up)
    world/performance_space        Boxes3D;  world/apparatus_plane  LineStrips3D + Mesh3D
    world/apparatus                bars (LineStrips3D) and blocks (Boxes3D) of a preset apparatus
    world/cameras/<cam>            Transform3D: world to camera (R, t as in cameras.yaml)
    world/cameras/<cam>/image      Pinhole (K, size); children: detections, tracks, b_buf,
                                   keypoints, skeleton (2D), gt_boxes, video (when the sizes match)
    world/cameras/<cam>/video      a second Pinhole at the video's size, for a scaled video
    world/tracks                   Points3D (N, 3) per frame, coloured by id, labelled "id source"
    world/track_paths              LineStrips3D, one strip per track id
    world/target, world/target/skeleton, world/poses   the target, its 3D pose; other tracks' poses
    world/gt/persons, world/gt/skeleton                ground truth
    world/target/flights           LineStrips3D: the target's path in each flight, labelled with its counts
    analysis/elements              TextLog: each element's start ("flight 1: 1 salto, 0.5 twist, tuck, ...") and end
    analysis/now                   TextDocument per frame: the elements going on, the hold timer
    analysis/com_z, analysis/somersault, analysis/twist   Scalars of angles.csv (plots on the timeline)

The ``analysis/`` entities and the flights appear where ``gymtrack analyse`` wrote ``<out>/analysis/``.

Rerun (``rerun-sdk``) is the optional ``view`` extra, imported lazily. :func:`read_recording`
reads a recording back with Rerun's own reader (``rerun.chunk.RrdReader``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..errors import InputError
from .element_marks import element_events, kind_bgr
from .overlay import B_BUF, DETECTION, id_colours, load_overlay_inputs, replace_when_done

TARGET = (230, 30, 30)  # RGB
GT = (40, 200, 80)


def import_rerun():
    """The ``rerun`` module, or an InputError naming the extra to install."""
    try:
        import rerun as rr
    except ImportError:  # pragma: no cover - the extra is installed in CI
        raise InputError("gymtrack view needs the 'view' extra: pip install 'gymtrack[view]'") from None
    return rr


def _rgb(ids: np.ndarray) -> np.ndarray:
    return id_colours(ids)[:, ::-1]


def _bgr2rgb(c) -> list[int]:
    return list(c[::-1])


def _send(rec, rr, entity: str, frame: np.ndarray, archetype, **cols) -> None:
    """Log rows grouped by frame with one ``send_columns`` (rows need not be sorted)."""
    frame = np.asarray(frame, dtype=np.int64)
    if not frame.size:
        return
    order = np.argsort(frame, kind="stable")
    frames, counts = np.unique(frame[order], return_counts=True)
    sorted_cols = {k: (v[order] if isinstance(v, np.ndarray) else [v[i] for i in order]) for k, v in cols.items()}
    rec.send_columns(entity, indexes=[rr.TimeColumn("frame", sequence=frames)],
                     columns=archetype.columns(**sorted_cols).partition(counts))


def _bone_strips(xyz: np.ndarray, bones: np.ndarray, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, J, D) joints, (B, 2) bones, (n, J) found -> (S, 2, D) segments and (S,) pose row of each."""
    a, b = bones[:, 0], bones[:, 1]
    good = ok[:, a] & ok[:, b]  # (n, B)
    row, k = np.nonzero(good)
    return np.stack([xyz[row, a[k]], xyz[row, b[k]]], 1), row


def _log_static_scene(rec, rr, scene) -> None:
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    s = np.asarray(scene.performance_space, float)
    rec.log("world/performance_space", rr.Boxes3D(mins=[s[:3]], sizes=[s[3:] - s[:3]], colors=[(255, 200, 0)],
                                                  labels=["performance space"]), static=True)
    for i, pl in enumerate(scene.planes):
        p, n = np.asarray(pl.point, float), np.asarray(pl.normal, float)
        along = np.cross([0.0, 0.0, 1.0], n)
        along = along / (np.linalg.norm(along) or 1.0)
        ext = np.array([[s[0], s[1]], [s[3], s[4]], [s[0], s[4]], [s[3], s[1]]]) @ along[:2]
        lo, hi = ext.min() - p[:2] @ along[:2], ext.max() - p[:2] @ along[:2]
        q = np.array([p + lo * along, p + hi * along, p + hi * along, p + lo * along])
        q[:, 2] = [s[2], s[2], s[5], s[5]]
        entity = "world/apparatus_plane" + (f"/{i}" if i else "")
        rec.log(entity, rr.LineStrips3D([np.vstack([q, q[:1]])], colors=[(255, 105, 180)]), static=True)
        rec.log(entity + "/surface", rr.Mesh3D(vertex_positions=q, triangle_indices=[[0, 1, 2], [0, 2, 3]],
                                               albedo_factor=[255, 105, 180, 50]), static=True)
    if scene.apparatus:
        from ..apparatus import get_apparatus

        app = get_apparatus(scene.apparatus)
        if app.bars:
            rec.log("world/apparatus/bars", rr.LineStrips3D([[b.start, b.end] for b in app.bars], colors=[(200, 200, 205)],
                                                            radii=[b.radius for b in app.bars]), static=True)
        if app.blocks:
            lo, hi = np.array([b.lo for b in app.blocks]), np.array([b.hi for b in app.blocks])
            rec.log("world/apparatus/blocks", rr.Boxes3D(mins=lo, sizes=hi - lo, colors=[(190, 150, 100)],
                                                         fill_mode=rr.components.FillMode.Solid), static=True)


def _log_cameras(rec, rr, rig, videos: dict[str, Path], first_frame: int, offsets: dict) -> dict[str, str]:
    """Cameras, and their videos as assets with one frame reference per frame; camera -> video entity."""
    from ..formats.video import VideoReader

    out = {}
    for cam in rig:
        base = f"world/cameras/{cam.name}"
        rec.log(base, rr.Transform3D(translation=cam.t, mat3x3=cam.R, relation=rr.TransformRelation.ChildFromParent),
                static=True)
        rec.log(base + "/image", rr.Pinhole(image_from_camera=cam.K, resolution=list(cam.size),
                                            camera_xyz=rr.ViewCoordinates.RDF), static=True)
        if cam.name not in videos:
            continue
        path = videos[cam.name]
        with VideoReader(path, first_frame, int(offsets.get(cam.name, 0))) as v:
            size, numbers = v.size, v.frame_numbers
        if tuple(size) == tuple(cam.size):
            entity = base + "/image/video"
        else:  # a scaled preview: its own pinhole, same pose
            entity = base + "/video"
            s = size[0] / cam.size[0]
            rec.log(entity, rr.Pinhole(image_from_camera=np.diag([s, s, 1.0]) @ cam.K, resolution=list(size),
                                       camera_xyz=rr.ViewCoordinates.RDF), static=True)
        asset = rr.AssetVideo(path=path)
        rec.log(entity, asset, static=True)
        ts = np.asarray(asset.read_frame_timestamps_nanos(), dtype=np.int64)
        n = min(len(ts), len(numbers))
        rec.send_columns(entity, indexes=[rr.TimeColumn("frame", sequence=numbers[:n])],
                         columns=rr.VideoFrameReference.columns_nanos(ts[:n]))
        out[cam.name] = entity
    return out


def _log_boxes(rec, rr, entity: str, boxes, colour=None, labels: bool = False) -> None:
    if not len(boxes):
        return
    cols = dict(centers=boxes.box[:, :2], half_sizes=boxes.box[:, 2:] / 2)
    cols["colors"] = _rgb(boxes.track_id) if colour is None else np.tile(np.asarray(colour, np.uint8), (len(boxes), 1))
    if labels:
        cols["labels"] = [str(i) for i in boxes.track_id.tolist()]
    _send(rec, rr, entity, boxes.frame, rr.Boxes2D, **cols)


def _log_2d(rec, rr, inputs, gt) -> None:
    r, o = inputs.routine, inputs.outputs
    for c, name in enumerate(r.camera_names):
        img = f"world/cameras/{name}/image"
        _log_boxes(rec, rr, img + "/detections", r.detections.for_camera(c), _bgr2rgb(DETECTION))
        _log_boxes(rec, rr, img + "/tracks", o.boxes.for_camera(c), labels=True)
        _log_boxes(rec, rr, img + "/b_buf", o.target_boxes.for_camera(c), _bgr2rgb(B_BUF))
        if gt is not None:
            m = gt.box_camera == c
            tb = type(r.detections).from_arrays(gt.box_frame[m], np.full(m.sum(), c), gt.box[m], r.camera_names,
                                                track_id=gt.box_person[m])
            _log_boxes(rec, rr, img + "/gt_boxes", tb, GT)
        p = inputs.poses
        if p is not None:
            p = p.subset(p.camera == c)
            ok = p.found()
            row, j = np.nonzero(ok)
            _send(rec, rr, img + "/keypoints", p.frame[row], rr.Points2D, positions=p.keypoints[row, j, :2],
                  keypoint_ids=j, colors=_rgb(p.track_id[row]))
            seg, srow = _bone_strips(p.keypoints[..., :2], p.skeleton.bones, ok)
            _send(rec, rr, img + "/skeleton", p.frame[srow], rr.LineStrips2D, strips=seg, colors=_rgb(p.track_id[srow]))


def _log_3d(rec, rr, inputs, routine_path: Path, out: Path) -> dict:
    o = inputs.outputs
    t = o.tracks
    labels = [f"{i} {s}" for i, s in zip(t.track_id.tolist(), t.source.tolist())]
    _send(rec, rr, "world/tracks", t.frame, rr.Points3D, positions=t.xyz, colors=_rgb(t.track_id), labels=labels,
          radii=np.full(len(t), 0.08))
    strips, ids = [], []
    for tid in np.unique(t.track_id):
        m = t.track_id == tid
        order = np.argsort(t.frame[m])
        strips.append(t.xyz[m][order])
        ids.append(tid)
    if strips:
        rec.log("world/track_paths", rr.LineStrips3D(strips, colors=_rgb(np.asarray(ids)), labels=[str(i) for i in ids]),
                static=True)
    g = o.target
    _send(rec, rr, "world/target", g.frame, rr.Points3D, positions=g.xyz, radii=np.full(len(g), 0.15),
          colors=np.tile(np.asarray(TARGET, np.uint8), (len(g), 1)),
          labels=[f"target {i} {s}" for i, s in zip(g.track_id.tolist(), g.source.tolist())])
    if len(g):
        rec.log("world/target/path", rr.LineStrips3D([g.xyz[np.argsort(g.frame)]], colors=[TARGET]), static=True)
    n_poses = 0
    pp = out / "poses_3d.csv"
    if pp.is_file():
        from ..formats.poses3d import read_poses_3d

        poses = read_poses_3d(pp)
        key = set(zip(g.frame.tolist(), g.track_id.tolist()))
        is_target = np.array([k in key for k in zip(poses.frame.tolist(), poses.track_id.tolist())], bool)
        ok = np.all(np.isfinite(poses.xyz), -1)
        for entity, m in (("world/target/skeleton", is_target), ("world/poses", ~is_target)):
            seg, row = _bone_strips(poses.xyz[m], poses.skeleton.bones, ok[m])
            colours = np.tile(np.asarray(TARGET, np.uint8), (len(row), 1)) if entity.startswith("world/target") \
                else _rgb(poses.track_id[m][row])
            _send(rec, rr, entity, poses.frame[m][row], rr.LineStrips3D, strips=seg, colors=colours)
        n_poses = len(poses)
    return {"tracks_3d": len(t), "target_3d": len(g), "poses_3d": n_poses}


def _log_gt(rec, rr, routine_path: Path, camera_names) -> object | None:
    gt_dir = routine_path / "gt"
    if not (gt_dir / "persons_3d.csv").is_file():
        return None
    from ..formats.ground_truth import load_ground_truth

    gt = load_ground_truth(routine_path, camera_names)
    _send(rec, rr, "world/gt/persons", gt.frame, rr.Points3D, positions=gt.xyz,
          colors=np.tile(np.asarray(GT, np.uint8), (len(gt.frame), 1)), labels=[f"gt {i} {r}" for i, r in zip(gt.person_id.tolist(), gt.role.tolist())])
    kp = gt_dir / "keypoints_3d.csv"
    if kp.is_file():
        from ..formats.gt_keypoints import read_keypoints_3d
        from ..skeletons import COCO17

        frames, _, joints = read_keypoints_3d(kp)
        P, T = joints.shape[:2]
        flat = joints.reshape(P * T, 17, 3)
        seg, row = _bone_strips(flat, COCO17.bones, np.all(np.isfinite(flat), -1))
        _send(rec, rr, "world/gt/skeleton", frames[row % T], rr.LineStrips3D, strips=seg,
              colors=np.tile(np.asarray(GT, np.uint8), (len(row), 1)))
    return gt


def analysis_entries(marks) -> tuple[np.ndarray, list[str]]:
    """(frame (N,), text) of the ``analysis/now`` document: the captions of every frame from the first
    element to one past the last shown (empty where nothing goes on, so the document clears)."""
    if not len(marks.elements):
        return np.zeros(0, np.int64), []
    f = np.arange(int(marks.start.min()), int(marks.end.max()) + 2, dtype=np.int64)
    return f, marks.per_frame(f)


def _log_analysis(rec, rr, inputs, out: Path) -> int:
    """The analysis stage's elements and angles (module docstring); returns the elements logged."""
    marks = inputs.marks
    if marks is not None:
        doc = {"elements": marks.elements}
        frames, texts, kinds = element_events(doc)
        _send(rec, rr, "analysis/elements", frames, rr.TextLog, text=texts, level=["INFO"] * len(texts),
              color=np.asarray([kind_bgr(k)[::-1] for k in kinds], np.uint8).reshape(-1, 3))
        f, now = analysis_entries(marks)
        _send(rec, rr, "analysis/now", f, rr.TextDocument, text=now)
        g = inputs.outputs.target
        strips, labels = [], []
        for i, el in enumerate(marks.elements):
            if el["kind"] == "flight":
                m = (g.frame >= el["start_frame"]) & (g.frame <= el["end_frame"])
                if m.sum() >= 2:
                    strips.append(g.xyz[m][np.argsort(g.frame[m])])
                    labels.append(marks.caption(i, el["end_frame"]).rsplit("  ", 1)[0])
        if strips:
            rec.log("world/target/flights", rr.LineStrips3D(strips, colors=[kind_bgr("flight")[::-1]], labels=labels,
                                                            radii=[0.03]), static=True)
    ap = out / "analysis" / "angles.csv"
    if ap.is_file():
        from ..formats.elements import read_angles

        a = read_angles(ap)
        for name in ("com_z", "somersault", "twist"):
            ok = np.isfinite(a[name])
            rec.send_columns(f"analysis/{name}", indexes=[rr.TimeColumn("frame", sequence=a["frame"][ok])],
                             columns=rr.Scalars.columns(scalars=a[name][ok]))
    return 0 if marks is None else len(marks.elements)


def write_recording(routine: str | Path, out: str | Path, rrd: str | Path, videos: bool = True,
                    progress: Callable[[str], None] | None = None) -> dict:
    """Write the Rerun recording ``rrd`` of ``routine`` and the outputs in ``out`` (see the module's
    entities). ``videos``: embed ``videos/<camera>.*`` as video assets. Returns what was logged:
    counts of rows per kind and the video entities."""
    rr = import_rerun()
    inputs = load_overlay_inputs(routine, out)
    r = inputs.routine
    rrd = Path(rrd)
    say = progress or (lambda _msg: None)
    with replace_when_done(rrd) as tmp:
        rec = rr.RecordingStream("gymtrack")
        rec.save(str(tmp))
        try:
            _log_static_scene(rec, rr, r.scene)
            first, offsets = r.scene.first_frame, r.scene.video_offsets
            video_entities = _log_cameras(rec, rr, r.rig, inputs.videos if videos else {}, first, offsets)
            say(f"cameras: {len(r.rig)}, videos: {len(video_entities)}")
            gt = _log_gt(rec, rr, r.path, r.camera_names)
            counts = _log_3d(rec, rr, inputs, r.path, Path(out))
            _log_2d(rec, rr, inputs, gt)
            counts["elements"] = _log_analysis(rec, rr, inputs, Path(out))
        finally:
            rec.flush()
            rec.disconnect()
    counts.update(detections=len(r.detections), boxes=len(inputs.outputs.boxes), b_buf=len(inputs.outputs.target_boxes),
                  keypoints=0 if inputs.poses is None else len(inputs.poses), ground_truth=gt is not None,
                  videos=video_entities, path=rrd)
    return counts


def read_recording(rrd: str | Path, entities: Sequence[str] | None = None) -> dict[str, dict[str, list]]:
    """A recording read back with Rerun's reader: entity path (``/world/...``) -> column -> one
    value per logged row (``frame`` for the timeline; components as ``Archetype:field``)."""
    import_rerun()
    from rerun.chunk import RrdReader

    parts: dict[str, list[tuple[int, dict]]] = {}
    for chunk in RrdReader(str(rrd)).store().stream():
        if entities is None or chunk.entity_path in entities:
            parts.setdefault(chunk.entity_path, []).append((chunk.num_rows, chunk.to_record_batch().to_pydict()))
    out: dict[str, dict[str, list]] = {}
    for ent, chunks in parts.items():
        keys = sorted({k for _, d in chunks for k in d})  # a column missing from a chunk reads None there
        out[ent] = {k: [v for n, d in chunks for v in d.get(k, [None] * n)] for k in keys}
    return out
