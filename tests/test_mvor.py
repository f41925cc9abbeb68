"""MVOR reader on the real data (skipped when ``shared/data/mvor`` is absent).

MVOR: Srivastav et al., MICCAI-LABELS 2018, arXiv:1808.08180, CC BY-NC-SA 4.0. The expected
figures are those of the data's README ("Checked facts").
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from gymtrack.errors import InputError
from gymtrack.formats.mvor import MVOR_JOINTS, coco17_to_mvor, default_folder, read_mvor
from gymtrack.skeletons import COCO17

FOLDER = default_folder()
needs_data = pytest.mark.skipif(
    FOLDER is None or not (FOLDER / "camma_mvor_2018.json").is_file(),
    reason=f"needs the MVOR data set: {(FOLDER or Path('../shared/data/mvor')) / 'camma_mvor_2018.json'} not found "
           "(put it in ../shared/data/mvor or set $GYMTRACK_MVOR)")


@pytest.fixture(scope="module")
def mvor():
    return read_mvor(FOLDER)


def test_coco17_to_mvor_rule():
    k = np.zeros((4, 17, 3))
    i = {n: j for j, n in enumerate(COCO17.joints)}
    k[:, i["nose"]] = [10, 10, 0.9]
    k[0, i["left_eye"]], k[0, i["right_eye"]] = [20, 0, 0.6], [40, 0, 0.8]  # both eyes: their midpoint
    k[1, i["left_ear"]], k[1, i["right_ear"]] = [0, 4, 0.5], [8, 4, 0.5]    # no eyes: the ears
    k[1, i["left_eye"]] = [1, 1, 0.3]                                        # one eye is not a pair
    k[3, i["nose"]] = 0
    k[3, i["right_ear"]] = [7, 7, 0.4]                                       # only one ear left
    k[0, i["left_shoulder"]], k[0, i["right_shoulder"]] = [0, 50, 1.0], [100, 50, 0.5]
    k[1, i["right_shoulder"]] = [60, 60, 0.7]
    k[2, i["left_wrist"]] = [5, 6, 0.2]
    m = coco17_to_mvor(k)
    assert m.shape == (4, 10, 3)
    assert m[0, 0].tolist() == [30, 0, 0.7] and m[1, 0].tolist() == [4, 4, 0.5]
    assert m[2, 0].tolist() == [10, 10, 0.9] and m[3, 0].tolist() == [7, 7, 0.4]
    assert m[0, 1].tolist() == [50, 50, 0.75] and m[1, 1].tolist() == [60, 60, 0.7] and m[2, 1].tolist() == [0, 0, 0]
    assert m[2, MVOR_JOINTS.index("left_wrist")].tolist() == [5, 6, 0.2]
    assert m[0, MVOR_JOINTS.index("left_shoulder")].tolist() == [0, 50, 1.0]


def test_missing_folder_is_a_clear_error(tmp_path):
    with pytest.raises(InputError, match="camma_mvor_2018.json: file not found"):
        read_mvor(tmp_path)


@needs_data
def test_rig_matches_the_readme_projection_and_opencv(mvor):
    doc = json.loads((FOLDER / "camma_mvor_2018.json").read_text())["cameras_info"]["camParams"]
    rng = np.random.default_rng(0)
    X = rng.uniform([-1, -1, 1.5], [1, 1, 4], (50, 3))  # metres, in front of cam1
    for c, cam in enumerate(mvor.rig):
        E = np.array(doc["extrinsics"][c]).reshape(4, 4)
        Xc = (np.linalg.inv(E) @ np.c_[X * 1000, np.ones(len(X))].T).T[:, :3]  # the README's recipe, mm
        (fx, fy), (cx, cy) = doc["intrinsics"][c]["focallength"], doc["intrinsics"][c]["principalpoint"]
        readme = np.c_[fx * Xc[:, 0] / Xc[:, 2] + cx, fy * Xc[:, 1] / Xc[:, 2] + cy]
        front = Xc[:, 2] > 0
        ours = cam.project(X, distort=False)
        assert np.allclose(ours[front], readme[front], atol=1e-6)
        cv, _ = cv2.projectPoints(X[front], cv2.Rodrigues(cam.R)[0], cam.t, cam.K, None)
        assert np.allclose(ours[front], cv.reshape(-1, 2), atol=1e-6)
    assert np.allclose(mvor.rig[0].centre, 0) and mvor.rig.names == ("cam1", "cam2", "cam3")
    assert 2.0 < np.linalg.norm(mvor.rig[1].centre) < 5.0  # metres, not mm


@needs_data
def test_counts_and_shapes(mvor):
    F, P = mvor.person_id.shape
    assert F == 732 and mvor.joints3d.shape == (F, P, 10, 3) and mvor.keypoints2d.shape == (F, 3, P, 10, 3)
    c = mvor.counts
    # 1061 3D annotations: 718/719, 293/294, 628/629 and 636/637 share (frame, person_id)
    assert c["annotations_3d"] + c["duplicate_3d"] == 1061 and c["duplicate_3d"] == 4
    assert c["missing_joints_3d"] == 6 and c["placeholder_points_3d"] == 2 * c["annotations_3d"]
    assert c["annotations_2d"] + c["duplicate_2d"] == 2926 and c["bbox_only"] == 1773 == len(mvor.bbox_only)
    assert mvor.has3d.sum() == c["annotations_3d"]
    assert np.isnan(mvor.joints3d).all(-1).sum() == 6 + (F * P - c["annotations_3d"]) * 10
    z = mvor.joints3d[..., 2]
    assert np.nanmin(z) > 0.5 and np.nanmax(z) < 8  # metres in front of cam1
    v = mvor.views_annotated()[mvor.has3d]
    assert ((v >= 2).sum(), (v == 1).sum()) == (925, 132)  # README: 501 + 428 in 2-3 views (less 4 duplicates)


@needs_data
def test_gt_3d_reprojects_onto_gt_2d(mvor):
    """README: visible joints, median 6.5 / 7.1 / 6.4 px, 90th percentile 16.9 / 18.5 / 16.2 px."""
    few = slice(0, 120)  # a few frames of day 1 and 2 are enough for the check
    for v, cam in enumerate(mvor.rig):
        X = mvor.joints3d[few]
        g = mvor.keypoints2d[few, v]
        ok = (g[..., 2] == 2) & np.isfinite(X[..., 0])
        uv = cam.project(X[ok], distort=False)
        err = np.linalg.norm(uv - g[ok][:, :2], axis=-1)
        assert ok.sum() > 300 and np.median(err) < 9 and np.percentile(err, 90) < 25, (cam.name, np.median(err))


@needs_data
def test_detection_layout_is_coco17_and_association_links_most(mvor):
    raw = json.loads((FOLDER / "openpose_kps.json").read_text())
    coco = np.array([d["coco_keypoints"] for d in raw]).reshape(-1, 17, 3)
    given = np.array([d["keypoints"] for d in raw]).reshape(-1, 10, 3)
    assert np.allclose(coco17_to_mvor(coco), given)  # MVOR's own mapping, reproduced exactly
    ls, rs = MVOR_JOINTS.index("left_shoulder"), MVOR_JOINTS.index("right_shoulder")
    for name, det in mvor.detections.items():
        c, m = det.counts, det.mapped
        assert c["linked"] + c["unlinked"] == c["entries"] == len(m)
        linked = m.track_id >= 0
        assert np.all(det.match_px[linked] <= 50) and np.isnan(det.match_px[~linked]).all()
        key = (m.frame * 3 + m.camera) * 100 + m.track_id
        assert len(np.unique(key[linked])) == linked.sum()  # one detection per person and view
        # left is the person's left, as in the GT: left shoulders land on GT left shoulders
        g = mvor.keypoints2d[m.frame[linked], m.camera[linked], m.track_id[linked]]
        d = m.keypoints[linked]
        both = (d[:, ls, 2] > 0) & (g[:, ls, 2] == 2) & (g[:, rs, 2] == 2)
        same = np.linalg.norm(d[both, ls, :2] - g[both, ls, :2], axis=-1)
        swapped = np.linalg.norm(d[both, ls, :2] - g[both, rs, :2], axis=-1)
        assert (same < swapped).mean() > 0.9, name
        accounted = (linked | det.in_bbox_only | det.repeated).mean()
        assert accounted > 0.8, (name, accounted)
    assert mvor.detections["rtpose"].counts["linked"] / mvor.detections["rtpose"].counts["entries"] > 0.8
    assert mvor.detections["openpose"].counts["repeated"] == 890  # the README's defect
    dense = mvor.detected_keypoints("rtpose")
    assert dense.shape == mvor.keypoints2d.shape
    assert (dense[..., 2] > 0).any(-1).sum() == mvor.detections["rtpose"].counts["linked"]
