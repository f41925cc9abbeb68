"""Fast undistortion of many box corners: OpenCV on a grid once, bilinear lookups afterwards.

Paper: Section III-B works on undistorted pixels (the epipolar constraint and the projection
matrices hold only there). :meth:`gymtrack.geometry.camera.Camera.undistort` (OpenCV's
iterative ``undistortPointsIter``) costs about 0.1 ms per call -- per camera and window it
would be a quarter of the tracker's time budget. The distortion field is smooth, so the tracker
undistorts a grid of pixels covering the image (plus a margin) with OpenCV once per camera
and interpolates bilinearly between grid points: all cameras' boxes of a window in a handful of
numpy operations. The grid is refined until interpolation agrees with OpenCV to ``tol`` pixels
at the cell centres (checked at construction); pixels outside the grid, and cameras whose
distortion the grid cannot follow, go to OpenCV directly.
"""

from __future__ import annotations

import numpy as np

from ..geometry.camera import Camera, Rig

#: built tables by the calibration they depend on: a tracker per routine and method would
#: otherwise redo the OpenCV grid (milliseconds per camera) for the same cameras
_BUILT: dict[tuple, tuple[np.ndarray, np.ndarray, float] | None] = {}
_BUILT_MAX = 64


class UndistortTables:
    """Per-camera lookup tables of :meth:`Camera.undistort`.

    Parameters
    ----------
    rig: the cameras; cameras without distortion are passed through unchanged.
    step: initial grid spacing in pixels (halved until the accuracy check passes, down to 8;
        a camera that needs finer goes to OpenCV for every point).
    margin: the grid covers the image grown by this fraction of its size on every side (box
        corners may lie outside the image).
    tol: largest allowed interpolation error in pixels.
    """

    def __init__(self, rig: Rig, step: float = 32.0, margin: float = 0.1, tol: float = 0.05):
        self.rig = rig
        self.tol = tol
        self.tables: dict[int, tuple[np.ndarray, np.ndarray, float]] = {}  # camera -> (table, origin, step)
        self.exact: list[int] = []  # distorted cameras the grid cannot follow
        for c, cam in enumerate(rig):
            if not cam.has_distortion:
                continue
            built = self._build_cached(cam, step, margin)
            if built is None:
                self.exact.append(c)
            else:
                self.tables[c] = built

    def _build_cached(self, cam: Camera, step: float, margin: float):
        """:meth:`_build`, reused for a camera of the same calibration (the tables are read only)."""
        key = (tuple(cam.size), cam.K.tobytes(), np.asarray(cam.dist, np.float64).tobytes(), step, margin, self.tol)
        if key not in _BUILT:
            if len(_BUILT) >= _BUILT_MAX:
                _BUILT.pop(next(iter(_BUILT)))  # the oldest
            built = _BUILT[key] = self._build(cam, step, margin)
            if built is not None:  # shared between trackers: read only
                built[0].flags.writeable = built[1].flags.writeable = False
        return _BUILT[key]

    def _build(self, cam, step: float, margin: float):
        w, h = cam.size
        lo = np.array([-margin * w, -margin * h])
        hi = np.array([(1 + margin) * w, (1 + margin) * h])
        while step >= 8.0:
            nx, ny = int(np.ceil((hi[0] - lo[0]) / step)) + 1, int(np.ceil((hi[1] - lo[1]) / step)) + 1
            gu, gv = lo[0] + step * np.arange(nx), lo[1] + step * np.arange(ny)
            grid = np.stack(np.meshgrid(gu, gv), axis=-1)  # (ny, nx, 2) pixel (u, v)
            table = cam.undistort(grid)
            if np.all(np.isfinite(table)):
                mid = grid[:-1, :-1] + step / 2
                err = np.abs(_bilinear(table, lo, step, mid.reshape(-1, 2)) - cam.undistort(mid.reshape(-1, 2)))
                if err.max() <= self.tol:
                    return table, lo, step
            step /= 2
        return None

    def _stack(self):
        """All tables in one flat array per coordinate (padded to a common grid shape) and per-camera
        parameter columns, so that a lookup is one gather of parameters and a few 1D gathers."""
        cams = sorted(self.tables)
        C = len(self.rig)
        ny = max(self.tables[c][0].shape[0] for c in cams)
        nx = max(self.tables[c][0].shape[1] for c in cams)
        stacked = np.full((C, ny, nx, 2), np.nan)
        # rows, per camera: grid origin x, y; step; usable grid extent in cells x, y (-1 without a
        # table, so that no pixel is inside it)
        par = np.tile(np.array([[0.0], [0.0], [1.0], [-1.0], [-1.0]]), (1, C))
        # rows, per camera: largest first cell index in x and y, the camera's offset in the flat table
        ipar = np.zeros((3, C), np.int64)
        for c in cams:
            t, o, s = self.tables[c]
            stacked[c, : t.shape[0], : t.shape[1]] = t
            par[:, c] = (o[0], o[1], s, t.shape[1] - 1, t.shape[0] - 1)
            ipar[:, c] = (max(t.shape[1] - 2, 0), max(t.shape[0] - 2, 0), c * ny * nx)
        flat = stacked.reshape(C * ny * nx, 2)
        self._stacked = (flat[:, 0].copy(), flat[:, 1].copy(), nx, par, ipar, np.isin(np.arange(C), cams))

    def __call__(self, camera: np.ndarray, uv: np.ndarray) -> np.ndarray:
        """Undistort pixels: camera (N,) indices, uv (N, 2) raw pixels -> (N, 2) undistorted pixels."""
        out = np.asarray(uv, dtype=np.float64).copy()
        if self.tables:
            if not hasattr(self, "_stacked"):
                self._stack()
            table_u, table_v, nx, par, ipar, has = self._stacked
            # separate 1D arrays per coordinate: numpy is slow on (N, 2) arrays broadcast
            # against (N, 1) columns (an inner loop of length 2)
            lox, loy, step, sizex, sizey = np.take(par, camera, axis=1)
            hix, hiy, base = np.take(ipar, camera, axis=1)
            u, v = out[:, 0], out[:, 1]
            gx, gy = (u - lox) / step, (v - loy) / step
            use = (gx >= 0) & (gy >= 0) & (gx <= sizex) & (gy <= sizey)
            with np.errstate(invalid="ignore"):  # NaN pixels: any cell, not used
                x0 = np.minimum(np.maximum(np.floor(gx).astype(np.int64), 0), hix)
                y0 = np.minimum(np.maximum(np.floor(gy).astype(np.int64), 0), hiy)
            fx, fy = gx - x0, gy - y0
            gx, gy = 1 - fx, 1 - fy
            k = base + y0 * nx + x0  # flat index of the cell's top-left grid point
            k1, k2, k3 = k + 1, k + nx, k + nx + 1
            for col, table in ((u, table_u), (v, table_v)):
                top = table[k] * gx + table[k1] * fx
                bottom = table[k2] * gx + table[k3] * fx
                col[use] = (top * gy + bottom * fy)[use]  # col is a view into out
            far = has[camera] & ~use  # outside the grid: OpenCV
            if far.any():
                for cam_i in np.unique(camera[far]):
                    rows = np.flatnonzero(far & (camera == cam_i))
                    out[rows] = self.rig[int(cam_i)].undistort(out[rows])
        for cam_i in self.exact:
            rows = np.flatnonzero(camera == cam_i)
            if len(rows):
                out[rows] = self.rig[cam_i].undistort(out[rows])
        return out


def _bilinear(table: np.ndarray, lo: np.ndarray, step: float, uv: np.ndarray) -> np.ndarray:
    """Bilinear interpolation of a (ny, nx, 2) grid starting at ``lo`` with spacing ``step``."""
    g = (uv - lo) / step
    i0 = np.minimum(np.floor(g).astype(np.int64), np.array(table.shape[1::-1]) - 2)
    f = g - i0
    x0, y0 = i0[:, 0], i0[:, 1]
    fx, fy = f[:, :1], f[:, 1:]
    top = table[y0, x0] * (1 - fx) + table[y0, x0 + 1] * fx
    bottom = table[y0 + 1, x0] * (1 - fx) + table[y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy
