"""benchmarks/aed_gap.py: its parts of the AED ratio's excess over the oracle add up to R - 1
(on a small simulated suite) and match a hand-worked case."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from gymtrack.tracking.types import INTERPOLATED, TRIANGULATION

_spec = importlib.util.spec_from_file_location("aed_gap", Path(__file__).resolve().parents[1] / "benchmarks" / "aed_gap.py")
aed_gap = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(aed_gap)
CAT = aed_gap.CATEGORIES


def _frames(err, mine, other, mask, src=None):
    n = len(err)
    return {"err": np.array(err, float), "src": np.full(n, TRIANGULATION) if src is None else np.array(src),
            "mine": np.array(mine), "other": np.array(other), "mask": np.array(mask, np.int64)}


def test_hand_worked_decomposition():
    """Uneven bars: frames 0, 1 covered by both (frame 1 another set of views, 1 m worse), frame 2
    by the method alone, frame 3 by the oracle alone: M = 6/3, O = 4/3, over both 3/2 and 2/2.
    High bar: frame 1 follows someone else (3 m worse), frame 0 the same views (1 m worse):
    M = 3, O = 1. sum O = 7/3, R = 5 / (7/3) = 15/7."""
    assert INTERPOLATED != TRIANGULATION
    ub = {"routine": "ub", "apparatus": "uneven_bars", "n_cam": 2, "frames": np.arange(10, 14),
          "cascade": _frames([1.0, 2.0, 3.0, np.nan], [2, 2, 2, 0], [0, 0, 0, 0], [3, 1, 3, 0]),
          "oracle": _frames([1.0, 1.0, np.nan, 2.0], [2, 2, 0, 2], [0, 0, 0, 0], [3, 3, 0, 3])}
    hb = {"routine": "hb", "apparatus": "horizontal_bar", "n_cam": 2, "frames": np.arange(1, 3),
          "cascade": _frames([2.0, 4.0], [2, 0], [0, 1], [3, 0]),
          "oracle": _frames([1.0, 1.0], [2, 2], [0, 0], [3, 3])}
    assert CAT[aed_gap.categorise(ub["cascade"], ub["oracle"])[1]] == "views"
    assert CAT[aed_gap.categorise(hb["cascade"], hb["oracle"])[1]] == "other_person"
    gap, events = aed_gap.decompose([ub, hb], "cascade")
    g = gap[2]
    assert g["keys"] == [("horizontal_bar", 2), ("uneven_bars", 2)]  # the apparatus order
    assert np.isclose(g["R"], 15 / 7)
    want_ub = np.zeros(len(CAT) + 1)
    want_ub[CAT.index("views")] = 0.5 / (7 / 3)  # (2 - 1) m over 2 frames both cover
    want_ub[-1] = ((2 - 1.5) - (4 / 3 - 1)) / (7 / 3)  # cover: 1/14
    want_hb = np.zeros(len(CAT) + 1)
    want_hb[CAT.index("same")] = 0.5 / (7 / 3)
    want_hb[CAT.index("other_person")] = 1.5 / (7 / 3)
    assert np.allclose(g["parts"][("uneven_bars", 2)], want_ub, atol=1e-15)
    assert np.allclose(g["parts"][("horizontal_bar", 2)], want_hb, atol=1e-15)
    assert np.isclose(sum(p.sum() for p in g["parts"].values()), 8 / 7)
    assert g["n"][("uneven_bars", 2)] == {"same": 1, "source": 0, "views": 1, "mixed": 0, "gap_fill": 0, "other_person": 0}
    assert events == []  # one frame off, not a run of 5


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    from gymtrack.simulate import simulate_suite

    out = tmp_path_factory.mktemp("suite")
    simulate_suite(out, 1, seconds=10.0, seed=3, apparatus=["horizontal_bar"])
    return out


def test_parts_add_up_to_the_ratio_on_a_simulated_suite(suite):
    routines = aed_gap.run(str(suite), ["cascade"])
    gap, _ = aed_gap.decompose(routines, "cascade")
    assert sorted(gap) == [2, 3, 4]
    for n, g in gap.items():
        (k,) = g["keys"]
        assert g["R"] > 0 and np.isfinite(g["parts"][k]).all()
        assert np.isclose(g["parts"][k].sum(), g["R"] - 1, rtol=0, atol=1e-12), n
        # the categories take every frame both cover
        e = next(e for e in routines if e["n_cam"] == n)
        both = np.isfinite(e["cascade"]["err"]) & np.isfinite(e["oracle"]["err"])
        assert sum(g["n"][k].values()) == both.sum() > 0
