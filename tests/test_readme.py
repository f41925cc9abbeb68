"""The README's Python example runs, and streaming it gives what the offline runner gives."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import gymtrack
from gymtrack.simulate import simulate_routine

README = Path(__file__).resolve().parents[1] / "README.md"
#: a fenced python block right after a ``<!-- tested: ... -->`` line
TESTED = re.compile(r"<!-- tested:[^\n]*-->\n```python\n(.*?)\n```", re.S)


def readme_blocks() -> list[str]:
    return TESTED.findall(README.read_text(encoding="utf-8"))


def test_readme_marks_its_streaming_example():
    blocks = readme_blocks()
    assert blocks and any("tracker.update(" in b for b in blocks)


@pytest.mark.parametrize("k", range(len(readme_blocks())))
def test_readme_example_runs(k, tmp_path, monkeypatch, capsys):
    simulate_routine("uneven_bars", n_cam=2, seed=0, seconds=10, out=tmp_path / "r")
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    exec(compile(readme_blocks()[k], f"README.md block {k}", "exec"), ns)
    assert "target frames" in capsys.readouterr().out
    # streaming frame by frame = the offline runner, to the bit
    offline = gymtrack.track_routine(tmp_path / "r")
    assert len(ns["target"]) > 100
    np.testing.assert_array_equal(ns["target"].frame, offline.target.frame)
    np.testing.assert_array_equal(ns["target"].xyz, offline.target.xyz)
