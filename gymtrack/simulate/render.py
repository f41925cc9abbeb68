"""Rendered video of a simulated routine: every view as frames, for end-to-end tests of videos.

Paper: Section III-A (a person detector runs on every frame of every view) and III-D (a pose
model runs on high-resolution crops of b_buf) need images; the paper's videos are private, so
the simulator draws its own: people as shaded body-part capsules around the simulated skeleton
(:mod:`.body`: joints and helper points), the apparatus and the floor in plain colours, seen
through each camera with its lens distortion.

How: each view is drawn as an ideal pinhole image on a canvas a little larger than the frame
(barrel distortion pulls pixels from outside the undistorted frame), then ``cv2.remap`` bends it
into the raw (distorted) image with a map computed once per camera (``Camera.undistort`` of
every output pixel). Every body point of every frame is projected with one matrix product per
camera; capsules are drawn far to near (painter's order) as OpenCV's round-capped thick lines,
bars cut into short pieces so they sort against people. No random numbers: the routine's other
files are the same with or without videos.

Shapes: body points (P, T, K, 3) world metres; images (H, W, 3) uint8 BGR.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import cv2
import numpy as np

from ..apparatus import Apparatus
from ..geometry.camera import Camera
from . import body as B

_NAMES = B.POINT_NAMES + ("mid_hip", "neck")  # two derived points appended to the body's points
_I = {n: i for i, n in enumerate(_NAMES)}
_TORSO, _LEGS, _SKIN, _FEET = range(4)
#: Body parts: (from, to, radius in metres for a 1.70 m body, colour slot). from == to is a sphere.
PARTS: tuple[tuple[str, str, float, int], ...] = (
    ("mid_hip", "neck", 0.11, _TORSO), ("left_hip", "right_hip", 0.085, _TORSO),
    ("left_shoulder", "right_shoulder", 0.055, _TORSO), ("neck", "head_centre", 0.045, _SKIN),
    ("head_centre", "head_centre", 0.10, _SKIN),
    ("left_shoulder", "left_elbow", 0.045, _TORSO), ("right_shoulder", "right_elbow", 0.045, _TORSO),
    ("left_elbow", "left_wrist", 0.035, _SKIN), ("right_elbow", "right_wrist", 0.035, _SKIN),
    ("left_wrist", "left_hand", 0.025, _SKIN), ("right_wrist", "right_hand", 0.025, _SKIN),
    ("left_hip", "left_knee", 0.07, _LEGS), ("right_hip", "right_knee", 0.07, _LEGS),
    ("left_knee", "left_ankle", 0.05, _LEGS), ("right_knee", "right_ankle", 0.05, _LEGS),
    ("left_heel", "left_toe", 0.03, _FEET), ("right_heel", "right_toe", 0.03, _FEET),
)
_PA = np.array([_I[a] for a, _, _, _ in PARTS])
_PB = np.array([_I[b] for _, b, _, _ in PARTS])
_PR = np.array([r for _, _, r, _ in PARTS])
_PSLOT = np.array([s for _, _, _, s in PARTS])

#: Clothing colours (BGR) by role; the target wears a red leotard.
ROLE_COLOURS = {"target": (50, 40, 200), "coach": (40, 120, 220), "judge": (70, 120, 50), "gymnast": (150, 60, 130),
                "spectator": (120, 115, 110)}
SKIN = (120, 160, 215)
FLOOR, MAT, WALL, GRID = (150, 165, 175), (160, 105, 55), (95, 90, 88), (125, 140, 150)
BLOCK, BAR, POST = (105, 150, 190), (185, 185, 190), (90, 90, 95)
NEAR = 0.2  # metres: parts closer to a camera than this are not drawn
_SHIFT = 3  # sub-pixel bits of OpenCV's drawing calls
_BAR_PIECE = 0.4  # metres: bars are drawn in pieces this long so they sort against people


@dataclass(frozen=True, eq=False)
class ViewCanvas:
    """How one camera's frames are drawn.

    size: (w, h) output frame; K: (3, 3) world-camera to canvas *pixel index* (scale, offset
    and the half-pixel shift folded in); canvas: (cw, ch); maps: ``cv2.remap`` maps from the
    output frame into the canvas (None without distortion: the canvas is the frame).
    """

    camera: Camera
    size: tuple[int, int]
    K: np.ndarray
    canvas: tuple[int, int]
    maps: tuple[np.ndarray, np.ndarray] | None


def view_canvas(cam: Camera, width: int | None = None) -> ViewCanvas:
    """The canvas of ``cam`` for frames ``width`` pixels wide (default the camera's; height keeps
    the aspect, both even for yuv420p video)."""
    W, H = cam.size
    w = int(width or W) // 2 * 2
    h = max(2, int(round(H * w / W)) // 2 * 2)
    s = w / W
    Ks = np.diag([s, s, 1.0]) @ cam.K
    if not cam.has_distortion:
        off = np.zeros(2)
        canvas, maps = (w, h), None
    else:
        # continuous raw coordinates of every output pixel centre -> undistorted, scaled
        gx, gy = np.meshgrid((np.arange(w) + 0.5) / s, (np.arange(h) + 0.5) / s)
        und = cam.undistort(np.stack([gx, gy], -1)) * s
        lo = np.floor(np.nanmin(und, axis=(0, 1))) - 2
        hi = np.ceil(np.nanmax(und, axis=(0, 1))) + 2
        lo, hi = np.maximum(lo, [-w, -h]), np.minimum(hi, [2 * w, 2 * h])  # wild lenses: cap the canvas
        off = -lo
        canvas = (int(hi[0] - lo[0]), int(hi[1] - lo[1]))
        m = np.nan_to_num(und + off - 0.5, nan=-1.0).astype(np.float32)
        maps = cv2.convertMaps(m[..., 0], m[..., 1], cv2.CV_16SC2)
    K = Ks.copy()
    K[:2, 2] += off - 0.5
    return ViewCanvas(cam, (w, h), K, canvas, maps)


def _project(vc: ViewCanvas, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(..., 3) world points -> (..., 2) canvas pixel index and (...,) depth (NaN behind)."""
    Xc = X @ vc.camera.R.T + vc.camera.t
    z = Xc[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = (Xc @ vc.K.T)[..., :2] / z[..., None]
    return np.where((z > NEAR)[..., None], uv, np.nan), np.where(z > NEAR, z, np.nan)


def _ints(uv: np.ndarray) -> np.ndarray:
    return np.round(np.clip(uv, -1e5, 1e5) * (1 << _SHIFT)).astype(np.int32)


def _shade(c, f: float) -> tuple[int, int, int]:
    return tuple(int(min(255, v * f)) for v in c)


def background(vc: ViewCanvas, app: Apparatus) -> np.ndarray:
    """(ch, cw, 3) the static scene on the canvas: wall, floor with a 1 m grid, the mat under the
    performance space, blocks (face-shaded) and the posts that hold bars, beams and rings."""
    cam = vc.camera
    cw, ch = vc.canvas
    gx, gy = np.meshgrid(np.arange(cw, dtype=np.float32), np.arange(ch, dtype=np.float32))
    pix = np.stack([gx, gy, np.ones_like(gx)], -1) @ np.linalg.inv(vc.K).T.astype(np.float32)
    ray = pix @ cam.R.astype(np.float32)  # row-vector form of R.T @ v
    C = cam.centre
    with np.errstate(divide="ignore", invalid="ignore"):
        d = -C[2] / ray[..., 2]
    floor = (ray[..., 2] < 0) & (d * np.linalg.norm(ray, axis=-1) < 80.0)
    d = np.where(floor, d, 0.0)  # rays that miss the floor: any finite value, they are masked
    x, y = C[0] + d * ray[..., 0], C[1] + d * ray[..., 1]
    s = np.asarray(app.performance_space)
    img = np.empty((ch, cw, 3), np.float32)
    img[:] = WALL
    img[floor] = FLOOR
    line = floor & ((np.abs(x - np.round(x)) < 0.015) | (np.abs(y - np.round(y)) < 0.015))
    img[line] = GRID
    img[floor & (x > s[0]) & (x < s[3]) & (y > s[1]) & (y < s[4])] = MAT
    fog = np.clip(np.where(floor, d * np.linalg.norm(ray, axis=-1), 80.0) / 80.0, 0, 1)[..., None] * 0.6
    img = (img * (1 - fog) + np.asarray(WALL, np.float32) * fog).astype(np.uint8)
    for a, b, r in _posts(app):
        _capsule(vc, img, np.array([a, b]), r, POST, shaded=False)
    for blk in app.blocks:
        _block(vc, img, np.asarray(blk.lo, float), np.asarray(blk.hi, float))
    return img


def _posts(app: Apparatus) -> list[tuple[tuple, tuple, float]]:
    """(from, to, radius) of the supports: posts under level bars and blocks, ropes above rings."""
    out = []
    for bar in app.bars:
        a, b = np.asarray(bar.start, float), np.asarray(bar.end, float)
        if abs(a[2] - b[2]) < 1e-6 and a[2] > 0.3:
            out += [((*p[:2], 0.0), tuple(p), 0.03) for p in (a, b)]
        elif b[2] > a[2]:  # a ring: its rope
            out.append((tuple(b), (b[0], b[1], 5.8), 0.01))
    for blk in app.blocks:
        lo, hi = np.asarray(blk.lo, float), np.asarray(blk.hi, float)
        if lo[2] > 0.1:
            c = (lo + hi) / 2
            for fx in (-0.35, 0.35):
                x = c[0] + fx * (hi[0] - lo[0])
                out.append(((x, c[1], 0.0), (x, c[1], lo[2]), 0.05))
    return out


def _capsule(vc: ViewCanvas, img: np.ndarray, ends: np.ndarray, radius: float, colour, shaded: bool = True) -> None:
    """Draw a 3D capsule ``ends`` (2, 3) of ``radius`` metres on ``img`` (canvas)."""
    uv, z = _project(vc, ends)
    if not np.all(np.isfinite(z)):
        return
    _draw(img, uv[0], uv[1], vc.K[0, 0] * radius / z.mean(), colour, shaded)


def _draw(img: np.ndarray, a: np.ndarray, b: np.ndarray, r: float, colour, shaded: bool) -> None:
    """A shaded capsule from canvas point ``a`` to ``b`` (2,) of radius ``r`` pixels."""
    if shaded and r > 2.0:
        layers = ((1.0, 0.0, 0.62), (0.7, -0.18, 1.0), (0.3, -0.4, 1.35))  # rim, body, highlight: lit from above
    else:
        layers = ((1.0, 0.0, 1.0),)
    for f, dy, k in layers:
        o = np.array([0.0, dy * r])
        p, q = _ints(a + o), _ints(b + o)
        cv2.line(img, (int(p[0]), int(p[1])), (int(q[0]), int(q[1])), _shade(colour, k), max(1, int(round(2 * r * f))),
                 cv2.LINE_AA, _SHIFT)


def _block(vc: ViewCanvas, img: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
    """The faces of an axis-aligned box that face the camera, shaded by their normal."""
    C = vc.camera.centre
    for axis in range(3):
        for side in (0, 1):
            n = np.zeros(3)
            n[axis] = 1.0 if side else -1.0
            face_c = (lo + hi) / 2
            face_c[axis] = hi[axis] if side else lo[axis]
            if np.dot(C - face_c, n) <= 0:
                continue
            u, v = [k for k in range(3) if k != axis]
            quad = np.array([face_c] * 4)
            for i, (su, sv) in enumerate(((0, 0), (1, 0), (1, 1), (0, 1))):
                quad[i, u] = hi[u] if su else lo[u]
                quad[i, v] = hi[v] if sv else lo[v]
            uv, z = _project(vc, quad)
            if np.all(np.isfinite(z)):
                k = 1.15 if axis == 2 else (0.85 if axis == 0 else 0.7)
                cv2.fillConvexPoly(img, _ints(uv), _shade(BLOCK, k), cv2.LINE_AA, _SHIFT)


def _bar_pieces(app: Apparatus) -> tuple[np.ndarray, np.ndarray]:
    """(Q, 2, 3) short pieces of every bar and (Q,) their radii."""
    ends, radii = [], []
    for bar in app.bars:
        a, b = np.asarray(bar.start, float), np.asarray(bar.end, float)
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / _BAR_PIECE)))
        f = np.linspace(0, 1, n + 1)[:, None]
        p = a + f * (b - a)
        ends += list(np.stack([p[:-1], p[1:]], 1))
        radii += [bar.radius] * n
    return np.array(ends).reshape(-1, 2, 3), np.array(radii)


def _with_derived(points: np.ndarray) -> np.ndarray:
    """(..., K, 3) body points -> (..., K + 2, 3) with the hip centre and the neck appended."""
    mid_hip = points[..., [_I["left_hip"], _I["right_hip"]], :].mean(-2, keepdims=True)
    neck = points[..., [_I["left_shoulder"], _I["right_shoulder"]], :].mean(-2, keepdims=True)
    return np.concatenate([points, mid_hip, neck], axis=-2)


def person_colours(role: np.ndarray, person_id: np.ndarray) -> np.ndarray:
    """(P, 4, 3) colours of the four slots (torso, legs, skin, feet) of every person; a person's
    id varies the shade so neighbours differ."""
    out = np.empty((len(role), 4, 3))
    for i, (r, pid) in enumerate(zip(role, person_id)):
        base = np.asarray(ROLE_COLOURS.get(str(r), ROLE_COLOURS["spectator"]), float)
        base = np.clip(base * (0.8 + 0.4 * ((int(pid) * 37) % 11) / 10), 0, 255)
        bare = str(r) in ("target", "gymnast")
        out[i] = [base, SKIN if bare else base * 0.6, SKIN, SKIN if bare else (50, 50, 55)]
    return out


def _draw_many(img: np.ndarray, a: np.ndarray, b: np.ndarray, r: np.ndarray, colour: np.ndarray) -> None:
    """Shaded capsules in the given order: ends ``a``, ``b`` (n, 2) pixel index, radii ``r`` (n,)
    pixels, ``colour`` (n, 3). The numbers are prepared for all at once; the loop only draws."""
    layers = ((1.0, 0.0, 0.62), (0.7, -0.18, 1.0), (0.3, -0.4, 1.35))  # rim, body, highlight: lit from above
    calls = []
    for f, dy, k in layers:
        o = np.stack([np.zeros_like(r), dy * r], -1)
        thick = np.maximum(1, np.round(2 * r * f)).astype(int)
        col = np.clip(colour * k, 0, 255).astype(int)
        keep = (r > 2.0) | (f == 1.0)  # small parts: one flat layer
        calls.append((_ints(a + o).tolist(), _ints(b + o).tolist(), thick.tolist(), col.tolist(), keep.tolist()))
    for i in range(len(r)):
        for p, q, th, col, keep in calls:
            if keep[i]:
                cv2.line(img, p[i], q[i], col[i], th[i], cv2.LINE_AA, _SHIFT)


def render_view(sim, camera: int, width: int | None = None) -> Iterator[np.ndarray]:
    """Frames of one view of ``sim`` (a :class:`~.routine.SimulatedRoutine`), in frame order:
    (h, w, 3) uint8 BGR, ``w = width`` (default the camera's width).

    The static scene is drawn undistorted and remapped once; people and bars are drawn straight
    between their distorted end points (parts are short: the bend a lens gives them is far
    below a pixel at these distortions)."""
    if sim.body_points is None:
        raise ValueError("render_view needs a SimulatedRoutine with body_points (simulate_routine keeps them)")
    cam = sim.rig[camera]
    vc = view_canvas(cam, width)
    bg = background(vc, sim.app)
    if vc.maps is not None:
        bg = cv2.remap(bg, vc.maps[0], vc.maps[1], cv2.INTER_LINEAR)
    s = vc.size[0] / cam.size[0]
    f = s * cam.K[0, 0]

    def project(X):
        z = cam.depth(X)
        return s * cam.project(X) - 0.5, np.where(z > NEAR, z, np.nan)

    uv, z = project(_with_derived(sim.body_points))  # (P, T, K + 2, 2), (P, T, K + 2)
    ua, ub = uv[:, :, _PA], uv[:, :, _PB]  # (P, T, S, 2)
    depth = (z[:, :, _PA] + z[:, :, _PB]) / 2  # (P, T, S)
    rad = f * ((sim.height / 1.70)[:, None] * _PR[None])[:, None, :] / depth
    ok = np.isfinite(depth) & np.all(np.isfinite(ua) & np.isfinite(ub), -1)
    w, h = vc.size
    lo, hi = np.minimum(ua, ub) - rad[..., None], np.maximum(ua, ub) + rad[..., None]
    ok &= (hi[..., 0] > 0) & (hi[..., 1] > 0) & (lo[..., 0] < w) & (lo[..., 1] < h)
    colours = person_colours(sim.role, sim.person_id)[:, _PSLOT]  # (P, S, 3)
    bars, bar_r = _bar_pieces(sim.app)
    buv, bz = project(bars)  # (Q, 2, 2), (Q, 2)
    bd = bz.mean(-1)
    bok = np.isfinite(bd) & np.all(np.isfinite(buv), axis=(1, 2))
    ba, bb, bd, brad = buv[bok, 0], buv[bok, 1], bd[bok], f * bar_r[bok] / bd[bok]
    bcol = np.broadcast_to(np.asarray(BAR, float), (len(bd), 3))
    for t in range(sim.n_frames):
        img = bg.copy()
        p, si = np.nonzero(ok[:, t])
        order = np.argsort(-np.concatenate([depth[p, t, si], bd]), kind="stable")
        _draw_many(img, np.concatenate([ua[p, t, si], ba])[order], np.concatenate([ub[p, t, si], bb])[order],
                   np.concatenate([rad[p, t, si], brad])[order], np.concatenate([colours[p, si], bcol])[order])
        yield img


def write_videos(sim, out: str | Path, width: int | None = None, options: dict | None = None,
                 progress: Callable[[str, int], None] | None = None) -> dict[str, Path]:
    """Render every view of ``sim`` to ``<out>/videos/<camera>.mp4`` (H.264; frame k is frame
    k + 1 of the routine). ``width``: frame width (default the cameras'; smaller for quick
    previews and tests -- pixels then scale by width / camera width). Returns camera -> path."""
    from ..formats.video import write_video

    folder = Path(out) / "videos"
    folder.mkdir(parents=True, exist_ok=True)
    opts = options or {"crf": "23", "preset": "veryfast"}
    paths = {}
    for c, name in enumerate(sim.rig.names):
        path = folder / f"{name}.mp4"
        n = write_video(path, render_view(sim, c, width), sim.fps, options=opts)
        if progress is not None:
            progress(name, n)
        paths[name] = path
    return paths
