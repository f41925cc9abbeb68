"""Byte-identity check for refactors: every method's outputs on a suite, with checksums.

Usage::

    PYTHONPATH=<tree> python benchmarks/snapshot_outputs.py SUITE OUT [PATTERN] [METHODS] [--wildtrack PATH]
    diff OLD/SHA256SUMS NEW/SHA256SUMS

Runs every method of the benchmark (cascade, cascade+, triangulation, plane, mvpt, oracle) on every routine
of SUITE (``gymtrack simulate-suite`` output; PATTERN is fnmatch on ``<apparatus>/ncam<n>/r<k>``,
several patterns comma-separated; METHODS, comma-separated, restricts the methods, e.g. ``cascade+,cascade``)
through :func:`gymtrack.eval.benchmark.run_method`, writes the outputs of docs/formats.md under
``OUT/<routine>/<method>/`` and ``OUT/SHA256SUMS`` (summary.json without its timing keys).
``--wildtrack PATH``: also the tracker's modes on WILDTRACK as the benchmark's real-data section
runs them (:func:`gymtrack.eval.wildtrack.run_wildtrack`'s detections and scene), under
``OUT/wildtrack/<mode>/``. A refactor of the tracker was checked this way: 4620 files, 0 differ, on
the default 84-routine suite.
"""
import hashlib, json, sys
from pathlib import Path
import numpy as np

wildtrack = None
if "--wildtrack" in sys.argv:
    i = sys.argv.index("--wildtrack")
    wildtrack = Path(sys.argv[i + 1])
    del sys.argv[i:i + 2]
suite, out = Path(sys.argv[1]), Path(sys.argv[2])
patterns = (sys.argv[3] if len(sys.argv) > 3 else "*").split(",")  # fnmatch on the routine path relative to SUITE
METHODS = ("cascade", "cascade+", "triangulation", "plane", "mvpt", "oracle")  # cascade+: beyond the paper
methods = tuple(sys.argv[4].split(",")) if len(sys.argv) > 4 else METHODS
import fnmatch
import gymtrack
print("gymtrack from", gymtrack.__file__, file=sys.stderr)
from gymtrack.formats.routine import load_routine
from gymtrack.formats.outputs import write_outputs
from gymtrack.eval.benchmark import run_method
try:
    from gymtrack.formats.ground_truth import load_ground_truth
except ImportError:  # older trees
    from gymtrack.eval.gt import load_ground_truth

def strip(d):
    if isinstance(d, dict):
        return {k: strip(v) for k, v in d.items() if not any(s in k for s in ("second", "fps", "time"))}
    if isinstance(d, list):
        return [strip(v) for v in d]
    return d

routines = sorted(p.parent for p in suite.rglob("scene.yaml") 
                  if any(fnmatch.fnmatch(str(p.parent.relative_to(suite)), q) for q in patterns))
for r in routines:
    rt = load_routine(r)
    size = np.array([c.size for c in rt.rig], dtype=np.float64)
    gt = load_ground_truth(r, rt.rig.names, image_size=size)
    for method in methods:
        res, _, _ = run_method(method, rt.rig, rt.scene, rt.detections, gt)
        d = out / r.relative_to(suite) / method
        write_outputs(res, d)
        s = d / "summary.json"
        s.write_text(json.dumps(strip(json.loads(s.read_text())), indent=1, sort_keys=True))
if wildtrack is not None:
    from gymtrack.detections import Detections
    from gymtrack.eval.wildtrack import FRAME_STEP, WildtrackSetup, noisy_detections, wildtrack_scene
    from gymtrack.formats.wildtrack import read_wildtrack_annotations, read_wildtrack_calibration
    from gymtrack.tracking.offline import track_detections
    setup = WildtrackSetup()
    rig = read_wildtrack_calibration(wildtrack)
    ann = read_wildtrack_annotations(wildtrack, rig.names, limit=setup.limit)
    d = ann.detections
    d = Detections(d.frame // FRAME_STEP, d.camera, d.box, d.score, d.track_id, d.camera_names)
    det, _ = noisy_detections(d, np.random.default_rng(setup.seed), setup)
    scene = wildtrack_scene(setup, ann.position)
    for mode in setup.modes:
        d = out / "wildtrack" / mode
        write_outputs(track_detections(rig, scene, det, mode=mode), d)
        s = d / "summary.json"
        s.write_text(json.dumps(strip(json.loads(s.read_text())), indent=1, sort_keys=True))
sums = [f"{hashlib.sha256(f.read_bytes()).hexdigest()}  {f.relative_to(out)}"
        for f in sorted(out.rglob("*")) if f.is_file() and f.name != "SHA256SUMS"]
(out / "SHA256SUMS").write_text("\n".join(sums) + "\n")
print(len(sums), "files", len(routines), "routines", file=sys.stderr)
