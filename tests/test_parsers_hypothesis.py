"""Property tests: whatever a user hands in, the parsers either read it or raise an InputError
subclass naming the place; never a bare ValueError / KeyError / TypeError / IndexError from deep
inside numpy, yaml or OpenCV."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gymtrack.errors import CalibrationError, DetectionFormatError, InputError
from gymtrack.formats.calibration import native_from_dict, read_anipose, read_easymocap, read_native, read_panoptic
from gymtrack.formats.motchallenge import read_detections, read_gt_boxes
from gymtrack.geometry import Rig

SETTINGS = settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@pytest.fixture(scope="module")
def tmp(tmp_path_factory) -> Path:
    """One folder for the whole module (hypothesis runs many examples per test function)."""
    return tmp_path_factory.mktemp("parsers")

# ============================================================================ MOTChallenge
numbers = st.one_of(
    st.integers(-5, 3000).map(str),
    st.floats(allow_nan=True, allow_infinity=True, width=32).map(repr),
    st.sampled_from(["-1", "0", "1", "0.5", "nan", "inf", "-inf", "1e400", "1e-9"]),
)
junk = st.one_of(st.text(alphabet=" ,.-+eE0123456789abcxyz\t", max_size=6), st.just(""))
token = st.one_of(numbers, numbers, numbers, junk)


@st.composite
def mot_lines(draw):
    """Lines that are mostly well-formed, each with a chance of one corruption."""
    lines = []
    file_ncol = draw(st.sampled_from([6, 7, 10, 10, 10, draw(st.integers(0, 12))]))
    for _ in range(draw(st.integers(0, 8))):
        ncol = file_ncol if draw(st.integers(0, 9)) else draw(st.integers(0, 12))
        cells = [str(draw(st.integers(0, 50))), "-1", *[str(draw(st.floats(-50, 2000, allow_nan=False))) for _ in range(2)],
                 *[str(draw(st.floats(0.5, 400))) for _ in range(2)], "0.9", "-1", "-1", "-1"][:ncol]
        cells += ["1"] * (ncol - len(cells))
        if cells and draw(st.integers(0, 3)) == 0:
            cells[draw(st.integers(0, len(cells) - 1))] = draw(token)
        sep = draw(st.sampled_from([",", ", ", " ,"]))
        lines.append(sep.join(cells))
        if draw(st.integers(0, 9)) == 0:
            lines.append(draw(st.sampled_from(["", "   ", "\t"])))
    return "\n".join(lines) + draw(st.sampled_from(["", "\n", "\r\n"]))


def _check_mot(tmp: Path, text: str, reader) -> None:
    p = tmp / "mot.txt"
    p.write_text(text)
    try:
        out = reader(p)
    except InputError as exc:
        assert isinstance(exc, DetectionFormatError)
        assert str(p) in str(exc)
        assert exc.line is None or exc.line >= 1
        return
    det, report = out[0], out[-1]
    n_lines = sum(1 for s in text.splitlines() if s.strip())
    assert len(det) == report.boxes == report.lines == n_lines
    assert np.all(np.isfinite(det.box)) and np.all(det.box[:, 2:] > 0)
    assert np.all(np.diff(det.frame) >= 0) and np.all(det.frame >= 0)


@SETTINGS
@given(text=mot_lines())
def test_random_mot_detection_files(tmp, text):
    _check_mot(tmp, text, read_detections)


@SETTINGS
@given(text=mot_lines())
def test_random_mot_gt_files(tmp, text):
    _check_mot(tmp, text, read_gt_boxes)


@SETTINGS
@given(text=st.text(max_size=200))
def test_arbitrary_text_as_mot(tmp, text):
    _check_mot(tmp, text, read_detections)


# ============================================================================ calibration structures
CAM_KEYS = ["name", "size", "K", "dist", "R", "rvec", "t"]
scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-10**30, 10**30), st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=4), st.sampled_from(["m", "cm", "mm", "nan"]),
)
values = st.recursive(
    scalars,
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.sampled_from(CAM_KEYS + ["units", "cameras", "x"]), children, max_size=4),
    max_leaves=20,
)


def _valid_dict() -> dict:
    R = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # looks along +y
    cam = {"name": "c0", "size": [640, 480], "K": [[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]], "dist": [0.0, 0, 0, 0, 0],
           "R": R.tolist(), "t": [0.0, 1.0, 5.0]}
    return {"units": "m", "cameras": [cam, dict(cam, name="c1", t=[1.0, 1.0, 5.0])]}


def _check_native(data) -> None:
    try:
        rig = native_from_dict(data, source="cameras.yaml")
    except InputError as exc:
        assert isinstance(exc, CalibrationError)
        assert str(exc).startswith("cameras.yaml")
        return
    assert isinstance(rig, Rig) and len(rig) >= 1


@SETTINGS
@given(values)
def test_random_structures_as_native_calibration(data):
    _check_native(data)


@st.composite
def mutated_native(draw):
    d = _valid_dict()
    where = draw(st.sampled_from(["top", "camera", "element"]))
    if where == "top":
        key = draw(st.sampled_from(["units", "cameras", "extra"]))
        if draw(st.booleans()):
            d.pop(key, None)
        else:
            d[key] = draw(values)
    else:
        cam = d["cameras"][draw(st.integers(0, 1))]
        key = draw(st.sampled_from(CAM_KEYS))
        if where == "camera":
            if draw(st.booleans()):
                cam.pop(key, None)
            else:
                cam[key] = draw(values)
        elif isinstance(cam.get(key), list):
            seq = cam[key]
            i = draw(st.integers(0, len(seq) - 1))
            seq[i] = draw(values)
    return d


@SETTINGS
@given(data=mutated_native())
def test_mutated_native_calibration(tmp, data):
    _check_native(data)
    # the same structure through the YAML and JSON readers
    p = tmp / "cameras.yaml"
    try:
        p.write_text(yaml.safe_dump(data))
    except yaml.YAMLError:  # pragma: no cover - safe_dump handles every value drawn here
        return
    try:
        read_native(p)
    except InputError as exc:
        assert isinstance(exc, CalibrationError) and str(p) in str(exc)
    pj = tmp / "cameras.json"
    pj.write_text(json.dumps(data))  # NaN/Infinity become JSON extensions Python reads back
    try:
        read_native(pj)
    except InputError as exc:
        assert isinstance(exc, CalibrationError) and str(pj) in str(exc)


@SETTINGS
@given(text=st.text(max_size=300))
def test_arbitrary_text_as_calibration_files(tmp, text):
    for name, reader in (("cameras.yaml", read_native), ("cameras.json", read_native), ("calibration.toml", read_anipose),
                         ("calibration_x.json", read_panoptic)):
        p = tmp / name
        p.write_text(text)
        with pytest.raises(CalibrationError):
            reader(p)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if v != v else ("inf" if v > 0 else "-inf")
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v if x is not None) + "]"
    return '"?"'


@SETTINGS
@given(key=st.sampled_from(["name", "size", "matrix", "distortions", "rotation", "translation", "fisheye"]), value=values)
def test_mutated_anipose_toml(tmp, key, value):
    base = {"name": "a", "size": [640, 480], "matrix": [[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]],
            "distortions": [0.0, 0, 0, 0, 0], "rotation": [0.0, 0.1, 0.0], "translation": [0.0, 0.0, 5.0]}
    if isinstance(value, dict) or value is None:
        base.pop(key, None)
    else:
        base[key] = value
    text = "[cam_0]\n" + "".join(f"{k} = {_toml_value(v)}\n" for k, v in base.items())
    p = tmp / "calibration.toml"
    p.write_text(text)
    try:
        read_anipose(p)
    except InputError as exc:
        assert isinstance(exc, CalibrationError) and str(p) in str(exc)


@SETTINGS
@given(text=st.text(alphabet="%YAML:1.0-\n names:[]\"K_aRTdist!opencv-matrix0123456789.,{}", max_size=200))
def test_arbitrary_text_as_easymocap(tmp, text):
    intri, extri = tmp / "intri.yml", tmp / "extri.yml"
    intri.write_text(text)
    extri.write_text(text)
    try:
        read_easymocap(intri, size=(640, 480))
    except InputError as exc:
        assert isinstance(exc, CalibrationError)
