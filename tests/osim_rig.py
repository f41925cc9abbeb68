"""A small OpenSim model of the COCO-17 markers, scaled and driven by inverse kinematics (tests only).

OpenSim's own check that it takes gymtrack's TRC: a generic 14-segment model (pelvis free in
space; ball joints at the lumbar spine, neck, hips and shoulders; hinges at the knees and elbows;
OpenSim's axes: Y up, X forward, Z right) with a marker per COCO-17 joint is scaled to the TRC's
marker distances (ScaleTool, measurements), its markers placed on a static stretch (MarkerPlacer),
and ``InverseKinematicsSolver`` tracks every frame; the per-frame marker errors come back.
Needs the ``opensim`` package (pip wheels for CPython 3.11 on Linux).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

JOINTS = ("nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder", "right_shoulder", "left_elbow",
          "right_elbow", "left_wrist", "right_wrist", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle",
          "right_ankle")
# generic adult (m): hip width, shoulder width, trunk, thigh, shank, upper arm, forearm, neck
W, S, TR, TH, SH, UP, FO, NK = 0.2, 0.36, 0.5, 0.42, 0.40, 0.30, 0.25, 0.2


def generic_model(path: Path) -> Path:
    """Write the generic model (.osim) to ``path``."""
    import opensim as osim

    m = osim.Model()
    m.setName("gymtrack_coco17")
    V = osim.Vec3

    def body(name: str, mass: float):
        b = osim.Body(name, mass, V(0), osim.Inertia(0.005 * mass, 0.005 * mass, 0.005 * mass))
        m.addBody(b)
        return b

    def marker(name: str, b, loc) -> None:
        m.addMarker(osim.Marker(name, b, V(*loc)))

    pelvis, torso, head = body("pelvis", 10), body("torso", 25), body("head", 5)
    m.addJoint(osim.FreeJoint("ground_pelvis", m.getGround(), V(0, 1, 0), V(0), pelvis, V(0), V(0)))
    m.addJoint(osim.BallJoint("lumbar", pelvis, V(0), V(0), torso, V(0), V(0)))
    m.addJoint(osim.BallJoint("neck", torso, V(0, TR, 0), V(0), head, V(0), V(0)))
    for side, z in (("left", -1.0), ("right", 1.0)):
        s = side[0]
        femur, tibia, hum, ulna = body(f"femur_{s}", 7), body(f"tibia_{s}", 3), body(f"humerus_{s}", 2), body(f"ulna_{s}", 1.5)
        m.addJoint(osim.BallJoint(f"hip_{s}", pelvis, V(0, 0, z * W / 2), V(0), femur, V(0), V(0)))
        m.addJoint(osim.PinJoint(f"knee_{s}", femur, V(0, -TH, 0), V(0), tibia, V(0), V(0)))
        m.addJoint(osim.BallJoint(f"shoulder_{s}", torso, V(0, TR, z * S / 2), V(0), hum, V(0), V(0)))
        m.addJoint(osim.PinJoint(f"elbow_{s}", hum, V(0, -UP, 0), V(0), ulna, V(0), V(0)))
        marker(f"{side}_hip", pelvis, (0, 0, z * W / 2))
        marker(f"{side}_knee", tibia, (0, 0, 0))
        marker(f"{side}_ankle", tibia, (0, -SH, 0))
        marker(f"{side}_shoulder", torso, (0, TR, z * S / 2))
        marker(f"{side}_elbow", ulna, (0, 0, 0))
        marker(f"{side}_wrist", ulna, (0, -FO, 0))
        marker(f"{side}_eye", head, (0.08, NK + 0.03, z * 0.03))
        marker(f"{side}_ear", head, (0.0, NK, z * 0.07))
    marker("nose", head, (0.1, NK, 0))
    for j in range(m.getJointSet().getSize()):  # a gymnast turns every way: no coordinate limits
        jt = m.getJointSet().get(j)
        for c in range(jt.numCoordinates()):
            jt.get_coordinates(c).setRangeMin(-100.0)
            jt.get_coordinates(c).setRangeMax(100.0)
    m.finalizeConnections()
    m.printToXML(str(path))
    return path


def _scale_xml(generic: str, trc: str, t0: float, t1: float, out: str) -> str:
    pairs = {"pelvis": [("left_hip", "right_hip")], "torso": [("left_hip", "left_shoulder"), ("right_hip", "right_shoulder")],
             "head": [("left_ear", "right_ear"), ("left_eye", "right_eye")]}
    for s, side in (("l", "left"), ("r", "right")):
        pairs[f"femur_{s}"] = [(f"{side}_hip", f"{side}_knee")]
        pairs[f"tibia_{s}"] = [(f"{side}_knee", f"{side}_ankle")]
        pairs[f"humerus_{s}"] = [(f"{side}_shoulder", f"{side}_elbow")]
        pairs[f"ulna_{s}"] = [(f"{side}_elbow", f"{side}_wrist")]
    meas = "".join(
        f'<Measurement name="{b}"><apply>true</apply><MarkerPairSet><objects>'
        + "".join(f"<MarkerPair><markers> {a} {c}</markers></MarkerPair>" for a, c in ps)
        + f'</objects></MarkerPairSet><BodyScaleSet><objects><BodyScale name="{b}"><axes> X Y Z</axes></BodyScale>'
        "</objects></BodyScaleSet></Measurement>" for b, ps in pairs.items())
    tasks = "".join(f'<IKMarkerTask name="{n}"><apply>true</apply><weight>1</weight></IKMarkerTask>' for n in JOINTS)
    return f"""<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000"><ScaleTool name="subject"><mass>50</mass>
<GenericModelMaker><model_file>{generic}</model_file></GenericModelMaker>
<ModelScaler><apply>true</apply><scaling_order> measurements</scaling_order><MeasurementSet><objects>{meas}</objects>
</MeasurementSet><marker_file>{trc}</marker_file><time_range> {t0} {t1}</time_range>
<preserve_mass_distribution>true</preserve_mass_distribution></ModelScaler>
<MarkerPlacer><apply>true</apply><IKTaskSet><objects>{tasks}</objects></IKTaskSet><marker_file>{trc}</marker_file>
<time_range> {t0} {t1}</time_range><output_model_file>{out}</output_model_file></MarkerPlacer>
</ScaleTool></OpenSimDocument>"""


def scale_and_track(trc: Path, folder: Path, static_s: float = 0.2) -> tuple[np.ndarray, list[str]]:
    """Scale the generic model to ``trc`` (its first ``static_s`` seconds as the static trial),
    then inverse kinematics on every frame; returns the marker errors (T, 17) in metres and names."""
    import opensim as osim

    generic = generic_model(folder / "generic.osim")
    table = osim.TimeSeriesTableVec3(str(trc))
    times = np.array(table.getIndependentColumn())
    setup = folder / "scale.xml"
    rel = lambda p: os.path.relpath(p, folder)  # OpenSim reads a setup's paths from the setup's folder
    setup.write_text(_scale_xml(rel(generic), rel(trc), times[0], times[0] + static_s, rel(folder / "scaled.osim")))
    if not osim.ScaleTool(str(setup)).run():
        raise RuntimeError("OpenSim's ScaleTool failed")
    model = osim.Model(str(folder / "scaled.osim"))
    state = model.initSystem()
    weights = osim.SetMarkerWeights()
    for n in JOINTS:
        weights.cloneAndAppend(osim.MarkerWeight(n, 1.0))
    solver = osim.InverseKinematicsSolver(model, osim.MarkersReference(str(trc), weights),
                                          osim.SimTKArrayCoordinateReference(), np.inf)
    solver.setAccuracy(1e-6)
    state.setTime(times[0])
    solver.assemble(state)
    names = [solver.getMarkerNameForIndex(i) for i in range(solver.getNumMarkersInUse())]
    errs = []
    for t in times:
        state.setTime(t)
        solver.track(state)
        errs.append([solver.computeCurrentMarkerError(n) for n in names])
    return np.array(errs), names
