"""2D pose files: native JSON, COCO keypoint results, OpenPose folders; errors name file and field."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gymtrack.errors import InputError
from gymtrack.formats.keypoints import read_keypoints, read_keypoints_file, write_keypoints
from gymtrack.poses import Poses2D
from gymtrack.skeletons import BODY25, COCO17, HALPE26, custom_skeleton
from mutation import mutated_doc

CAMS = ("cam1", "cam2")


def _random_poses(rng, n, sk=COCO17, cams=CAMS) -> Poses2D:
    J = len(sk.joints)
    kp = np.column_stack([rng.uniform(0, 1920, (n * J, 2)), rng.uniform(0.01, 1, n * J)]).reshape(n, J, 3)
    kp[rng.uniform(size=(n, J)) < 0.2] = [np.nan, np.nan, 0.0]
    kp[0] = [np.nan, np.nan, 0.0]  # a pose with nothing found is kept
    bbox = np.column_stack([rng.uniform(0, 1500, (n, 2)), rng.uniform(10, 400, (n, 2))])
    bbox[rng.uniform(size=n) < 0.3] = np.nan
    return Poses2D(rng.integers(1, 50, n), rng.integers(0, len(cams), n), rng.integers(-1, 4, n), kp, bbox, sk, cams)


@pytest.mark.parametrize("sk", [COCO17, BODY25, HALPE26, custom_skeleton(["head", "neck", "left_hand"])],
                         ids=lambda s: s.name)
def test_write_read_round_trip(tmp_path, sk):
    p = _random_poses(np.random.default_rng(3), 30, sk)
    paths = write_keypoints(tmp_path, p)
    assert [x.name for x in paths] == ["cam1.json", "cam2.json"]
    doc = json.loads(paths[0].read_text())
    assert ("skeleton" in doc) == (sk.name != "custom")
    q = read_keypoints(tmp_path, CAMS)
    s = p.sorted()
    assert q.skeleton == sk and len(q) == len(p)
    assert np.array_equal(q.frame, s.frame) and np.array_equal(q.camera, s.camera)
    assert np.array_equal(q.track_id, s.track_id)
    assert np.array_equal(np.isnan(q.bbox), np.isnan(s.bbox))
    assert np.allclose(q.bbox, s.bbox, atol=0.006, equal_nan=True)
    assert np.array_equal(q.found(), s.found())
    f = s.found()
    assert np.allclose(q.keypoints[f][:, :2], s.keypoints[f][:, :2], atol=0.006)
    assert np.allclose(q.keypoints[f][:, 2], s.keypoints[f][:, 2], rtol=1e-3)
    assert (~q.found()).all(axis=1).sum() >= 1  # the all-missing pose survives


def test_native_details(tmp_path):
    doc = {"skeleton": "coco17", "poses": [
        {"frame": 12, "keypoints": [[1.5, 2, 0.9]] * 16 + [[None, None, 0.7]], "bbox": [0, 1, 20, 30], "track_id": 3},
        {"frame": 11.0, "keypoints": [[0, 0, 0]] * 17, "bbox": None}]}
    (tmp_path / "a.json").write_text(json.dumps(doc))
    p = read_keypoints_file(tmp_path / "a.json", 1, ("x", "a"))
    assert p.frame.tolist() == [12, 11] and p.camera.tolist() == [1, 1] and p.track_id.tolist() == [3, -1]
    assert p.keypoints[0, 16, 2] == 0 and np.isnan(p.keypoints[0, 16, 0])  # null x/y: not found, score 0
    assert p.bbox[0].tolist() == [0, 1, 20, 30] and np.isnan(p.bbox[1]).all()
    assert p.found()[0].sum() == 16 and p.found()[1].sum() == 0
    # a joint list equal to a known skeleton is that skeleton
    (tmp_path / "b.json").write_text(json.dumps({"joints": list(COCO17.joints), "poses": doc["poses"]}))
    assert read_keypoints_file(tmp_path / "b.json", 0, ("b",)).skeleton is COCO17


def test_coco_results_infer_or_take_the_skeleton(tmp_path):
    rng = np.random.default_rng(0)
    for J, sk, named in ((17, COCO17, None), (25, BODY25, "body25"), (26, HALPE26, None)):
        flat = rng.uniform(0, 100, 3 * J).round(2).tolist()
        (tmp_path / "c.json").write_text(json.dumps([{"image_id": 7, "category_id": 1, "keypoints": flat,
                                                      "score": 0.8, "bbox": [1, 2, 3, 4]}] * 2))
        p = read_keypoints_file(tmp_path / "c.json", 0, ("c",), skeleton=named)
        assert p.skeleton is sk and len(p) == 2 and np.allclose(p.keypoints[1].ravel(), flat)
        assert p.bbox[0].tolist() == [1, 2, 3, 4] and p.frame.tolist() == [7, 7]
    # 25 joints are BODY_25 or BODY_25B: two poses of random joints cannot tell which
    (tmp_path / "c.json").write_text(json.dumps([{"image_id": 7, "keypoints": [1, 2, 1] * 25}]))
    with pytest.raises(InputError, match=r"c.json: field '\[0\].keypoints': 25 joints per pose fit several skeletons"
                                         r".*say which with --skeleton"):
        read_keypoints_file(tmp_path / "c.json", 0, ("c",))
    (tmp_path / "c.json").write_text(json.dumps([{"image_id": 7, "keypoints": [1, 2, 1] * 5}]))
    with pytest.raises(InputError, match=r"c.json: field '\[0\].keypoints': 5 joints per pose: no known skeleton"):
        read_keypoints_file(tmp_path / "c.json", 0, ("c",))
    p = read_keypoints_file(tmp_path / "c.json", 0, ("c",), skeleton=custom_skeleton(["a", "b", "c", "d", "e"]))
    assert p.keypoints.shape == (1, 5, 3)
    with pytest.raises(InputError, match="17 joints, expected 25"):
        (tmp_path / "d.json").write_text(json.dumps([{"image_id": 1, "keypoints": [1, 2, 1] * 17}]))
        read_keypoints_file(tmp_path / "d.json", 0, ("d",), skeleton="body25")


def _openpose(folder: Path, frames, people_per_frame=2, n_values=75):
    folder.mkdir(parents=True)
    rng = np.random.default_rng(1)
    for f in frames:
        people = [{"person_id": [-1], "pose_keypoints_2d": rng.uniform(0, 1, n_values).tolist(),
                   "face_keypoints_2d": []} for _ in range(people_per_frame)]
        (folder / f"routine_{f:012d}_keypoints.json").write_text(json.dumps({"version": 1.3, "people": people}))


def test_openpose_folder_and_skeletons_must_agree(tmp_path):
    _openpose(tmp_path / "kp" / "cam1", [3, 1, 2])
    (tmp_path / "kp" / "cam2.json").write_text(json.dumps({"skeleton": "body25", "poses": [
        {"frame": 2, "keypoints": [[1, 1, 1]] * 25}]}))
    p = read_keypoints(tmp_path / "kp", CAMS)
    assert p.skeleton is BODY25 and len(p) == 7
    assert p.frame.tolist() == [1, 1, 2, 2, 2, 3, 3] and p.camera.tolist() == [0, 0, 0, 0, 1, 0, 0]
    assert np.isnan(p.bbox[p.camera == 0]).all()
    # an empty COCO list names no skeleton; random 25-joint poses do not tell BODY_25 from BODY_25B
    (tmp_path / "kp" / "cam2.json").write_text("[]")
    with pytest.raises(InputError, match="25 joints per pose fit several skeletons"):
        read_keypoints(tmp_path / "kp", CAMS)
    assert read_keypoints(tmp_path / "kp", CAMS, skeleton="BODY_25").skeleton is BODY25
    (tmp_path / "kp" / "cam2.json").write_text(json.dumps({"skeleton": "coco17", "poses": []}))
    with pytest.raises(InputError, match=r"cam1/routine_000000000001_keypoints.json: field 'people\[0\]"
                                         r".pose_keypoints_2d': 25 joints, expected 17 \(coco17\)"):
        read_keypoints(tmp_path / "kp", CAMS)


def test_folder_errors(tmp_path):
    _openpose(tmp_path / "kp" / "cam1", [1], n_values=54)  # OpenPose's COCO-18 model
    (tmp_path / "kp" / "cam2.json").write_text("[]")
    assert read_keypoints(tmp_path / "kp", CAMS).skeleton.name == "coco18"
    with pytest.raises(InputError, match=r"cam1/routine_000000000001_keypoints.json: field 'people\[0\]"
                                         r".pose_keypoints_2d': 18 joints, expected 25 \(body25\)"):
        read_keypoints(tmp_path / "kp", CAMS, skeleton="body25")
    with pytest.raises(InputError, match="no keypoints for camera 'cam3'"):
        read_keypoints(tmp_path / "kp", CAMS + ("cam3",))
    (tmp_path / "kp" / "cam1" / "notes.txt").write_text("x")
    with pytest.raises(InputError, match="notes.txt: not a JSON file"):
        read_keypoints_file(tmp_path / "kp" / "cam1", 0, CAMS)
    (tmp_path / "kp" / "cam9.json").write_text("[]")
    with pytest.raises(InputError, match="cam9.json: names no camera"):
        read_keypoints(tmp_path / "kp", CAMS)
    (tmp_path / "kp" / "cam1.json").write_text("[]")
    with pytest.raises(InputError, match="camera 'cam1' has both cam1 and cam1.json; keep one"):
        read_keypoints(tmp_path / "kp", CAMS)


@pytest.mark.parametrize("poses, field, message", [
    ([{"frame": 1, "keypoints": [[1, 2, 1]] * 16}], "poses[0].keypoints", "must hold 17 joints"),
    ([{"frame": 1.5, "keypoints": [[1, 2, 1]] * 17}], "poses[0].frame", "must be an integer"),
    ([{"frame": "1", "keypoints": [[1, 2, 1]] * 17}], "poses[0].frame", "must be an integer"),
    ([{"keypoints": [[1, 2, 1]] * 17}], "poses[0].frame", "missing"),
    ([{"frame": 1, "keypoints": [[1, 2, -0.1]] * 17}], "poses[0].keypoints", "joint 0 score must be a finite"),
    ([{"frame": 1, "keypoints": [[1, "2", 1]] * 17}], "poses[0].keypoints", "joint 0 y must be a number"),
    ([{"frame": 1, "keypoints": [[1, 2]] * 17}], "poses[0].keypoints[0]", "must be [x, y, score]"),
    ([{"frame": 1, "keypoints": [[1, 2, 1]] * 17, "bbox": [1, 2, 3]}], "poses[0].bbox", "4 numbers"),
    ([{"frame": 1, "keypoints": [[1, 2, 1]] * 17, "track_id": -2}], "poses[0].track_id", "must be in [-1"),
])
def test_native_errors_name_file_pose_and_field(tmp_path, poses, field, message):
    path = tmp_path / "cam1.json"
    path.write_text(json.dumps({"skeleton": "coco17", "poses": poses}))
    with pytest.raises(InputError) as e:
        read_keypoints_file(path, 0, CAMS)
    assert e.value.source == str(path) and e.value.field == field and message in e.value.problem


def test_unknown_skeleton_and_bad_json(tmp_path):
    path = tmp_path / "cam1.json"
    path.write_text(json.dumps({"skeleton": "coco19", "poses": []}))
    with pytest.raises(InputError, match=r"cam1.json: field 'skeleton': unknown skeleton 'coco19'"):
        read_keypoints_file(path, 0, CAMS)
    path.write_text('{"skeleton": "coco17",\n "poses": [}')
    with pytest.raises(InputError, match=r"cam1.json: line 2: not valid JSON"):
        read_keypoints_file(path, 0, CAMS)


# ------------------------------------------------------------------------- mutation property test
VALID_NATIVE = {"skeleton": "coco17", "poses": [
    {"frame": 3, "keypoints": [[10.0 + j, 20.0, 0.5] for j in range(17)], "bbox": [1, 2, 30, 40], "track_id": 2},
    {"frame": 4, "keypoints": [[None, None, 0]] * 17}]}
VALID_COCO = [{"image_id": 5, "category_id": 1, "keypoints": [1.0, 2.0, 0.3] * 17, "score": 0.9, "bbox": [0, 0, 5, 5]}]
VALID_OPENPOSE = {"version": 1.3, "people": [{"person_id": [-1], "pose_keypoints_2d": [5.0, 6.0, 0.7] * 25}]}

json_values = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20), st.text(max_size=4),
              st.floats(allow_nan=True, allow_infinity=True)),
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=3), inner, max_size=3)),
    max_leaves=6)


@st.composite
def mutated(draw, base):
    """A mutated document as JSON text, sometimes cut short."""
    doc = draw(mutated_doc(base, json_values))
    text = json.dumps(doc)
    if draw(st.integers(0, 9)) == 0:
        text = text[: draw(st.integers(0, len(text)))]
    return text


def _check(path: Path, read):
    try:
        p = read()
    except InputError as e:
        assert e.source is not None and Path(e.source) == path
        # the place is named, unless the whole document is of the wrong kind
        assert e.field is not None or e.line is not None or e.problem.startswith("must be a native")
        return
    assert isinstance(p, Poses2D)
    assert p.keypoints.shape[1:] == (len(p.skeleton.joints), 3) and p.frame.dtype == np.int64
    assert not np.isinf(p.keypoints).any() and (p.keypoints[..., 2] >= 0).all()


SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                           HealthCheck.function_scoped_fixture])


@SETTINGS
@given(text=mutated(VALID_NATIVE))
def test_mutated_native_file_reads_or_names_the_problem(tmp_path, text):
    path = tmp_path / "cam1.json"
    path.write_text(text)
    _check(path, lambda: read_keypoints_file(path, 0, CAMS))


@SETTINGS
@given(text=mutated(VALID_COCO))
def test_mutated_coco_file_reads_or_names_the_problem(tmp_path, text):
    path = tmp_path / "cam1.json"
    path.write_text(text)
    _check(path, lambda: read_keypoints_file(path, 0, CAMS))


@SETTINGS
@given(text=mutated(VALID_OPENPOSE))
def test_mutated_openpose_file_reads_or_names_the_problem(tmp_path, text):
    folder = tmp_path / "cam1"
    folder.mkdir(exist_ok=True)
    path = folder / "x_000000000007_keypoints.json"
    path.write_text(text)
    _check(path, lambda: read_keypoints_file(folder, 0, CAMS))
