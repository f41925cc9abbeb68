"""End to end: the tracker against ground truth on simulated routines and on WILDTRACK.

Simulated routines (``gymtrack.simulate``): with four views the target is found with few
switches and a mean 3D error of a few centimetres; with only the two opposite views the cascade
(plane fallback) is clearly more accurate than triangulation alone (the paper's Table 3 / 4).
WILDTRACK (real calibration and annotation boxes, a horizontal plane at hip height): the 3D
positions land near the annotated ground positions.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import WILDTRACK, needs_wildtrack
from gymtrack import simulate
from gymtrack.detections import Detections
from gymtrack.eval import metrics
from gymtrack.tracking import track_detections

SECONDS = 12


def target_errors(sim, mode):
    """Tracker's target against the ground truth on the performing frames:
    (AED as :class:`gymtrack.eval.metrics.Distance`, median error where the output is the
    gymnast, coverage, switches)."""
    res = track_detections(sim.rig, sim.scene, sim.detections, mode=mode)
    gt = sim.target_centre
    ok = np.all(np.isfinite(gt), axis=1)
    perf = sim.frames[sim.performing & ok]
    d = metrics.average_euclidean_distance(sim.frames[ok], gt[ok], res.target.frame, res.target.xyz, frames=perf)
    cov = metrics.coverage(perf, res.target.frame)
    g = sim.ground_truth()
    who, dist = metrics.nearest_person(res.target.frame, res.target.xyz, g.frame, g.person_id, g.xyz, gate=1.0)
    on_target = float(np.median(dist[who == sim.target_id])) if np.any(who == sim.target_id) else np.inf
    return d, on_target, cov.share, res.summary["target_switches"]


@pytest.mark.slow
def test_four_views_find_the_target_with_centimetre_error():
    sim = simulate.simulate_routine("uneven_bars", n_cam=4, seed=0, seconds=SECONDS)
    d, on_target, cov, switches = target_errors(sim, "cascade")
    print(f"uneven bars, n_cam=4, cascade: AED {d.mean:.3f} m over {d.n} frames (median {on_target:.3f} m "
          f"while on the gymnast), coverage {cov:.2f}, switches {switches}")
    assert on_target < 0.08  # centimetres while following the gymnast
    assert d.mean < 0.15  # including the frames of a brief switch to someone else
    assert cov > 0.8
    assert switches <= 3


def near_plane_routine(apparatus, n_cam, seeds=(1, 0, 2, 3), max_off=0.15):
    """The first simulated routine whose gymnast keeps within ``max_off`` metres (median) of the
    scene's plane while performing -- the paper's premise. The simulator also makes routines
    that drift further (on the uneven bars, along the bar); there the plane fallback's error is
    about that drift, which no plane-based method avoids."""
    for seed in seeds:
        sim = simulate.simulate_routine(apparatus, n_cam=n_cam, seed=seed, seconds=SECONDS)
        plane = sim.scene.planes[0]
        c = sim.target_centre[sim.performing]
        off = float(np.nanmedian(np.abs((c - np.array(plane.point)) @ np.array(plane.normal))))
        if off < max_off:
            return sim, seed, off
    pytest.fail(f"no simulated {apparatus} routine among seeds {seeds} keeps the gymnast near the plane")


@pytest.mark.slow
@pytest.mark.parametrize("apparatus", ["balance_beam", "uneven_bars"])
def test_two_opposite_views_cascade_beats_triangulation(apparatus):
    sim, seed, off = near_plane_routine(apparatus, n_cam=2)
    out = {}
    for mode in ("cascade", "triangulation"):
        d, on_target, cov, _ = target_errors(sim, mode)
        out[mode] = d
        print(f"{apparatus} (seed {seed}, gymnast {off:.2f} m off the plane), n_cam=2, {mode}: "
              f"AED {d.mean:.3f} m over {d.n} frames, coverage {cov:.2f}")
    assert min(out["cascade"].n, out["triangulation"].n) >= 50  # both found the target for a while ...
    assert out["cascade"].mean < 0.7 * out["triangulation"].mean  # ... and the cascade is clearly closer


@needs_wildtrack
def test_wildtrack_positions_land_near_the_annotated_ground_positions():
    from gymtrack.formats.scene import scene_from_dict
    from gymtrack.formats.wildtrack import read_wildtrack_annotations, read_wildtrack_calibration

    rig = read_wildtrack_calibration(WILDTRACK)
    ann = read_wildtrack_annotations(WILDTRACK, camera_names=rig.names, limit=80)
    d = ann.detections
    rng = np.random.default_rng(0)
    keep = rng.random(len(d)) > 0.1  # drop 10 % of the boxes, jitter the rest
    box = d.box + rng.normal(0, 3.0, d.box.shape) * [1, 1, 0.5, 0.5]
    frame = d.frame[keep] // 5  # annotations are every 5th video frame: number them 0, 1, 2...
    raw = Detections.from_arrays(frame, d.camera[keep], box[keep], rig.names)
    oracle = Detections.from_arrays(frame, d.camera[keep], box[keep], rig.names, track_id=d.track_id[keep])
    scene = scene_from_dict({
        "performance_space": [-3.0, -9.0, 0.0, 9.0, 27.0, 2.5],  # the annotated ground area
        "buffer": 0.5,
        "planes": [{"point": [0, 0, 0.9], "normal": [0, 0, 1]}],  # a box centre is about hip height
        "params": {"max_speed": 2.0},  # 2 frames per second: walking is ~0.7 m per frame
    })
    gf, gp = ann.frame // 5, ann.position[:, :2]

    def horizontal_error(tracks):
        errs = [np.linalg.norm(tracks.xyz[tracks.frame == f][:, None, :2] - gp[gf == f][None], axis=2).min(axis=1)
                for f in np.unique(tracks.frame)]
        return np.concatenate(errs)

    found = {}
    for name, det, mode, assoc in (("cascade", raw, "cascade", "iou"), ("plane", raw, "plane", "iou"),
                                   ("cascade, oracle association", oracle, "cascade", "oracle")):
        res = track_detections(rig, scene, det, mode=mode, association=assoc)
        e = horizontal_error(res.tracks)
        found[name] = np.median(e)
        print(f"WILDTRACK {name}: {len(res.tracks)} points, median horizontal error {np.median(e):.3f} m, "
              f"90th percentile {np.percentile(e, 90):.3f} m")
        assert len(res.tracks) > 500
        assert np.median(np.abs(res.tracks.xyz[:, 2] - 0.9)) < 0.2  # centres at hip height
    assert found["cascade, oracle association"] < 0.1  # geometry on real calibration: centimetres
    assert found["plane"] < 0.35
    assert found["cascade"] < 0.6  # 20-40 people, 7 views: some clusters mix people up
