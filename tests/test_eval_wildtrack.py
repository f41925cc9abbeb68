"""The WILDTRACK section (gymtrack.eval.wildtrack): detector-like noise and a short real-data run."""

from __future__ import annotations

import numpy as np

from conftest import WILDTRACK, needs_wildtrack
from gymtrack.detections import Detections
from gymtrack.eval.wildtrack import WildtrackSetup, noisy_detections, run_wildtrack, wildtrack_markdown

DATA = WILDTRACK


def test_noisy_detections_counts_and_seed():
    det = Detections.from_arrays(np.repeat(np.arange(100), 5), np.tile(np.arange(5), 100), np.tile([500.0, 500, 60, 180], (500, 1)),
                                 [f"c{i}" for i in range(5)], track_id=np.arange(500))
    setup = WildtrackSetup(drop=0.2, false_positives=0.5)
    a, ca = noisy_detections(det, np.random.default_rng(1), setup)
    b, cb = noisy_detections(det, np.random.default_rng(1), setup)
    assert ca == cb and np.array_equal(a.box, b.box)  # seeded
    assert ca["kept"] + ca["dropped"] == 500 and len(a) == ca["kept"] + ca["false_positives"]
    assert 60 < ca["dropped"] < 140  # ~ 0.2 x 500
    assert 180 < ca["false_positives"] < 320  # ~ Poisson(0.5) x 100 frames x 5 views
    assert np.all(a.track_id == -1) and np.all(np.diff(a.frame) >= 0)
    assert np.all(a.box[:, 2:] > 0)


def test_missing_folder_is_skipped_with_a_note(tmp_path):
    r = run_wildtrack(tmp_path / "nowhere")
    assert r["available"] is False and "skipped" in r["note"]
    assert "skipped" in wildtrack_markdown(r)


@needs_wildtrack
def test_short_wildtrack_run_with_clean_boxes():
    # 30 annotated frames, the annotation boxes themselves (no noise): the triangulated tracks must
    # sit on the annotated ground positions (horizontally) and at about hip height
    setup = WildtrackSetup(limit=30, drop=0.0, jitter=0.0, size_noise=0.0, false_positives=0.0, modes=("cascade", "triangulation"))
    r = run_wildtrack(DATA, setup)
    assert r["available"] and r["frames"] == 30
    for mode in ("cascade", "triangulation"):
        m = r["modes"][mode]
        assert m["matches"] > 0.5 * m["objects"]  # most people found
        assert m["median_distance"] < 0.15  # metres, horizontal
        assert 0.6 < m["mean_height"] < 1.2
    md = wildtrack_markdown(r)
    assert "| cascade |" in md and "Why these numbers" in md


@needs_wildtrack
def test_cascade_plus_reports_what_the_per_view_tracker_linked():
    # 40 annotated frames with the benchmark's noise: at 2 fps cascade+ links boxes by predicted
    # motion that do not overlap, and the report counts them
    r = run_wildtrack(DATA, WildtrackSetup(limit=40, modes=("cascade", "cascade+")))
    plus, base = r["modes"]["cascade+"], r["modes"]["cascade"]
    assert plus["links_2d_motion"] > 0 and plus["tracks_2d_started"] > 0
    assert "links_2d_motion" not in base  # the paper's cascade keeps the IoU tracker
    assert plus["misses"] < base["misses"] and plus["fp_ghosts"] < base["fp_ghosts"]  # against the annotations
    assert f"made {plus['links_2d_motion']} links by predicted motion" in wildtrack_markdown(r)
