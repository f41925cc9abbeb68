"""Property tests for the readers of whole files: scene.yaml, the ground
truth (persons_3d.csv, keypoints_3d.csv), poses_3d.csv, the tracker's outputs (tracks_3d.csv,
target_3d.csv), and the Panoptic and EasyMocap calibrations.

Each starts from a valid file and mutates it (a cell replaced by junk, a cell or line dropped or
doubled, the header changed, the text cut short; a YAML/JSON value replaced, removed or added).
Whatever comes out, the reader either parses it -- and the result holds what the format promises
-- or raises the project's :class:`~gymtrack.errors.InputError` naming the file and a line or
field; never another exception. (WILDTRACK calibration XML too. MOTChallenge files, the native and aniposelib calibrations:
``test_parsers_hypothesis.py``; 2D keypoint files: ``test_keypoints_formats.py``.)
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gymtrack.errors import InputError
from gymtrack.formats.calibration import read_easymocap, read_panoptic, read_wildtrack_calibration
from gymtrack.formats.gt_keypoints import read_keypoints_3d
from gymtrack.formats.ground_truth import read_persons_3d
from gymtrack.formats.outputs import read_target_3d, read_tracks_3d
from gymtrack.formats.poses3d import read_poses_3d, write_poses_3d
from gymtrack.formats.scene import load_scene
from gymtrack.geometry import Rig
from gymtrack.poses import Poses3D
from gymtrack.scene import Scene
from gymtrack.skeletons import COCO17
from mutation import mutated_doc as mutated

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "balance_beam"


@pytest.fixture(scope="module")
def tmp(tmp_path_factory) -> Path:
    """One folder for the module (hypothesis runs many examples per test function)."""
    return tmp_path_factory.mktemp("files")


def _expect_located(path: Path, read):
    """Run ``read``; an InputError must name ``path`` and a line or field. Returns the result or None."""
    try:
        return read()
    except InputError as e:
        assert e.source is not None and Path(e.source) == path, (e.source, str(e))
        assert e.line is not None or e.field is not None, str(e)
        assert e.line is None or e.line >= 1
        return None


# ============================================================================ CSV files
junk = st.one_of(
    st.sampled_from(["", " ", "nan", "inf", "-inf", "1e400", "-1", "0", "2.5", "x", "1,2", '"', "1e9", "nose", "-0"]),
    st.text(alphabet=" ,.-+eE0123456789abxyz_\"\t", max_size=6),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**20, 10**20).map(str),
)


@st.composite
def mutated_csv(draw, text: str):
    """``text`` (a header and rows) with 1-3 mutations of cells, lines or the end."""
    lines = text.splitlines()
    for _ in range(draw(st.integers(1, 3))):
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        cells = lines[i].split(",")
        what = draw(st.sampled_from(["cell", "cell", "cell", "drop cell", "add cell", "drop line", "double line",
                                     "blank line", "swap lines"]))
        if what == "cell":
            cells[draw(st.integers(0, len(cells) - 1))] = draw(junk)
        elif what == "drop cell":
            del cells[draw(st.integers(0, len(cells) - 1))]
        elif what == "add cell":
            cells.insert(draw(st.integers(0, len(cells))), draw(junk))
        elif what == "drop line":
            del lines[i]
            continue
        elif what == "double line":
            lines.insert(i, lines[i])
            continue
        elif what == "blank line":
            lines.insert(i, draw(st.sampled_from(["", "  ", ","])))
            continue
        else:
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
            continue
        lines[i] = ",".join(cells)
    out = "\n".join(lines) + draw(st.sampled_from(["\n", "", "\r\n"]))
    if draw(st.integers(0, 9)) == 0:
        out = out[: draw(st.integers(0, len(out)))]
    return out


def _head(path: Path, n: int) -> str:
    return "\n".join(path.read_text().splitlines()[:n]) + "\n"


PERSONS = _head(EXAMPLE / "gt" / "persons_3d.csv", 12)
KEYPOINTS = _head(EXAMPLE / "gt" / "keypoints_3d.csv", 1 + 3 * 17)  # 3 persons' COCO-17 joints


@SETTINGS
@given(text=mutated_csv(PERSONS))
def test_mutated_persons_3d(tmp, text):
    p = tmp / "persons_3d.csv"
    p.write_text(text)
    d = _expect_located(p, lambda: read_persons_3d(p))
    if d is not None:
        n = len(d["frame"])
        assert d["xyz"].shape == (n, 3) and d["frame"].dtype.kind == "i" and d["person_id"].dtype.kind == "i"
        assert len(d["role"]) == n


@SETTINGS
@given(text=mutated_csv(KEYPOINTS))
def test_mutated_keypoints_3d(tmp, text):
    p = tmp / "keypoints_3d.csv"
    p.write_text(text)
    out = _expect_located(p, lambda: read_keypoints_3d(p))
    if out is not None:
        frames, pid, joints = out
        assert joints.shape == (len(pid), len(frames), 17, 3)
        assert np.all(np.diff(frames) > 0) and np.all(np.diff(pid) > 0)
        assert not np.isinf(joints).any()


def _poses3d_text(tmp_factory_path: Path) -> str:
    rng = np.random.default_rng(0)
    M, J = 3, len(COCO17.joints)
    how = rng.integers(0, 3, size=(M, J)).astype(np.int8)
    xyz = rng.normal(size=(M, J, 3))
    xyz[how == 0] = np.nan
    poses = Poses3D(np.array([1, 1, 2]), np.array([0, 3, 0]), xyz, rng.uniform(0, 1, (M, J)),
                    np.where(how > 0, 2, 0).astype(np.int64), np.where(how > 0, 1.5, np.nan), how, COCO17)
    p = write_poses_3d(tmp_factory_path / "poses_3d.csv", poses)
    text = p.read_text()
    return "\n".join(text.splitlines()[: 1 + 2 * J]) + "\n"  # two poses: mutations stay close to them


@pytest.fixture(scope="module")
def poses3d_text(tmp_path_factory) -> str:
    return _poses3d_text(tmp_path_factory.mktemp("poses3d"))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                 HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_mutated_poses_3d(tmp, poses3d_text, data):
    p = tmp / "poses_3d.csv"
    p.write_text(data.draw(mutated_csv(poses3d_text)))
    out = _expect_located(p, lambda: read_poses_3d(p))
    if out is not None:
        assert isinstance(out, Poses3D)
        assert out.xyz.shape == (len(out.frame), len(out.skeleton.joints), 3)


TRACKS = ("frame,track_id,x,y,z,top_z,bottom_z,source,n_views\n"
          "1,0,3.5489,0.6747,0.7819,1.6037,-0.0614,triangulation,4\n"
          "1,1,2.5716,-0.1561,0.8442,1.6849,-0.0083,plane,1\n"
          "2,0,3.5500,0.6700,0.7800,1.6000,-0.0600,interpolated,0\n"
          "3,1,2.5530,-0.1401,0.8331,nan,nan,triangulation,3\n")
TARGET = ("frame,track_id,x,y,z,source\n"
          "1,0,3.5489,0.6747,0.7819,triangulation\n"
          "2,0,3.5500,0.6700,0.7800,interpolated\n"
          "3,0,3.5530,0.6401,0.8331,plane\n")


@SETTINGS
@given(text=mutated_csv(TRACKS))
def test_mutated_tracks_3d(tmp, text):
    p = tmp / "tracks_3d.csv"
    p.write_text(text)
    d = _expect_located(p, lambda: read_tracks_3d(p))
    if d is not None:
        assert d["xyz"].shape == (len(d["frame"]), 3)
        assert set(d["source"]) <= {"triangulation", "plane", "interpolated"}


@SETTINGS
@given(text=mutated_csv(TARGET))
def test_mutated_target_3d(tmp, text):
    p = tmp / "target_3d.csv"
    p.write_text(text)
    d = _expect_located(p, lambda: read_target_3d(p))
    if d is not None:
        assert d["xyz"].shape == (len(d["frame"]), 3)


# ============================================================================ structured files
json_values = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12), st.floats(allow_nan=False, allow_infinity=False),
              st.text(max_size=5), st.sampled_from(["m", "mm", "balance_beam", "nan", ""])),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=3),
    max_leaves=10,
)


def mutated_doc(base):
    """``base`` (JSON-like) with 1-3 values replaced, removed or appended to (:mod:`mutation`)."""
    return mutated(base, json_values)


SCENE = yaml.safe_load((EXAMPLE / "scene.yaml").read_text())


@SETTINGS
@given(doc=mutated_doc(SCENE), cut=st.integers(0, 20))
def test_mutated_scene_yaml(tmp, doc, cut):
    p = tmp / "scene.yaml"
    text = yaml.safe_dump(doc)
    p.write_text(text[: len(text) * cut // 10] if cut < 10 else text)  # sometimes cut short
    try:
        scene = load_scene(p)
    except InputError as e:
        assert e.source is not None and Path(e.source) == p, str(e)
        return
    assert isinstance(scene, Scene)
    assert np.all(np.isfinite(np.asarray(scene.performance_space, float)))


def _panoptic_doc() -> dict:
    R = [[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]
    cam = {"name": "00_00", "type": "hd", "resolution": [1920, 1080],
           "K": [[1400.0, 0, 960], [0, 1400.0, 540], [0, 0, 1]], "distCoef": [0.0, 0.0, 0.0, 0.0, 0.0],
           "R": R, "t": [[0.0], [100.0], [500.0]]}
    return {"calibDataSource": "x", "cameras": [cam, dict(cam, name="00_01", t=[[50.0], [100.0], [500.0]])]}


@SETTINGS
@given(doc=mutated_doc(_panoptic_doc()))
def test_mutated_panoptic_calibration(tmp, doc):
    p = tmp / "calibration_x.json"
    p.write_text(json.dumps(doc))
    try:
        rig = read_panoptic(p)
    except InputError as e:
        assert e.source is not None and Path(e.source) == p, str(e)
        return
    assert isinstance(rig, Rig) and len(rig) >= 1


def _fs_mat(key: str, a: np.ndarray) -> str:
    a = np.atleast_2d(np.asarray(a, dtype=np.float64))
    data = ", ".join(repr(float(v)) for v in a.ravel())
    return f"{key}: !!opencv-matrix\n   rows: {a.shape[0]}\n   cols: {a.shape[1]}\n   dt: d\n   data: [ {data} ]\n"


EASYMOCAP_INTRI = ("%YAML:1.0\n---\nnames:\n   - \"c0\"\n   - \"c1\"\n"
                   + _fs_mat("K_c0", [[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]]) + _fs_mat("dist_c0", np.zeros((1, 5)))
                   + _fs_mat("K_c1", [[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]]) + _fs_mat("dist_c1", np.zeros((1, 5)))
                   + "H_c0: 480\nW_c0: 640\nH_c1: 480\nW_c1: 640\n")
EASYMOCAP_EXTRI = ("%YAML:1.0\n---\nnames:\n   - \"c0\"\n   - \"c1\"\n"
                   + _fs_mat("R_c0", [[1.5708], [0.0], [0.0]]) + _fs_mat("T_c0", [[0.0], [1.0], [5.0]])
                   + _fs_mat("R_c1", [[1.5708], [0.0], [0.0]]) + _fs_mat("T_c1", [[1.0], [1.0], [5.0]]))


@st.composite
def mutated_filestorage(draw, text: str):
    """An OpenCV FileStorage text with a token replaced, a line dropped or the text cut short."""
    lines = text.splitlines()
    for _ in range(draw(st.integers(1, 2))):
        i = draw(st.integers(2, len(lines) - 1))
        what = draw(st.sampled_from(["number", "number", "drop line", "cut"]))
        if what == "number":
            toks = lines[i].split(" ")
            k = draw(st.integers(0, len(toks) - 1))
            toks[k] = draw(st.sampled_from(["nan", "1e400", "-1", "0", "x", "", "[", "]", "3", "2.5", "c9", "\"c0\""]))
            lines[i] = " ".join(toks)
        elif what == "drop line":
            del lines[i]
        else:
            lines = lines[:i]
            break
    return "\n".join(lines) + "\n"


@pytest.mark.filterwarnings("ignore:.*guessed as twice the principal point")  # a mutation dropped W_/H_: said, fine
@SETTINGS
@given(intri=st.one_of(st.just(EASYMOCAP_INTRI), mutated_filestorage(EASYMOCAP_INTRI)),
       extri=st.one_of(st.just(EASYMOCAP_EXTRI), mutated_filestorage(EASYMOCAP_EXTRI)))
def test_mutated_easymocap_calibration(tmp, intri, extri):
    (tmp / "intri.yml").write_text(intri)
    (tmp / "extri.yml").write_text(extri)
    try:
        rig = read_easymocap(tmp / "intri.yml")
    except InputError as e:
        assert e.source is not None and Path(e.source).name in ("intri.yml", "extri.yml"), str(e)
        return
    assert isinstance(rig, Rig) and len(rig) >= 1


WILDTRACK_EXTR = """<?xml version="1.0"?>
<opencv_storage>
  <rvec>
    1.759099006652832 0.46710100769996643 -0.331699013710022
   </rvec>
  <tvec>
    -525.8941650390625 45.40763473510742 986.7235107421875
  </tvec>
</opencv_storage>
"""
WILDTRACK_INTR = """<?xml version="1.0"?>
<opencv_storage>
<camera_matrix type_id="opencv-matrix">
  <rows>3</rows>
  <cols>3</cols>
  <dt>d</dt>
  <data>1743.4478759765625 0.0 934.5202026367188 0.0 1735.1566162109375 444.3987731933594 0.0 0.0 1.0</data></camera_matrix>
<distortion_coefficients type_id="opencv-matrix">
  <rows>5</rows>
  <cols>1</cols>
  <dt>d</dt>
  <data>
    0 0
    0 0
    0</data></distortion_coefficients>
</opencv_storage>
"""


def _wildtrack_folder(root: Path, extr: str, intr: str) -> Path:
    (root / "extrinsic").mkdir(parents=True, exist_ok=True)
    (root / "intrinsic_zero").mkdir(exist_ok=True)
    (root / "intrinsic_original").mkdir(exist_ok=True)
    (root / "extrinsic" / "extr_CVLab1.xml").write_text(extr)
    for sub in ("intrinsic_zero", "intrinsic_original"):
        (root / sub / "intr_CVLab1.xml").write_text(intr)
    return root


@SETTINGS
@given(extr=st.one_of(st.just(WILDTRACK_EXTR), mutated_filestorage(WILDTRACK_EXTR)),
       intr=st.one_of(st.just(WILDTRACK_INTR), mutated_filestorage(WILDTRACK_INTR)),
       which=st.sampled_from(["zero", "original"]))
def test_mutated_wildtrack_calibration(tmp, extr, intr, which):
    root = _wildtrack_folder(tmp / "calibrations", extr, intr)
    try:
        rig = read_wildtrack_calibration(root, intrinsics=which)
    except InputError as e:
        assert e.source is not None and (Path(e.source) == root or Path(e.source).name in
                                          ("extr_CVLab1.xml", "intr_CVLab1.xml")), str(e)
        return
    assert isinstance(rig, Rig) and len(rig) == 1


def test_the_unmutated_files_parse(tmp, poses3d_text):
    """The starting points are valid: a failure above is the mutation's, not the base's."""
    for name, text, read in (("persons_3d.csv", PERSONS, read_persons_3d), ("keypoints_3d.csv", KEYPOINTS, read_keypoints_3d),
                             ("poses_3d.csv", poses3d_text, read_poses_3d), ("tracks_3d.csv", TRACKS, read_tracks_3d),
                             ("target_3d.csv", TARGET, read_target_3d)):
        p = tmp / name
        p.write_text(text)
        assert read(p) is not None
    (tmp / "calibration_x.json").write_text(json.dumps(_panoptic_doc()))
    assert len(read_panoptic(tmp / "calibration_x.json")) == 2
    (tmp / "intri.yml").write_text(EASYMOCAP_INTRI)
    (tmp / "extri.yml").write_text(EASYMOCAP_EXTRI)
    assert len(read_easymocap(tmp / "intri.yml")) == 2
    assert len(read_wildtrack_calibration(_wildtrack_folder(tmp / "calibrations", WILDTRACK_EXTR, WILDTRACK_INTR),
                                          intrinsics="original")) == 1
    (tmp / "scene.yaml").write_text(yaml.safe_dump(SCENE))
    assert isinstance(load_scene(tmp / "scene.yaml"), Scene)
