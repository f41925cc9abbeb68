"""``gymtrack export``: TRC, C3D, MOT and BVH files read back with other libraries.

The skeleton is a simulated gymnast's ground-truth joints (rigid bones) with the gaps a pose
stage leaves: a second with no pose (a camera silent), a 5-frame hole, a wrist lost for 0.3 s and
an ear lost for 0.7 s. Expected, by the export rule (gaps up to 0.5 s interpolated, longer ones
split): 1 + 17 gaps filled, 3 parts, 30 + 21 frames in no part. Readers: pandas (TRC, MOT), ezc3d
and the pure-Python ``c3d`` (C3D), pybvh's parser and forward kinematics (BVH), OpenSim's own file
adapters where the ``opensim`` package is installed.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.formats.atomic import atomic_output, read_marker
from gymtrack.formats.poses3d import read_poses_3d, write_poses_3d
from gymtrack.poses import Poses3D
from gymtrack.simulate import simulate_routine
from gymtrack.skeletons import COCO17
from gymtrack.version import SOURCE_VERSION, version

FPS = 30.0
SILENT = np.arange(100, 130)  # one second without a pose
HOLE = np.arange(200, 205)  # 5 frames without a pose
WRIST = ("left_wrist", np.arange(50, 59))  # 0.3 s
EAR = ("left_ear", np.arange(240, 261))  # 0.7 s: longer than 0.5 s, splits
J = COCO17.joints


def _poses(sim) -> Poses3D:
    k = int(np.flatnonzero(sim.person_id == sim.target_id)[0])
    xyz = sim.keypoints[k].copy()
    frames = sim.frames.copy()
    for name, fr in (WRIST, EAR):
        xyz[np.isin(frames, fr), J.index(name)] = np.nan
    keep = ~np.isin(frames, np.concatenate([SILENT, HOLE]))
    frames, xyz = frames[keep], xyz[keep]
    M = len(frames)
    return Poses3D(frames, np.full(M, 3), xyz, np.ones((M, 17)), np.full((M, 17), 3), np.full((M, 17), 1.0),
                   np.ones((M, 17), np.int8), COCO17)


@pytest.fixture(scope="module")
def routine_out(tmp_path_factory):
    """(routine folder, output folder with the marker and poses_3d.csv, the poses as the file holds them)."""
    tmp = tmp_path_factory.mktemp("export")
    sim = simulate_routine("horizontal_bar", n_cam=3, seed=1, seconds=10)
    assert sim.fps == FPS
    routine, out = tmp / "routine", tmp / "out"
    sim.write(routine)
    with atomic_output(out, "track", {"routine": routine.absolute()}) as staging:
        write_poses_3d(staging / "poses_3d.csv", _poses(sim))
    return routine, out, read_poses_3d(out / "poses_3d.csv")


def _grid(p: Poses3D) -> tuple[np.ndarray, np.ndarray]:
    """The poses on their frame range (T, 17, 3), NaN where no estimate."""
    frames = np.arange(p.frame.min(), p.frame.max() + 1)
    g = np.full((len(frames), 17, 3), np.nan)
    g[p.frame - frames[0]] = p.xyz
    return frames, g


def _interp(frames, g):
    """Linear interpolation over gaps of at most 15 frames (0.5 s), by pandas (independent of the exporter)."""
    df = pd.DataFrame(g.reshape(len(frames), -1))
    miss = df.isna()
    run = (miss != miss.shift()).cumsum()
    long_gap = miss & (miss.apply(lambda c: c.groupby(run[c.name]).transform("sum")) > 15)
    return df.interpolate(limit_area="inside").mask(long_gap).to_numpy().reshape(g.shape)


def _export(out, *args):
    r = CliRunner().invoke(app, ["export", str(out), *args])
    return r, r.output + (str(r.exception) if r.exception and not isinstance(r.exception, SystemExit) else "")


def test_trc_read_back_with_pandas(routine_out, tmp_path):
    _, out, p = routine_out
    r, text = _export(out, "--format", "trc", "-o", str(tmp_path / "run.trc"))
    assert r.exit_code == 0, text
    assert "18 gaps up to 0.5 s interpolated" in text and "split it into 3 parts" in text and "51 frames in no part" in text
    files = sorted(tmp_path.glob("run_part*.trc"))
    assert [f.name for f in files] == ["run_part1.trc", "run_part2.trc", "run_part3.trc"]
    frames, g = _grid(p)
    # pandas' interpolation, capped at 15 frames, gives what may be filled; a long gap stays NaN
    want = _interp(frames, g)
    seen = []
    for f in files:
        lines = f.read_text().splitlines()
        assert lines[0].split("\t")[:3] == ["PathFileType", "4", "(X/Y/Z)"]
        assert lines[1].split("\t") == ["DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units", "OrigDataRate",
                                        "OrigDataStartFrame", "OrigNumFrames"]
        head = lines[2].split("\t")
        names = [n for n in lines[3].split("\t")[2:] if n]
        assert names == list(J) and lines[4].split("\t")[2:5] == ["X1", "Y1", "Z1"]
        df = pd.read_csv(f, sep="\t", skiprows=6, header=None)
        assert float(head[0]) == FPS and int(head[2]) == len(df) and int(head[3]) == 17 and head[4] == "m"
        fr = df[0].to_numpy()
        assert int(head[6]) == fr[0] and np.all(np.diff(fr) == 1)
        np.testing.assert_allclose(df[1].to_numpy(), fr / FPS, atol=1e-6)
        yup = df.iloc[:, 2:].to_numpy().reshape(len(df), 17, 3)
        world = np.stack([yup[..., 2], yup[..., 0], yup[..., 1]], axis=-1)  # (y, z, x) back to (x, y, z)
        np.testing.assert_allclose(world, want[fr - frames[0]], atol=6e-7)  # 6 decimals
        seen.append(fr)
    seen = np.concatenate(seen)
    # the parts are exactly the frames where every joint has a value after filling
    complete = frames[np.isfinite(want).all(axis=(1, 2))]
    assert np.array_equal(seen, complete) and len(frames) - len(complete) == 51


def test_c3d_read_back_with_ezc3d_and_c3d(routine_out, tmp_path):
    ezc3d = pytest.importorskip("ezc3d")
    _, out, p = routine_out
    path = tmp_path / "run.c3d"
    r, text = _export(out, "--format", "c3d", "-o", str(path))
    assert r.exit_code == 0, text
    frames, g = _grid(p)
    missing = ~np.isfinite(g).all(-1)  # (T, J) joint-frames without an estimate
    assert missing.sum() == 30 * 17 + 5 * 17 + 9 + 21
    assert f"{missing.sum()} without an estimate written as invalid" in text
    c = ezc3d.c3d(str(path))
    P = c["parameters"]["POINT"]
    assert list(P["LABELS"]["value"]) == list(J) and P["RATE"]["value"][0] == FPS and P["UNITS"]["value"] == ["m"]
    assert P["X_SCREEN"]["value"] == ["+X"] and P["Y_SCREEN"]["value"] == ["+Z"]  # z up
    assert c["header"]["points"]["first_frame"] == frames[0]
    pts = c["data"]["points"][:3].transpose(2, 1, 0)  # (T, J, 3)
    res = c["data"]["meta_points"]["residuals"][0].T
    assert np.array_equal(res == -1, missing) and np.all(res[~missing] >= 0)
    np.testing.assert_allclose(pts[~missing], g[~missing], atol=1e-6)  # float32
    assert np.isnan(pts[missing]).all()
    c3d = pytest.importorskip("c3d")
    with open(path, "rb") as fh, pytest.warns(UserWarning, match="analog"):
        reader = c3d.Reader(fh)
        assert [s.strip() for s in reader.point_labels] == list(J) and reader.point_rate == FPS
        assert reader.get("POINT:UNITS").string_value.strip() == "m"
        got = np.stack([pts_ for _, pts_, _ in reader.read_frames()])  # (T, J, 5): x y z residual cameras
    assert np.array_equal(got[..., 3] == -1, missing)
    np.testing.assert_allclose(got[..., :3][~missing], g[~missing], atol=1e-6)


def _bvh_joints(path: Path) -> np.ndarray:
    """(T, 17, 3) world joints of a BVH file by pybvh's forward kinematics."""
    pybvh = pytest.importorskip("pybvh")
    b = pybvh.read_bvh_file(str(path))
    pos = b.node_positions()
    names = [n.name for n in b.nodes]
    y = pos[:, [names.index(n) for n in J]]
    return np.stack([y[..., 2], y[..., 0], y[..., 1]], axis=-1), b


@pytest.mark.filterwarnings("ignore:Rest pose suggests world up")  # pybvh guessing the up axis: unused here
def test_bvh_forward_kinematics_with_pybvh(routine_out, tmp_path):
    _, out, p = routine_out
    path = tmp_path / "run.bvh"
    r, text = _export(out, "--format", "bvh", "-o", str(path))
    assert r.exit_code == 0, text
    assert "split it into 3 parts" in text
    frames, g = _grid(p)
    want = _interp(frames, g)
    b0, b1 = COCO17.bones.T
    length = np.linalg.norm(want[:, b0] - want[:, b1], axis=-1)  # (T, bones)
    steady = np.all(np.abs(length - np.nanmedian(length, axis=0)) < 2e-4, axis=1)  # interpolation keeps no length
    assert 0 < (~steady & np.isfinite(length).all(1)).sum() <= len(WRIST[1]) + len(HOLE)  # interpolated frames
    n = 0
    for f in sorted(tmp_path.glob("run_part*.bvh")):
        got, b = _bvh_joints(f)
        assert b.frame_time == pytest.approx(1 / FPS)
        T = len(got)
        # the part's frames: where its joints match (the file has no frame numbers)
        starts = [s for s in range(len(frames) - T + 1) if np.isfinite(want[s:s + T]).all()]
        s = starts[int(np.argmin([np.nanmedian(np.linalg.norm(got - want[s:s + T], axis=-1)) for s in starts]))]
        err = np.linalg.norm(got - want[s:s + T], axis=-1)
        ok = steady[s:s + T]
        assert err[ok].max() < 1e-3, f"{f.name}: FK error {err[ok].max() * 1000:.3f} mm where bones are steady"
        n += ok.sum()
    assert n == steady.sum()
    m = re.search(r"in the (\d+) frames whose bone lengths are within 0.25 mm of the rig's, its forward kinematics is "
                  r"within ([0-9.]+) mm", text)
    assert m and float(m.group(2)) < 1.0 and int(m.group(1)) >= 0.9 * steady.sum(), text


@pytest.mark.filterwarnings("ignore:Rest pose suggests world up")
def test_bvh_error_only_where_a_bone_length_changes(tmp_path):
    """A shin 3 cm longer in one frame moves that frame's ankle by about 3 cm; the rest stay exact."""
    from gymtrack.export.bvh import fit_rig, fk_error, solve_motion, write_bvh

    sim = simulate_routine("still_rings", n_cam=3, seed=2, seconds=10)
    k = int(np.flatnonzero(sim.person_id == sim.target_id)[0])
    xyz = sim.keypoints[k][:120].copy()
    a, kn = J.index("right_ankle"), J.index("right_knee")
    xyz[60, a] += 0.03 * (xyz[60, a] - xyz[60, kn]) / np.linalg.norm(xyz[60, a] - xyz[60, kn])
    rig = fit_rig(xyz, J)
    m = solve_motion(rig, xyz, J)
    e = fk_error(rig, m, xyz, J)
    write_bvh(tmp_path / "r.bvh", rig, m, FPS)
    got, _ = _bvh_joints(tmp_path / "r.bvh")
    e2 = np.linalg.norm(got - xyz, axis=-1)
    for err in (e, e2):
        assert err[60, a] == pytest.approx(0.03, abs=1e-4)
        assert np.delete(err.ravel(), 60 * 17 + a).max() < 1e-4


@pytest.fixture(autouse=True)
def _opensim_log_elsewhere(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # OpenSim writes opensim.log into the working directory when first imported


def test_mot_header_as_opensim_expects(routine_out, tmp_path):
    from gymtrack.formats.elements import ANGLE_MEASURES, ANGLES_COLUMNS, write_angles

    _, out, _ = routine_out
    r, text = _export(out, "--format", "mot", "-o", str(tmp_path / "a.mot"))
    assert r.exit_code != 0 and "gymtrack analyse" in text  # no analysis stage yet
    rng = np.random.default_rng(0)
    n = 40
    cols = {c: rng.uniform(0, 180, n) for c in ANGLES_COLUMNS}
    cols.update(frame=np.arange(10, 10 + n), track_id=np.full(n, 3), support=np.full(n, "none"))
    cols["split"][5] = np.nan
    write_angles(out / "analysis" / "angles.csv", cols)
    try:
        r, text = _export(out, "--format", "mot", "-o", str(tmp_path / "a.mot"))
    finally:
        (out / "analysis" / "angles.csv").unlink()
    assert r.exit_code == 0, text
    assert "1 measures that could not be computed written as NaN" in text
    lines = (tmp_path / "a.mot").read_text().splitlines()
    end = lines.index("endheader")
    head = dict(x.split("=") for x in lines[1:end])
    assert head == {"version": "1", "nRows": str(n), "nColumns": str(1 + len(ANGLE_MEASURES)), "inDegrees": "yes"}
    df = pd.read_csv(tmp_path / "a.mot", sep="\t", skiprows=end + 1)
    assert list(df.columns) == ["time", *ANGLE_MEASURES] and len(df) == n
    np.testing.assert_allclose(df["time"], cols["frame"] / FPS, atol=1e-6)
    for c in ANGLE_MEASURES:
        np.testing.assert_allclose(df[c], np.round(cols[c], 2), atol=1e-6)  # angles.csv keeps 2 decimals
    assert df["split"].isna().sum() == 1
    try:
        import opensim as osim
    except ImportError:
        return
    t = osim.TimeSeriesTable(str(tmp_path / "a.mot"))  # OpenSim's own reader of the motion file
    assert t.getNumRows() == n and list(t.getColumnLabels()) == list(ANGLE_MEASURES)
    assert t.getTableMetaDataAsString("inDegrees") == "yes"
    col = t.getDependentColumn("left_knee").to_numpy()
    np.testing.assert_allclose(col, np.round(cols["left_knee"], 2), atol=1e-6)
    assert np.isnan(t.getDependentColumn("split").to_numpy()[5])


def test_opensim_reads_the_files(routine_out, tmp_path):
    osim = pytest.importorskip("opensim")
    _, out, p = routine_out
    r, text = _export(out, "--format", "trc", "-o", str(tmp_path / "run.trc"))
    assert r.exit_code == 0, text
    t = osim.TimeSeriesTableVec3(str(tmp_path / "run_part1.trc"))
    assert t.getNumColumns() == 17 and list(t.getColumnLabels()) == list(J)
    frames, g = _grid(p)
    row = t.getRowAtIndex(0)
    v = row[J.index("nose")]
    # OpenSim's reading of the first row: (y, z, x) of the world
    np.testing.assert_allclose([v.get(0), v.get(1), v.get(2)], g[0, J.index("nose")][[1, 2, 0]], atol=1e-6)
    assert t.getIndependentColumn()[0] == pytest.approx(frames[0] / FPS)


def test_bad_input_and_overwrite(routine_out, tmp_path):
    _, out, _ = routine_out
    empty = tmp_path / "empty"
    empty.mkdir()
    r, text = _export(empty, "--format", "trc")
    assert r.exit_code != 0 and "gymtrack pose" in text and "poses_3d.csv" in text
    r, text = _export(out, "--format", "fbx")
    assert r.exit_code != 0 and "trc, c3d, mot, bvh" in text
    dest = tmp_path / "x.c3d"
    assert _export(out, "--format", "c3d", "-o", str(dest))[0].exit_code == 0
    before = dest.read_bytes()
    r, text = _export(out, "--format", "c3d", "-o", str(dest))
    assert r.exit_code != 0 and "--overwrite" in text and dest.read_bytes() == before
    # a stale part of an earlier export under the same name is replaced too
    (tmp_path / "x_part7.c3d").write_text("old")
    r, text = _export(out, "--format", "c3d", "-o", str(dest), "--overwrite")
    assert r.exit_code == 0, text
    assert not (tmp_path / "x_part7.c3d").exists() and sorted(q.name for q in tmp_path.iterdir()) == ["empty", "x.c3d"]


def test_writes_are_all_or_nothing(routine_out, tmp_path, monkeypatch):
    import gymtrack.export.trc as trc

    _, out, _ = routine_out
    calls = []
    real = trc.write_trc

    def failing(path, *a, **k):
        calls.append(path)
        if len(calls) == 3:
            raise OSError("disk full")
        return real(path, *a, **k)

    monkeypatch.setattr(trc, "write_trc", failing)
    with pytest.raises(OSError):
        from gymtrack.export import export_output

        export_output(out, "trc", dest=tmp_path / "run.trc")
    assert len(calls) == 3 and list(tmp_path.iterdir()) == []  # no part, no temporary file


def test_version_everywhere(routine_out, tmp_path):
    import tomllib

    root = Path(__file__).resolve().parents[1]
    assert tomllib.loads((root / "pyproject.toml").read_text())["project"]["version"] == SOURCE_VERSION
    for flag in ("--version", "-V"):
        r = CliRunner().invoke(app, [flag])
        assert r.exit_code == 0 and r.output.strip() == f"gymtrack {version()}"
    _, out, _ = routine_out
    assert read_marker(out)["version"] == version()
    from gymtrack.formats.outputs import write_outputs
    from gymtrack.tracking import track_detections

    sim = simulate_routine("vault", n_cam=2, seed=0, seconds=10)
    res = track_detections(sim.rig, sim.scene, sim.detections.select(sim.detections.frame < 40), mode="cascade")
    write_outputs(res, tmp_path)
    assert json.loads((tmp_path / "summary.json").read_text())["version"] == version()


def test_opensim_scales_and_tracks_our_trc(routine_out, tmp_path):
    """OpenSim's inverse kinematics on the first part of the TRC: a scaled 14-segment model follows the
    markers (rigid trunk, hinge knees and elbows: centimetre-level model error, not a file error)."""
    pytest.importorskip("opensim")
    from osim_rig import scale_and_track

    _, out, _ = routine_out
    assert _export(out, "--format", "trc", "-o", str(tmp_path / "run.trc"))[0].exit_code == 0
    err, names = scale_and_track(tmp_path / "run_part1.trc", tmp_path)
    assert sorted(names) == sorted(J) and len(err) == 99  # every marker, every frame of the part
    rms = float(np.sqrt(np.mean(err ** 2)))
    print(f"OpenSim IK on {tmp_path / 'run_part1.trc'}: marker RMS {rms * 1000:.1f} mm, max {err.max() * 1000:.1f} mm")
    assert rms < 0.015 and err.max() < 0.05


def test_all_tracks_and_the_targets_rows(routine_out, tmp_path):
    """poses_3d.csv of every track: --all-tracks gives a file per track; without it, target_3d.csv's rows."""
    ezc3d = pytest.importorskip("ezc3d")
    _, src, p = routine_out
    other = Poses3D(p.frame, np.full(len(p), 5), p.xyz + [2.0, 0.0, 0.0], p.score, p.n_views, p.reproj_px, p.how, p.skeleton)
    out = tmp_path / "out"
    with atomic_output(out, "track") as staging:
        write_poses_3d(staging / "poses_3d.csv", Poses3D.concat([p, other]))
        # the target follows track 3, then track 5 from frame 150 on
        tid = np.where(p.frame < 150, 3, 5)
        rows = "".join(f"{f},{t},0,0,0,triangulation\n" for f, t in zip(p.frame, tid))
        (staging / "target_3d.csv").write_text("frame,track_id,x,y,z,source\n" + rows)
    r, text = _export(out, "--format", "c3d", "--fps", "30")
    assert r.exit_code == 0, text
    pts = ezc3d.c3d(str(out / "export" / "target.c3d"))["data"]["points"][:3].transpose(2, 1, 0)
    frames, g = _grid(p)
    shift = np.where(frames >= 150, 2.0, 0.0)[:, None]
    ok = np.isfinite(g).all(-1)
    np.testing.assert_allclose(pts[..., 0][ok], (g[..., 0] + shift)[ok], atol=1e-6)
    r, text = _export(out, "--format", "c3d", "--fps", "30", "--all-tracks")
    assert r.exit_code == 0, text
    for t, dx in ((3, 0.0), (5, 2.0)):
        pts = ezc3d.c3d(str(out / "export" / f"track{t}.c3d"))["data"]["points"][:3].transpose(2, 1, 0)
        np.testing.assert_allclose(pts[..., 0][ok], g[..., 0][ok] + dx, atol=1e-6)
    folder = tmp_path / "files"
    folder.mkdir()
    assert _export(out, "--format", "c3d", "--fps", "30", "--all-tracks", "-o", str(folder))[0].exit_code == 0
    assert sorted(q.name for q in folder.iterdir()) == ["track3.c3d", "track5.c3d"]  # -o a folder: default names
    # without a routine in the marker, the frame rate must be given
    r, text = _export(out, "--format", "trc")
    assert r.exit_code != 0 and "--fps" in text


def test_pipeline_with_a_silent_camera(tmp_path):
    """simulate -> track -> pose -> export, a camera silent for a second: the files follow poses_3d.csv
    (read here with pandas): C3D invalid exactly where it has no row, the TRC frames complete."""
    ezc3d = pytest.importorskip("ezc3d")
    from gymtrack.formats.outputs import write_outputs
    from gymtrack.tracking import track_detections

    sim = simulate_routine("horizontal_bar", n_cam=2, seed=3, seconds=10)
    routine, out = tmp_path / "routine", tmp_path / "out"
    sim.write(routine)
    cam0 = routine / "detections" / "cam0.txt"
    lines = cam0.read_text().splitlines()
    cam0.write_text("".join(ln + "\n" for ln in lines if not 150 <= int(ln.split(",")[0]) < 180))
    from gymtrack.formats.routine import load_routine

    r = load_routine(routine)
    with atomic_output(out, "track", {"routine": routine.absolute()}) as staging:
        write_outputs(track_detections(r.rig, r.scene, r.detections, mode="cascade"), staging)
    res = CliRunner().invoke(app, ["pose", str(routine), str(out), "--simulated-model"])
    assert res.exit_code == 0, res.output
    df = pd.read_csv(out / "poses_3d.csv")
    assert df.groupby("frame")["track_id"].nunique().max() == 1  # the target only
    first, last = df["frame"].min(), df["frame"].max()
    want_invalid = (last - first + 1) * 17 - len(df)
    r1, text = _export(out, "--format", "c3d")
    assert r1.exit_code == 0, text
    assert f"{want_invalid} without an estimate written as invalid" in text
    c = ezc3d.c3d(str(out / "export" / "target.c3d"))
    res_ = c["data"]["meta_points"]["residuals"][0]
    assert (res_ == -1).sum() == want_invalid
    r2, text = _export(out, "--format", "trc")
    assert r2.exit_code == 0, text
    for f in sorted((out / "export").glob("target*.trc")):
        t = pd.read_csv(f, sep="\t", skiprows=6, header=None)
        assert np.isfinite(t.to_numpy()).all() and (np.diff(t[0]) == 1).all()
    r3, text = _export(out, "--format", "bvh")
    assert r3.exit_code == 0, text
    assert "BVH rig:" in text


def test_gap_rule_against_pandas():
    """fill_gaps and complete_parts on random gaps agree with pandas' interpolation of runs <= 15 frames."""
    from gymtrack.export.series import complete_parts, fill_gaps

    rng = np.random.default_rng(7)
    for _ in range(20):
        T, Jn = int(rng.integers(5, 120)), int(rng.integers(1, 5))
        xyz = rng.normal(size=(T, Jn, 3)).cumsum(0)
        for _ in range(int(rng.integers(0, 6))):  # holes of random length in random joints
            j, s, n = rng.integers(Jn), rng.integers(T), rng.integers(1, 30)
            xyz[s:s + n, j] = np.nan
        filled, info = fill_gaps(xyz, 15)
        want = _interp(np.arange(T), xyz)
        np.testing.assert_allclose(filled, want, atol=1e-12)
        assert info.cells == int((np.isnan(xyz[..., 0]) & ~np.isnan(want[..., 0])).sum())
        runs = complete_parts(filled)
        ok = np.zeros(T, bool)
        for r in runs:
            ok[r] = True
            assert r.start == 0 or not np.isfinite(filled[r.start - 1]).all()  # maximal
        assert np.array_equal(ok, np.isfinite(filled).all(axis=(1, 2)))
