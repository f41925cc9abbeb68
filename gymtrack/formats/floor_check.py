"""Where the standing people's feet are: the venue's floor height, measured from the boxes.

Paper: Eq. 13 identifies the target by its box top above ``h_top`` and its box bottom above
``h_bot``; both heights assume the calibrated floor at z = 0. A real venue's floor is often a few
centimetres off (the calibration board lay on a mat, the origin on a podium), and then a person
standing still has box bottoms at -0.1 m, not at the -0.03 m a detector's box reaches below the soles. ``gymtrack info`` reports where they lie so the
user can set ``h_bot`` and ``performance_space`` to the floor that is.

Method: in up to ``max_frames`` frames, every pair of boxes of two views whose centres agree
(paper Eq. 1 below ``gate``) is triangulated at its bottom-centre and top-centre (undistorted);
a pair whose top lies 1.3-2.2 m above its bottom is a standing person, whose bottom is the floor
under them. The median and the 10-90 % range of those bottoms are reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..detections import Detections
from ..geometry.camera import Rig
from ..geometry.epipolar import epipolar_distance, fundamental_matrices
from ..geometry.triangulation import triangulate

__all__ = ["FloorEstimate", "standing_bottoms"]


@dataclass(frozen=True)
class FloorEstimate:
    """Box bottoms (metres, world z) of pairs seen as standing people: median, 10 % and 90 % quantiles."""

    pairs: int
    median: float
    low: float
    high: float

    def advice(self, zmin: float, h_bot: float) -> str | None:
        """What to change in scene.yaml when the floor lies below the performance space or h_bot."""
        if self.median < zmin - 0.1:  # boxes reach a few cm below the soles: only a clear offset is news
            return (f"standing people's box bottoms (z = {self.median:+.2f} m) lie below the performance space's zmin "
                    f"({zmin:g} m): the calibrated floor is off z = 0; lower performance_space's zmin to about "
                    f"{self.median - 0.05:.2f}, and measure target.h_bot ({h_bot:g} m) from that floor")
        return None

    def describe(self) -> str:
        return (f"standing people's box bottoms lie at z = {self.median:+.2f} m (10-90 %: {self.low:+.2f} .. "
                f"{self.high:+.2f} m, {self.pairs} two-view pairs)")


def _same_frame(fa: np.ndarray, fb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs ``(ia, ib)`` with ``fa[ia] == fb[ib]``, vectorised."""
    order = np.argsort(fb, kind="stable")
    lo, hi = np.searchsorted(fb[order], fa, "left"), np.searchsorted(fb[order], fa, "right")
    n = hi - lo
    ia = np.repeat(np.arange(fa.size), n)
    ib = order[np.repeat(lo - np.cumsum(n) + n, n) + np.arange(ia.size)] if ia.size else np.zeros(0, np.int64)
    return ia, ib


def standing_bottoms(det: Detections, rig: Rig, max_frames: int = 100, gate: float = 0.1,
                     min_pairs: int = 20) -> FloorEstimate | None:
    """The :class:`FloorEstimate` of the routine's boxes (module docstring); None with fewer than
    ``min_pairs`` standing pairs."""
    frames = np.unique(det.frame)
    if frames.size > max_frames:
        frames = frames[np.linspace(0, frames.size - 1, max_frames).astype(np.int64)]
    d = det.select(np.isin(det.frame, frames))
    if not len(d) or len(rig) < 2:
        return None
    box = d.box.astype(np.float64)
    cam = d.camera.astype(np.int64)
    und = np.empty_like(box)
    pts = {}
    for c, camera in enumerate(rig):
        m = cam == c
        if m.any():
            b = box[m]
            centre = camera.undistort(b[:, :2])
            bottom = camera.undistort(b[:, :2] + np.column_stack([np.zeros(len(b)), b[:, 3] / 2]))
            top = camera.undistort(b[:, :2] - np.column_stack([np.zeros(len(b)), b[:, 3] / 2]))
            und[m] = np.column_stack([centre, b[:, 2:]])
            pts[c] = (np.flatnonzero(m), bottom, top)
    F = fundamental_matrices(rig)
    P = rig.projections
    bottoms = []
    for i in range(len(rig)):
        for j in range(i + 1, len(rig)):
            if i not in pts or j not in pts:
                continue
            ri, bi, ti = pts[i]
            rj, bj, tj = pts[j]
            a, b = _same_frame(d.frame[ri], d.frame[rj])
            keep = epipolar_distance(und[ri][a], und[rj][b], F[i, j]) < gate
            a, b = a[keep], b[keep]
            if not a.size:
                continue
            Pij = P[[i, j]]
            Xb, _ = triangulate(Pij, np.stack([bi[a], bj[b]], axis=1), iterations=0)
            Xt, _ = triangulate(Pij, np.stack([ti[a], tj[b]], axis=1), iterations=0)
            h = Xt[:, 2] - Xb[:, 2]
            ok = np.isfinite(h) & (h > 1.3) & (h < 2.2)
            bottoms.append(Xb[ok, 2])
    z = np.concatenate(bottoms) if bottoms else np.zeros(0)
    if z.size < min_pairs:
        return None
    lo, med, hi = np.quantile(z, [0.1, 0.5, 0.9])
    return FloorEstimate(int(z.size), float(med), float(lo), float(hi))
