"""Calibration readers: each format written in the test from known random cameras, read back,
and compared with the originals (parameters and projections); bad input names file and field."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from gymtrack.errors import CalibrationError, InputError
from gymtrack.formats.calibration import (
    PANOPTIC_TO_ZUP,
    detect_format,
    load_calibration,
    native_to_dict,
    read_anipose,
    read_calibration,
    read_easymocap,
    read_native,
    read_panoptic,
    write_native,
)
from gymtrack.geometry import Camera, Rig


def assert_same_cameras(a: Rig, b: Rig, pts: np.ndarray, atol_t: float = 1e-9, atol_px: float = 1e-6) -> None:
    """Same names, parameters and projections of ``pts`` (N, 3)."""
    assert a.names == b.names
    for ca, cb in zip(a, b):
        assert ca.size == cb.size
        np.testing.assert_allclose(cb.K, ca.K, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(cb.R, ca.R, atol=1e-9)
        np.testing.assert_allclose(cb.t, ca.t, atol=atol_t)
        np.testing.assert_allclose(cb.dist[: ca.dist.size], ca.dist, atol=1e-12)
        np.testing.assert_allclose(cb.project(pts), ca.project(pts), atol=atol_px)


def opencv_project(cam: Camera, X: np.ndarray) -> np.ndarray:
    uv, _ = cv2.projectPoints(X.reshape(-1, 1, 3), cam.rvec, cam.t, cam.K, cam.dist)
    return uv.reshape(-1, 2)


# ============================================================================ native
def test_native_yaml_round_trip_is_exact(tmp_path, rng, make_rig, make_points):
    rig = make_rig(rng, 4, distortion=5)
    p = write_native(rig, tmp_path / "cameras.yaml")
    back = read_native(p)
    X = make_points(rng, rig, 50)
    assert_same_cameras(rig, back, X, atol_t=0, atol_px=0)
    for c in back:  # and what we read projects like OpenCV does
        np.testing.assert_allclose(c.project(X), opencv_project(c, X), atol=1e-6)
    text = p.read_text()
    assert text.startswith("units: m")
    assert yaml.safe_load(text)["cameras"][0]["size"] == [1920, 1080]


def test_native_json_round_trip(tmp_path, rng, make_rig, make_points):
    rig = make_rig(rng, 3, distortion=8)
    back = load_calibration(write_native(rig, tmp_path / "cameras.json"))
    assert_same_cameras(rig, back, make_points(rng, rig, 20), atol_t=0, atol_px=0)


@pytest.mark.parametrize("units,scale", [("m", 1.0), ("cm", 100.0), ("mm", 1000.0), ("MM", 1000.0)])
def test_native_units_are_converted_to_metres(tmp_path, rng, make_rig, units, scale):
    rig = make_rig(rng, 2)
    d = native_to_dict(rig)
    d["units"] = units
    for c in d["cameras"]:
        c["t"] = [v * scale for v in c["t"]]
    (tmp_path / "cameras.yaml").write_text(yaml.safe_dump(d))
    back = read_native(tmp_path / "cameras.yaml")
    for a, b in zip(rig, back):
        np.testing.assert_allclose(b.t, a.t, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(b.centre, a.centre, atol=1e-9)


def test_native_rvec_and_optional_dist(tmp_path, rng, make_rig, make_points):
    rig = make_rig(rng, 3)
    d = native_to_dict(rig)
    for c, cam in zip(d["cameras"], rig):
        del c["R"], c["dist"]
        c["rvec"] = cam.rvec.tolist()
        c["t"] = [[v] for v in c["t"]]  # an OpenCV column vector is accepted too
    (tmp_path / "cameras.yaml").write_text(yaml.safe_dump(d))
    back = read_native(tmp_path / "cameras.yaml")
    assert_same_cameras(rig, back, make_points(rng, rig, 20), atol_px=1e-6)
    assert not any(c.has_distortion for c in back)


# ============================================================================ aniposelib
def _anipose_toml(rig: Rig, scale: float, order=None, metadata: str = "") -> str:
    parts = []
    for i in order if order is not None else range(len(rig)):
        c = rig[i]
        parts.append(
            f"[cam_{i}]\nname = \"{c.name}\"\nsize = [{c.size[0]}, {c.size[1]}]\n"
            f"matrix = {json.dumps(c.K.tolist())}\ndistortions = {json.dumps(c.dist.tolist())}\n"
            f"rotation = {json.dumps(c.rvec.tolist())}\ntranslation = {json.dumps((c.t * scale).tolist())}\n"
        )
    return "\n".join(parts) + ("\n[metadata]\nadjusted = true\nerror = 0.5\n" + metadata)


def test_anipose_toml_in_millimetres(tmp_path, rng, make_rig, make_points):
    rig = make_rig(rng, 3, distortion=5)
    p = tmp_path / "calibration.toml"
    p.write_text(_anipose_toml(rig, 1000.0))
    back, report = read_calibration(p, units="mm")
    assert report.format == "anipose" and report.units == "mm"
    assert_same_cameras(rig, back, make_points(rng, rig, 30), atol_t=1e-12, atol_px=1e-6)


def test_anipose_orders_cameras_numerically_and_reads_metadata_units(tmp_path, rng, make_camera, make_points):
    rig = Rig([make_camera(rng, f"c{i}") for i in range(11)])
    p = tmp_path / "calibration.toml"
    p.write_text(_anipose_toml(rig, 100.0, order=[10, 2, 0, 1, 3, 4, 5, 6, 7, 8, 9], metadata='units = "cm"\n'))
    back = read_anipose(p)
    assert back.names == rig.names  # cam_2 before cam_10
    assert_same_cameras(rig, back, make_points(rng, rig[:3], 10), atol_t=1e-12)


def test_anipose_default_metres_warns_when_cameras_are_implausibly_far(tmp_path, rng, make_rig):
    rig = make_rig(rng, 2)
    p = tmp_path / "calibration.toml"
    p.write_text(_anipose_toml(rig, 1000.0))  # mm read as metres: cameras kilometres away
    with pytest.warns(UserWarning, match="units"):
        back = read_anipose(p)
    np.testing.assert_allclose(back[0].t, rig[0].t * 1000.0)
    p.write_text(_anipose_toml(rig, 1.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_anipose(p)  # metres: no warning


# ============================================================================ EasyMocap
def _fs_mat(key: str, a: np.ndarray) -> str:
    """One ``!!opencv-matrix`` entry exactly as EasyMocap's FileStorage.write prints it."""
    a = np.atleast_2d(a)
    data = ", ".join(f"{v:.6f}" for v in a.reshape(-1))
    return f"{key}: !!opencv-matrix\r\n  rows: {a.shape[0]}\r\n  cols: {a.shape[1]}\r\n  dt: d\r\n  data: [{data}]\r\n"


def _write_easymocap(folder: Path, rig: Rig, with_size: bool = True, rot_override: dict | None = None) -> None:
    head = "%YAML:1.0\r\n---\r\nnames:\r\n" + "".join(f'  - "{c.name}"\r\n' for c in rig)
    intri, extri = head, head
    for c in rig:
        intri += _fs_mat(f"K_{c.name}", c.K) + _fs_mat(f"dist_{c.name}", c.dist[None])
        if with_size:
            intri += f"H_{c.name}: {c.size[1]}\r\nW_{c.name}: {c.size[0]}\r\n"
        R = (rot_override or {}).get(c.name, c.R)
        extri += _fs_mat(f"R_{c.name}", c.rvec[:, None]) + _fs_mat(f"Rot_{c.name}", R) + _fs_mat(f"T_{c.name}", c.t[:, None])
    (folder / "intri.yml").write_text(intri)
    (folder / "extri.yml").write_text(extri)


def test_easymocap_intri_extri(tmp_path, rng, make_rig, make_points):
    rig = make_rig(rng, 4, distortion=5)
    _write_easymocap(tmp_path, rig)
    back = load_calibration(tmp_path / "intri.yml")
    assert back.names == rig.names
    X = make_points(rng, rig, 30)
    for a, b in zip(rig, back):
        assert b.size == a.size
        np.testing.assert_allclose(b.K, a.K, atol=1e-6)  # the file keeps 6 decimals
        np.testing.assert_allclose(b.t, a.t, atol=1e-6)
        np.testing.assert_allclose(b.R, a.R, atol=1e-5)
        np.testing.assert_allclose(b.project(X), a.project(X), atol=0.05)
    # the folder and extri.yml name the same calibration
    assert load_calibration(tmp_path).names == rig.names
    assert load_calibration(tmp_path / "extri.yml").names == rig.names


def test_easymocap_without_size_guesses_and_says_so(tmp_path, rng, make_rig):
    rig = make_rig(rng, 2)
    _write_easymocap(tmp_path, rig, with_size=False)
    with pytest.warns(UserWarning, match="guessed"):
        back, report = read_calibration(tmp_path / "intri.yml")
    assert any("guessed" in n for n in report.notes)
    for a, b in zip(rig, back):
        assert b.size == (round(2 * a.K[0, 2]), round(2 * a.K[1, 2]))
    back = read_easymocap(tmp_path / "intri.yml", size=(1920, 1080))
    assert all(c.size == (1920, 1080) for c in back)


def test_easymocap_rot_disagreeing_with_rvec_is_an_error(tmp_path, rng, make_rig):
    rig = make_rig(rng, 2)
    _write_easymocap(tmp_path, rig, rot_override={rig[1].name: rig[0].R})
    with pytest.raises(CalibrationError, match=f"Rot_{rig[1].name}") as e:
        read_easymocap(tmp_path / "intri.yml")
    assert "extri.yml" in str(e.value)


# ============================================================================ CMU Panoptic
def _to_panoptic(cam: Camera) -> dict:
    """A z-up metre camera expressed in the Panoptic world (y down, cm)."""
    A = PANOPTIC_TO_ZUP
    return {
        "name": cam.name, "type": "hd", "resolution": list(cam.size), "panel": 0, "node": 0,
        "K": cam.K.tolist(), "distCoef": cam.dist.tolist(), "R": (cam.R @ A).tolist(), "t": [[v * 100] for v in cam.t],
    }


def test_panoptic_conversion_keeps_projections_and_puts_z_up(tmp_path, rng, make_rig, make_points):
    rig = make_rig(rng, 3, distortion=5)
    cams = [_to_panoptic(c) for c in rig]
    vga = dict(_to_panoptic(rig[0]), name="01_01", type="vga", resolution=[640, 480])
    kin = dict(_to_panoptic(rig[1]), name="50_01", type="kinect-color")
    p = tmp_path / "calibration_160422_ultimatum1.json"
    p.write_text(json.dumps({"calibDataSource": "test", "cameras": [cams[0], vga, vga, cams[1], kin, cams[2]]}))
    assert detect_format(p) == "panoptic"
    back, report = read_calibration(p)
    assert back.names == rig.names
    assert report.skipped == {"type vga": 2, "type kinect-color": 1}
    X = make_points(rng, rig, 40)
    assert_same_cameras(rig, back, X, atol_t=1e-12, atol_px=1e-6)

    # a Panoptic-world point (cm, y down) projects, with the file's own R, t, to the same pixel
    # as its converted z-up point does with the converted camera
    X_pan = (X @ PANOPTIC_TO_ZUP) * 100.0  # rows: A.T @ X * 100
    for raw, cam in zip(cams, back):
        uv_pan, _ = cv2.projectPoints(
            X_pan.reshape(-1, 1, 3), cv2.Rodrigues(np.array(raw["R"]))[0], np.array(raw["t"], float), np.array(raw["K"]), np.array(raw["distCoef"])
        )
        np.testing.assert_allclose(cam.project(X_pan @ PANOPTIC_TO_ZUP.T / 100.0), uv_pan.reshape(-1, 2), atol=1e-6)
    # z is up: 1 m above the Panoptic origin is y = -100 cm there
    np.testing.assert_allclose(PANOPTIC_TO_ZUP @ np.array([0.0, -100.0, 0.0]) / 100, [0, 0, 1])
    assert np.isclose(np.linalg.det(PANOPTIC_TO_ZUP), 1.0)
    assert np.all(back.centres[:, 2] > 1.5)  # every random camera is 2-7 m above the floor

    kinect = read_panoptic(p, camera_types=("kinect",))
    assert kinect.names == ("50_01",)
    with pytest.raises(CalibrationError, match="no camera of type"):
        read_panoptic(p, camera_types=("nope",))


# ============================================================================ format detection
def test_load_calibration_detects_by_name_and_rejects_unknown(tmp_path, rng, make_rig):
    rig = make_rig(rng, 2)
    sub = tmp_path / "r"
    sub.mkdir()
    write_native(rig, sub / "cameras.yaml")
    assert load_calibration(sub).names == rig.names  # a folder with one calibration
    odd = write_native(rig, tmp_path / "my_cams.yaml")
    with pytest.raises(CalibrationError, match="cannot tell the calibration format") as e:
        load_calibration(odd)
    assert "my_cams.yaml" in str(e.value)
    assert load_calibration(odd, format="native").names == rig.names
    with pytest.raises(CalibrationError, match="unknown calibration format"):
        load_calibration(odd, format="colmap")
    (sub / "calibration.toml").write_text(_anipose_toml(rig, 1.0))
    with pytest.raises(CalibrationError, match="several calibrations"):
        load_calibration(sub)
    with pytest.raises(CalibrationError, match="does not apply"):
        load_calibration(sub / "cameras.yaml", units="mm")
    with pytest.raises(CalibrationError, match="file not found"):
        load_calibration(tmp_path / "absent" / "cameras.yaml")


# ============================================================================ bad input
def _native(rig: Rig) -> dict:
    return native_to_dict(rig)


def _bad(mutate):
    def case(d):
        mutate(d)
        return d
    return case


BAD_NATIVE = {
    "not a rotation": (_bad(lambda d: d["cameras"][1].__setitem__("R", (np.array(d["cameras"][1]["R"]) * 1.1).tolist())), "cam1.R", "not a rotation"),
    "reflection": (_bad(lambda d: d["cameras"][0].__setitem__("R", (-np.array(d["cameras"][0]["R"])).tolist())), "cam0.R", "reflection"),
    "singular K": (_bad(lambda d: d["cameras"][0]["K"][0].__setitem__(0, 0.0)), "cam0.K", "singular"),
    "K shape": (_bad(lambda d: d["cameras"][0].__setitem__("K", d["cameras"][0]["K"][:2])), "cameras[0].K", "shape"),
    "t shape": (_bad(lambda d: d["cameras"][1].__setitem__("t", [1.0, 2.0])), "cameras[1].t", "shape"),
    "missing t": (_bad(lambda d: d["cameras"][1].pop("t")), "cameras[1].t", "missing"),
    "missing rotation": (_bad(lambda d: d["cameras"][0].pop("R")), "cameras[0]", "rotation missing"),
    "R and rvec": (_bad(lambda d: d["cameras"][0].__setitem__("rvec", [0, 0, 0])), "cameras[0]", "not both"),
    "units missing": (_bad(lambda d: d.pop("units")), "units", "units missing"),
    "units unknown": (_bad(lambda d: d.__setitem__("units", "ft")), "units", "unknown units"),
    "NaN in t": (_bad(lambda d: d["cameras"][0]["t"].__setitem__(2, float("nan"))), "cameras[0].t", "NaN"),
    "NaN in dist": (_bad(lambda d: d["cameras"][0]["dist"].__setitem__(0, float("nan"))), "cameras[0].dist", "NaN"),
    "dist length": (_bad(lambda d: d["cameras"][0].__setitem__("dist", [0.1, 0.0, 0.0])), "cameras[0].dist", "4, 5 or 8"),
    "text in K": (_bad(lambda d: d["cameras"][0]["K"][1].__setitem__(1, "f")), "cameras[0].K", "numbers"),
    "size": (_bad(lambda d: d["cameras"][0].__setitem__("size", [1920.5, 1080])), "cameras[0].size", "whole"),
    "unknown key": (_bad(lambda d: d["cameras"][0].__setitem__("dsit", [0, 0, 0, 0])), "cameras[0].dsit", "unknown key"),
    "name not text": (_bad(lambda d: d["cameras"][0].__setitem__("name", 7)), "cameras[0].name", "quote"),
    "duplicate names": (_bad(lambda d: d["cameras"][1].__setitem__("name", "cam0")), "cameras", "unique"),
    "no cameras": (_bad(lambda d: d.__setitem__("cameras", [])), "cameras", "non-empty"),
}


@pytest.mark.parametrize("case", sorted(BAD_NATIVE))
def test_bad_native_calibration_names_file_and_field(tmp_path, rng, make_rig, case):
    mutate, field, problem = BAD_NATIVE[case]
    d = mutate(_native(make_rig(rng, 2)))
    p = tmp_path / "cameras.yaml"
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(CalibrationError) as e:
        read_native(p)
    msg = str(e.value)
    assert str(p) in msg and f"field '{field}'" in msg and problem in msg, msg


def test_bad_calibration_text_is_located(tmp_path, rng, make_rig):
    p = tmp_path / "cameras.yaml"
    p.write_text("units: m\ncameras:\n  - name: a\n    K: [[1, 0\n")
    with pytest.raises(CalibrationError, match=r"not valid YAML.*line \d+") as e:
        read_native(p)
    assert str(p) in str(e.value)
    pj = tmp_path / "cameras.json"
    pj.write_text('{"units": "m", "cameras": [}')
    with pytest.raises(CalibrationError, match=r"not valid JSON.*line 1"):
        read_native(pj)
    pt = tmp_path / "calibration.toml"
    pt.write_text("[cam_0\nname = 'x'")
    with pytest.raises(CalibrationError, match="not valid TOML"):
        read_anipose(pt)
    pt.write_text(_anipose_toml(make_rig(rng, 1), 1.0).replace("translation", "translatio"))
    with pytest.raises(CalibrationError, match="missing key") as e:
        read_anipose(pt)
    assert "cam_0.translation" in str(e.value)
    pt.write_text(_anipose_toml(make_rig(rng, 1), 1.0).replace("rotation = [", "rotation = [1, "))
    with pytest.raises(CalibrationError, match="cam_0.rotation"):
        read_anipose(pt)
    bad = tmp_path / "intri.yml"
    bad.write_text("%YAML:1.0\n---\nnames: [a\n")
    (tmp_path / "extri.yml").write_text("%YAML:1.0\n---\nnames: []\n")
    with pytest.raises(CalibrationError, match="intri.yml"):
        read_easymocap(bad)


def test_all_calibration_errors_are_input_errors():
    assert issubclass(CalibrationError, InputError) and issubclass(CalibrationError, ValueError)
