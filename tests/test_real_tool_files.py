"""Real tools' 2D pose files, in each tool's documented layout: read right, or refused clearly.

OpenPose ``--write_json`` folders (and Pose2Sim's ``cam01.0031.json`` naming), scores above 1,
COCO results with string ``image_id`` and AlphaPose's ``category_id`` / ``idx``, MMPose's
``--save-predictions`` files, COCO-WholeBody's 133 joints, HALPE_26 as rtmlib writes it through
Pose2Sim, and camera folders matched to the calibration by name or sorted order.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gymtrack.errors import GymtrackWarning, InputError
from gymtrack.formats.camera_match import match_cameras
from gymtrack.formats.keypoints import KeypointsReport, read_keypoints, read_keypoints_file
from gymtrack.formats.pose_boxes import boxes_from_poses
from gymtrack.skeletons import BODY25, COCO17, COCO_WHOLEBODY, HALPE26, get_skeleton

# one standing person, COCO-17 order, pixels (x right, y down), scores as a heatmap model gives
STAND = np.array([[500, 100], [510, 90], [490, 90], [520, 95], [480, 95], [540, 150], [460, 150], [550, 220],
                  [450, 220], [555, 290], [445, 290], [530, 300], [470, 300], [532, 400], [468, 400], [534, 500],
                  [466, 500]], float)


def _person(k: int, J: int = 17, sk=COCO17, score=0.9, rng=None) -> np.ndarray:
    """(J, 3) a standing person shifted by k (x) with small noise, in ``sk``'s order."""
    rng = rng or np.random.default_rng(k)
    xy = STAND + [3 * k, 0] + rng.normal(0, 2, STAND.shape)
    c = {n: xy[i] for i, n in enumerate(COCO17.joints)}
    c["neck"] = c["mid_hip"] = c["hip"] = c["head"] = None
    out = np.zeros((len(sk.joints), 3))
    for j, n in enumerate(sk.joints):
        if n in COCO17.joints:
            out[j] = [*c[n], score]
        elif n == "neck":
            out[j] = [*(0.5 * (c["left_shoulder"] + c["right_shoulder"])), score]
        elif n in ("mid_hip", "hip"):
            out[j] = [*(0.5 * (c["left_hip"] + c["right_hip"])), score]
        elif n == "head":
            out[j] = [*(c["nose"] + [0, -40]), score]
        else:  # feet: beside the ankle
            side = "left" if n.startswith("left") else "right"
            out[j] = [*(c[f"{side}_ankle"] + [0, 12]), score]
    return out


def _openpose_folder(folder: Path, name, frames, sk=BODY25, people=2, score=0.9, extra_values=0):
    folder.mkdir(parents=True, exist_ok=True)
    for f in frames:
        ppl = []
        for p in range(people):
            kp = _person(f + 40 * p, sk=sk, score=score)
            ppl.append({"person_id": [-1], "pose_keypoints_2d": kp.ravel().tolist() + [0.0] * extra_values,
                        "face_keypoints_2d": [], "hand_left_keypoints_2d": [], "hand_right_keypoints_2d": []})
        (folder / name(f)).write_text(json.dumps({"version": 1.3, "people": ppl}))


def test_openpose_names_frames_and_scores_above_one(tmp_path):
    # OpenPose's own naming, 12-digit frame, and confidences a little above 1 (heatmap peaks)
    _openpose_folder(tmp_path / "kp" / "cam1", lambda f: f"run_{f:012d}_keypoints.json", range(30), score=1.0373)
    # Pose2Sim's naming <camera>.<4-digit index>.json, and a camera number before the frame
    _openpose_folder(tmp_path / "kp" / "cam2", lambda f: f"Static_cam_02.{f:05d}.json", range(0, 30, 3), score=0.8)
    (tmp_path / "kp" / "cam1_pose.mp4").write_bytes(b"\0")  # what Pose2Sim writes beside the *_json folders
    (tmp_path / "kp" / "cam1_img").mkdir()
    for c in ("cam1", "cam2"):
        (tmp_path / "kp" / c).rename(tmp_path / "kp" / f"{c}_json")
    rep = KeypointsReport()
    p = read_keypoints(tmp_path / "kp", ("cam1", "cam2"), report=rep)
    assert "not read (beside the *_json folders): cam1_img, cam1_pose.mp4" in rep.lines()
    assert p.skeleton == BODY25 and rep.skeleton_how == "recognised from the joint count and layout"
    assert sorted(set(p.frame[p.camera == 1].tolist())) == list(range(0, 30, 3))  # the last number, not 2
    assert rep.scores_above_1 == 30 * 2 * 25 and rep.max_score == pytest.approx(1.0373)
    assert (p.keypoints[..., 2] <= 1.0373).all() and "scores above 1" in " ".join(rep.lines())


@pytest.mark.parametrize("names, message", [
    (("cam01.0001.json", "cam01.01.json"), "frame 1 again"),
    (("cam01.0001.json", "cam01.json_notes.txt"), "not a JSON file"),
    (("first.json",), "no frame number in the file name"),
])
def test_openpose_folder_refusals_name_the_file(tmp_path, names, message):
    folder = tmp_path / "cam1_json"
    folder.mkdir()
    for n in names:
        (folder / n).write_text(json.dumps({"people": []}))
    with pytest.raises(InputError, match=message) as e:
        read_keypoints_file(folder, 0, ("cam1",))
    assert Path(e.value.source).parent == folder


def test_coco_results_string_image_ids_and_alphapose_fields(tmp_path):
    kp = _person(0)
    doc = [{"image_id": iid, "category_id": 1, "idx": [3.0], "score": 2.4, "keypoints": kp.ravel().tolist(),
            "box": [1, 2, 3, 4]} for iid in ("51", "000052.jpg", 53, "cam1/frame_54.png")]
    (tmp_path / "res.json").write_text(json.dumps(doc))
    p = read_keypoints_file(tmp_path / "res.json", 0, ("c",))
    assert p.frame.tolist() == [51, 52, 53, 54] and p.skeleton == COCO17
    doc[1]["image_id"] = "frame.jpg"
    (tmp_path / "res.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match=r"res.json: field '\[1\].image_id': image_id 'frame.jpg' holds no frame"):
        read_keypoints_file(tmp_path / "res.json", 0, ("c",))


def _mmpose_instances(frame: int, n: int = 2, J: int = 17, sk=COCO17):
    out = []
    for p in range(n):
        kp = _person(frame + 40 * p, sk=sk)
        out.append({"keypoints": kp[:, :2].tolist(), "keypoint_scores": kp[:, 2].tolist(),
                    "bbox": [[float(kp[:, 0].min()), float(kp[:, 1].min()), float(kp[:, 0].max()), float(kp[:, 1].max())]],
                    "bbox_score": 0.97})
    return out


def test_mmpose_save_predictions_demo_and_inferencer(tmp_path):
    meta = {"dataset_name": "coco", "num_keypoints": 17, "keypoint_id2name": {str(i): n for i, n in enumerate(COCO17.joints)}}
    demo = {"meta_info": meta, "instance_info": [{"frame_id": f, "instances": _mmpose_instances(f)} for f in range(1, 6)]}
    (tmp_path / "results_cam1.json").write_text(json.dumps(demo))
    p = read_keypoints_file(tmp_path / "results_cam1.json", 0, ("c",))
    assert p.skeleton == COCO17 and p.frame.tolist() == [1, 1, 2, 2, 3, 3, 4, 4, 5, 5]
    kp = _person(1)
    assert np.allclose(p.bbox[0], [kp[:, 0].min(), kp[:, 1].min(), np.ptp(kp[:, 0]), np.ptp(kp[:, 1])])  # corners -> ltwh
    # the inferencer's list of frames; joints named nowhere: 17 joints are COCO-17
    inf = [{"frame_id": f, "instances": _mmpose_instances(f)} for f in range(3)]
    (tmp_path / "inf.json").write_text(json.dumps(inf))
    assert read_keypoints_file(tmp_path / "inf.json", 0, ("c",)).frame.tolist() == [0, 0, 1, 1, 2, 2]
    # one image: the frame is the file name's last number
    (tmp_path / "000042.json").write_text(json.dumps({"meta_info": meta, "instance_info": _mmpose_instances(42)}))
    assert read_keypoints_file(tmp_path / "000042.json", 0, ("c",)).frame.tolist() == [42, 42]
    (tmp_path / "img.json").write_text(json.dumps({"meta_info": meta, "instance_info": _mmpose_instances(42)}))
    with pytest.raises(InputError, match="img.json: the predictions of one image"):
        read_keypoints_file(tmp_path / "img.json", 0, ("c",))
    bad = {"meta_info": meta, "instance_info": [{"frame_id": 1, "instances": [{"keypoints": [[1, 2]] * 17,
                                                                                 "keypoint_scores": [0.5] * 16}]}]}
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    with pytest.raises(InputError, match=r"bad.json: field 'instance_info\[0\].instances\[0\].keypoint_scores'"):
        read_keypoints_file(tmp_path / "bad.json", 0, ("c",))


def test_wholebody_133_and_halpe26_through_pose2sim(tmp_path):
    # COCO-WholeBody: 23 body joints used, 110 face and hand joints counted
    wb = [{"image_id": f, "keypoints": np.vstack([_person(f, sk=COCO_WHOLEBODY), np.full((110, 3), [1.0, 1.0, 0.5])])
           .ravel().tolist()} for f in range(25)]
    (tmp_path / "wb.json").write_text(json.dumps(wb))
    rep = KeypointsReport()
    p = read_keypoints_file(tmp_path / "wb.json", 0, ("c",), report=rep)
    assert p.skeleton == COCO_WHOLEBODY and p.keypoints.shape == (25, 23, 3) and rep.unused_joints == 110
    # rtmlib's HALPE_26 as Pose2Sim saves it: OpenPose-style folders
    _openpose_folder(tmp_path / "pose" / "cam01_json", lambda f: f"cam01.{f:04d}.json", range(12), sk=HALPE26)
    assert read_keypoints_file(tmp_path / "pose" / "cam01_json", 0, ("c",)).skeleton == HALPE26
    assert get_skeleton("HALPE_26") is HALPE26 and get_skeleton("COCO_133") is COCO_WHOLEBODY
    # any named joint list, in file order
    p = read_keypoints_file(tmp_path / "pose" / "cam01_json", 0, ("c",), skeleton=",".join(f"j{i}" for i in range(26)))
    assert p.skeleton.name == "custom" and p.skeleton.joints[25] == "j25"
    assert read_keypoints_file(tmp_path / "pose" / "cam01_json", 0, ("c",), skeleton=",".join(HALPE26.joints)).skeleton \
        is HALPE26


def test_cameras_matched_by_name_similar_name_or_sorted_order(tmp_path):
    m = match_cameras(["cam01", "cam02", "cam10"], ["cam_10", "cam_01", "cam_02"])
    assert m.entries == {"cam_10": "cam10", "cam_01": "cam01", "cam_02": "cam02"}
    m = match_cameras(["cam1", "cam2"], ["int_cam1_img", "int_cam2_img"])  # Pose2Sim's calibration names
    assert m.entries == {"int_cam1_img": "cam1", "int_cam2_img": "cam2"} and not m.by_order
    m = match_cameras(["left", "right"], ["A", "B"])
    assert m.entries == {"A": "left", "B": "right"} and m.by_order
    for c in ("a", "b"):
        _openpose_folder(tmp_path / "pose" / f"{c}_json", lambda f: f"x.{f:04d}.json", range(25), sk=COCO17)
    rep = KeypointsReport()
    with pytest.warns(GymtrackWarning, match="matched to cameras by sorted order.*camB <- b_json, camA <- a_json"):
        read_keypoints(tmp_path / "pose", ("camB", "camA"), report=rep)
    assert rep.matched_by == {"camB": "sorted order", "camA": "sorted order"}
    assert any(line.startswith("camera camA <- ") and "a_json" in line for line in rep.lines())
    with pytest.raises(InputError, match="a_json, b_json cannot be matched to the cameras camA, camB, camC.*2 for 3"):
        read_keypoints(tmp_path / "pose", ("camA", "camB", "camC"))


def test_boxes_from_poses_cover_the_person(tmp_path):
    _openpose_folder(tmp_path / "cam1", lambda f: f"c.{f:04d}.json", range(25), sk=COCO17, people=1)
    p = read_keypoints_file(tmp_path / "cam1", 0, ("cam1",))
    p.keypoints[3, :14, 2] = 0.1  # one pose with only 3 confident joints left... and one with 2
    p.keypoints[4, :15, 2] = 0.1
    made = boxes_from_poses(p)
    assert made.boxes == 24 and made.too_few_joints == 1 and "derived from the 2D poses" in made.describe()
    d = made.detections.select(made.detections.frame == 0)
    x, y, w, h = d.box[0]
    kp = p.keypoints[0]
    assert x - w / 2 < kp[:, 0].min() and x + w / 2 > kp[:, 0].max()  # every joint inside, with padding
    assert y - h / 2 < kp[:, 1].min() - 30 and kp[:, 1].max() < y + h / 2 < kp[:, 1].max() + 30


def test_floor_below_zero_allowed_and_reported(tmp_path):
    """A venue whose calibrated floor lies 5 cm below z = 0: h_bot below 0 is accepted within the
    tracking space, and `gymtrack info` says where the standing people's box bottoms lie."""
    from dataclasses import replace

    from typer.testing import CliRunner

    from gymtrack.cli import app
    from gymtrack.errors import SceneError
    from gymtrack.formats.floor_check import standing_bottoms
    from gymtrack.formats.scene import scene_from_dict
    from gymtrack.geometry.camera import Rig
    from gymtrack.simulate import simulate_routine

    sim = simulate_routine("vault", n_cam=4, seed=5, seconds=10)
    flat = standing_bottoms(sim.detections, sim.rig)
    lowered = Rig([replace(c, t=c.t + c.R @ [0.0, 0.0, 0.05]) for c in sim.rig])  # world z shifted: floor at -0.05
    low = standing_bottoms(sim.detections, lowered)
    assert low.median == pytest.approx(flat.median - 0.05, abs=0.01)
    s = scene_from_dict({"apparatus": "vault", "performance_space": [-10, -3, -0.1, 10, 3, 4],
                         "target": {"h_top": 1.9, "h_bot": -0.05}})
    assert s.target.h_bot == -0.05
    with pytest.raises(SceneError, match="h_bot .* below the tracking space's floor"):
        scene_from_dict({"apparatus": "vault", "target": {"h_top": 1.9, "h_bot": -0.05}})
    routine = sim.write(tmp_path / "r")
    r = CliRunner().invoke(app, ["info", str(routine)])
    assert r.exit_code == 0, r.output
    assert f"floor: standing people's box bottoms lie at z = {flat.median:+.2f} m" in r.output


def test_info_checks_the_poses_beside_detections(tmp_path):
    from typer.testing import CliRunner

    from gymtrack.cli import app

    example = Path(__file__).resolve().parents[1] / "examples" / "balance_beam"
    kp = tmp_path / "kp"
    for c in ("cam0", "cam1", "cam2", "cam3"):
        _openpose_folder(kp / f"{c}_json", lambda f: f"{c}.{f:04d}.json", range(1, 26), sk=COCO17, people=1)
    r = CliRunner().invoke(app, ["info", str(example), "--keypoints", str(kp)])
    assert r.exit_code == 0, r.output
    assert "2D poses: camera cam2 <- " in r.output and "cam2_json (by name)" in r.output
    assert "skeleton coco17 (from the joint count, layout checked)" in r.output
    (kp / "cam3_json").rename(kp / "cam9_json")  # one left on each side: sorted order, said so
    r = CliRunner().invoke(app, ["info", str(example), "--keypoints", str(kp)])
    assert r.exit_code == 0 and "cam9_json (by sorted order)" in r.output
    (kp / "cam8_json").mkdir()  # two folders for one camera left: refused, naming them
    r = CliRunner().invoke(app, ["info", str(example), "--keypoints", str(kp)])
    assert r.exit_code != 0 and "cam8_json, cam9_json cannot be matched to the cameras cam3" in str(r.exception)
