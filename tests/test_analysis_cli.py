"""``gymtrack analyse`` on an output folder, the README's analysis example, bad input, the batch step."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.batch.routines import parse_steps
from gymtrack.cli import app
from gymtrack.errors import InputError
from gymtrack.eval.judging import truth_poses
from gymtrack.formats.atomic import atomic_output
from gymtrack.formats.elements import read_angles, read_elements
from gymtrack.formats.poses3d import write_poses_3d
from gymtrack.simulate import simulate_routine

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
BLOCK = re.compile(r"<!-- tested-analysis:[^\n]*-->\n```python\n(.*?)\n```", re.S)


def _output(folder: Path, sim, target_rows: bool = True) -> Path:
    """A complete output folder holding the true skeleton as poses_3d.csv and the target's rows."""
    poses = truth_poses(sim.frames, sim.keypoints[0], 1)
    with atomic_output(folder, "track", {}) as staging:
        write_poses_3d(staging / "poses_3d.csv", poses)
        lines = ["frame,track_id,x,y,z,source"]
        if target_rows:
            lines += [f"{f},1,0,0,1,triangulation" for f in poses.frame]
        (staging / "target_3d.csv").write_text("\n".join(lines) + "\n")
    return folder


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    d = tmp_path_factory.mktemp("ancli")
    sim = simulate_routine("balance_beam", n_cam=4, seed=0, seconds=20, out=d / "r")
    _output(d / "out", sim)
    return d, sim


def test_readme_analysis_example_runs(world, monkeypatch, capsys):
    d, _ = world
    blocks = BLOCK.findall(README.read_text(encoding="utf-8"))
    assert len(blocks) == 1 and "gymtrack.analyse(" in blocks[0]
    monkeypatch.chdir(d)
    exec(compile(blocks[0], "README.md analysis block", "exec"), {})
    out = capsys.readouterr().out
    assert re.search(r"flight \d+-\d+: -?[0-9.]+ saltos", out) and "left knee at frame" in out
    assert (d / "out" / "analysis" / "elements.json").is_file()


def test_analyse_writes_the_folder_and_prints_the_elements(world):
    d, sim = world
    res = CliRunner().invoke(app, ["analyse", str(d / "r"), str(d / "out"), "--samples", "4"], terminal_width=160)
    assert res.exit_code == 0, res.output
    assert "flight" in res.output and "saltos" in res.output
    doc = read_elements(d / "out" / "analysis" / "elements.json")
    truth = read_elements(d / "r" / "gt" / "elements.json")
    got = [(e["start_frame"], e["saltos"], e["twists"], e["shape"]) for e in doc["elements"] if e["kind"] == "flight"]
    want = [(e["start_frame"], e["saltos"], e["twists"], e["shape"]) for e in truth["elements"] if e["kind"] == "flight"]
    assert [g[1:] for g in got] == [w[1:] for w in want] and len(got) >= 2
    assert all(abs(g[0] - w[0]) <= 1 for g, w in zip(got, want))
    cols = read_angles(d / "out" / "analysis" / "angles.csv")
    assert len(cols["frame"]) == int(np.isfinite(sim.keypoints[0]).all(axis=(1, 2)).sum())
    marker = json.loads((d / "out" / ".gymtrack-output.json").read_text()) if (d / "out" / ".gymtrack-output.json").is_file() else None
    if marker is not None:
        assert any(u["command"] == "analyse" for u in marker.get("updates", []))
    pytest.importorskip("matplotlib")
    assert (d / "out" / "analysis" / "report.html").is_file()


def test_no_target_no_poses_and_no_plane(world, tmp_path):
    d, sim = world
    out = _output(tmp_path / "notarget", sim, target_rows=False)
    res = CliRunner().invoke(app, ["analyse", str(d / "r"), str(out)])
    assert isinstance(res.exception, InputError) and "no target" in str(res.exception)
    assert not (out / "analysis").exists()
    (out / "poses_3d.csv").unlink()
    res = CliRunner().invoke(app, ["analyse", str(d / "r"), str(out)])
    assert isinstance(res.exception, InputError) and "gymtrack pose" in str(res.exception)
    # a scene without apparatus or plane: said, and the rest computed
    bare = tmp_path / "bare"
    bare.mkdir()
    (bare / "scene.yaml").write_text("fps: 30\nperformance_space: [-4, -2, 0, 4, 2, 4]\n")
    res = CliRunner().invoke(app, ["analyse", str(bare), str(d / "out"), "--samples", "0", "--no-report"],
                             terminal_width=200)
    assert res.exit_code == 0, res.output
    assert "not computed: somersault" in res.output and "still computed:" in res.output
    assert "left_knee" in res.output.split("still computed:")[1]


def test_the_command_line_exits_2_with_one_line(world, tmp_path):
    d, _ = world
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-m", "gymtrack.cli", "analyse", str(d / "r"), str(tmp_path)],
                       capture_output=True, text=True, env=env)
    assert p.returncode == 2 and "error:" in p.stderr and "poses_3d.csv" in p.stderr


def test_batch_runs_analyse_after_pose_and_before_eval():
    assert parse_steps("eval,analyse,pose,track") == ("track", "pose", "analyse", "eval")
