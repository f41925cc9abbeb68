"""Test data for the viewer and overlay tests: a short simulated routine and an output folder made
from its ground truth (every person a 3D track, the true boxes as per-view boxes, the target's
true box as b_buf, its true joints as the 3D pose and their projections as 2D poses), so the
expected contents of a recording or an overlay are known without running the tracker."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gymtrack.formats.keypoints import write_keypoints
from gymtrack.formats.motchallenge import write_mot
from gymtrack.poses import Poses2D
from gymtrack.simulate import simulate_routine
from gymtrack.skeletons import COCO17

SOURCES = ("triangulation", "plane", "interpolated")


def make_routine(folder: Path, video_width: int | None = None):
    """A 10 s balance-beam routine written to ``folder`` (videos at ``video_width`` when given)."""
    sim = simulate_routine("balance_beam", 4, seed=5, seconds=10, out=folder)
    if video_width:
        from gymtrack.simulate.render import write_videos

        write_videos(sim, folder, video_width)
    return sim


def write_gt_outputs(sim, out: Path) -> Path:
    """An output folder (formats.md) holding the ground truth of ``sim``."""
    out.mkdir(parents=True, exist_ok=True)
    pi, ti = np.nonzero(sim.alive)
    xyz = sim.centre[pi, ti]
    src = np.asarray(SOURCES)[(pi + ti) % 3]
    with open(out / "tracks_3d.csv", "w") as fh:
        fh.write("frame,track_id,x,y,z,top_z,bottom_z,source,n_views\n")
        for f, i, p, s, tz, bz in zip(sim.frames[ti], sim.person_id[pi], xyz, src, sim.top_z[pi, ti], sim.bottom_z[pi, ti]):
            fh.write(f"{f},{i},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f},{tz:.4f},{bz:.4f},{s},4\n")
    with open(out / "target_3d.csv", "w") as fh:
        fh.write("frame,track_id,x,y,z,source\n")
        for t in np.flatnonzero(sim.performing):
            p = sim.centre[0, t]
            fh.write(f"{sim.frames[t]},{sim.target_id},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f},triangulation\n")
    ok = np.isfinite(sim.true_boxes.depth) & (sim.true_boxes.inside > 0) & sim.alive[None]
    kp_rows = []
    for c, name in enumerate(sim.rig.names):
        p, t = np.nonzero(ok[c])
        write_mot(out / "tracks_2d" / f"{name}.txt", sim.frames[t], sim.person_id[p], sim.gt_box[c, p, t])
        tt = t[(p == 0) & sim.performing[t]]
        b = sim.gt_box[c, 0, tt].copy()
        b[:, 2:] = 1.3 * b[:, 2:].max(1, keepdims=True)
        write_mot(out / "target_2d" / f"{name}.txt", sim.frames[tt], np.full(tt.size, sim.target_id), b)
        uv = sim.rig[c].project(sim.keypoints[0, tt])
        kp = np.concatenate([uv, np.ones(uv.shape[:2] + (1,))], -1)
        kp_rows.append(Poses2D(sim.frames[tt], np.full(tt.size, c), np.full(tt.size, sim.target_id), kp,
                               np.full((tt.size, 4), np.nan), COCO17, sim.rig.names))
    write_keypoints(out / "keypoints", Poses2D.concat(kp_rows))
    perf = np.flatnonzero(sim.performing)
    with open(out / "poses_3d.csv", "w") as fh:
        fh.write("frame,track_id,joint,x,y,z,score,n_views,reproj_px\n")
        for t in perf:
            for j, name in enumerate(COCO17.joints):
                x, y, z = sim.keypoints[0, t, j]
                fh.write(f"{sim.frames[t]},{sim.target_id},{name},{x:.4f},{y:.4f},{z:.4f},0.9,4,1.0\n")
    return out
