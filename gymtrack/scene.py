"""The scene: the domain knowledge for one apparatus and venue, validated with pydantic.

Paper: the performance space ``S_perf`` and buffer ``beta`` (Eq. 4), the vertical plane(s)
(Eq. 7) and further surfaces, the identification heights (Eq. 13) and every parameter of Section III-E. Defaults
are the paper's values; an ``apparatus`` preset (:mod:`gymtrack.apparatus`) fills the keys the
mapping leaves out, and keys in the mapping override the preset.

This is the domain-level model the tracker, the simulator and the evaluation share; reading and
writing ``scene.yaml`` (with errors naming the file and field) is :mod:`gymtrack.formats.scene`.
"""

from __future__ import annotations

from typing import Any, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from .apparatus import APPARATUS_NAMES, get_apparatus

__all__ = ["Vec3", "PlaneSpec", "TargetSpec", "Params", "Scene", "in_box"]

Vec3 = tuple[float, float, float]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class PlaneSpec(_Strict):
    """A plane through ``point`` with (not necessarily unit) ``normal``; stored unit-length."""

    point: Vec3
    normal: Vec3

    @field_validator("point", "normal")
    @classmethod
    def _finite(cls, v: Vec3) -> Vec3:
        if not np.all(np.isfinite(v)):
            raise ValueError("must be finite numbers")
        return v

    @field_validator("normal")
    @classmethod
    def _unit(cls, v: Vec3) -> Vec3:
        n = np.linalg.norm(v)
        if n < 1e-9:
            raise ValueError("normal must not be the zero vector")
        return tuple(float(x / n) for x in v)  # type: ignore[return-value]

    @property
    def is_vertical(self) -> bool:
        return abs(self.normal[2]) < 1e-6


class TargetSpec(_Strict):
    """Eq. 13: a track is the target when its box top rises above ``h_top`` and its box bottom
    above ``h_bot`` (metres) while inside the performance space. A real venue's calibrated floor
    lies a few centimetres off z = 0, so both may be below 0, down to the tracking space's floor
    (checked by :class:`Scene`)."""

    h_top: float = Field(2.0, allow_inf_nan=False)
    h_bot: float = Field(0.6, allow_inf_nan=False)


class Params(_Strict):
    """Tracker parameters; every default is the paper's value (Section III-E), except the
    additions beyond the paper, ``relink_frames`` and ``backfill_frames`` (0 turns each off)."""

    window: int = Field(10, ge=4, description="omega, frames per window; the step is window // 2")
    iou_threshold: float = Field(0.1, gt=0, lt=1)
    max_age: int = Field(2, ge=0, description="frames a 2D track survives without a box")
    min_tracklet_boxes: int = Field(5, ge=1, description="boxes a tracklet needs inside a window to be kept")
    cluster_2d: float = Field(0.3, gt=0, description="lambda, Algorithm 1 threshold on Eq. 2")
    cluster_plane: float = Field(0.5, gt=0, description="metres, Algorithm 1 threshold on Eq. 8")
    link_3d: float = Field(0.6, gt=0, description="metres, gate of the cross-window assignment")
    relink_frames: int = Field(
        10, ge=0, description="frames a lost 3D track can still be continued across a gap (0: the paper, no re-linking)"
    )
    max_speed: float = Field(1.0, gt=0, description="nu, metres per frame (Eq. 4)")
    identify_frames: int = Field(30, ge=1, description="Delta of Eq. 13")
    backfill_frames: int = Field(
        60, ge=0, description="frames an identification (Eq. 13) reaches back to give its track the "
        "frames without a target before it; also the target's extra latency (0: the paper, no back-fill)"
    )
    max_gap: int = Field(7, ge=0, description="target gaps up to this many frames are interpolated")
    box_scale: float = Field(1.3, ge=1.0, description="alpha of Eq. 14")
    body_half_depth: float = Field(0.25, gt=0, description="metres: half the body's extent across the plane, for Eq. 14's "
                                   "body box in views without a detection (default: the preset's; 0.8 on pommel horse)")
    opposite_angle_deg: float = Field(150.0, gt=90, le=180)
    # mode cascade+ (beyond the paper): two-view clusters fused with the plane by their uncertainty
    # (tracking.fusion). Off by default: on the default suite it meets the fusion's accuracy criteria
    # (README), but cascade+ is below 0.85 x triangulation's speed with or without it
    fuse_plane: bool = Field(False, description="cascade+ only: fuse two-view clusters with the plane (tracking.fusion)")
    plane_sigma: float = Field(0.1, gt=0, description="metres: how far the body's centre strays from the "
                               "apparatus plane along its normal (the plane prior of cascade+'s fusion); smaller "
                               "follows the plane like the paper, larger follows the rays")
    pixel_sigma: float = Field(2.0, gt=0, description="pixels: the detector's box-centre noise (cascade+)")
    box_sigma: float = Field(0.03, ge=0, description="box-centre noise as a fraction of the box height (cascade+)")
    refine_plane: int = Field(0, ge=0, description="cascade+ only: windows between online refits of the apparatus "
                              "plane from the tracker's own points (0: off; planes: auto turns it on at 20)")

    @model_validator(mode="after")
    def _window_fits(self) -> "Params":
        if self.min_tracklet_boxes > self.window:
            raise ValueError(f"min_tracklet_boxes ({self.min_tracklet_boxes}) cannot exceed window ({self.window})")
        return self

    @property
    def step(self) -> int:
        return self.window // 2


class Scene(_Strict):
    """The scene of one apparatus and venue (what a validated ``scene.yaml`` holds)."""

    apparatus: Optional[str] = None
    fps: float = Field(30.0, gt=0)
    performance_space: tuple[float, float, float, float, float, float]
    buffer: float = Field(1.0, ge=0, description="beta: S_track is S_perf grown by beta in x and y")
    focus: Optional[Vec3] = Field(
        None, description="where the apparatus (the action) is; two views are judged opposite there. "
        "Default: the centre of the performance space"
    )
    planes: tuple[PlaneSpec, ...] = ()
    surfaces: tuple[PlaneSpec, ...] = Field(
        (), description="further surfaces the body's centre keeps to where the vertical plane does not hold "
        "(e.g. the pommel horse's horizontal support surface); the plane stage uses them when the recipe's "
        "``surfaces`` is on. Default: the preset's"
    )
    auto_planes: bool = Field(False, description="``planes: auto`` in scene.yaml: the apparatus plane is fitted "
                              "from the data before tracking (the preset's planes, if any, are the starting guess)")
    target: TargetSpec = TargetSpec()
    params: Params = Params()
    first_frame: int = Field(1, ge=0, description="frame number of the first frame of every video (videos/<camera>.*)")
    video_offsets: dict[str, int] = Field(
        default_factory=dict, description="camera -> frames: file frame k of that camera's video is frame "
        "first_frame + k - offset (a camera that started recording n frames early has offset n)"
    )
    frame_offsets: dict[str, int] = Field(
        default_factory=dict, description="camera -> frames: that camera's detections and keypoints of frame f "
        "are frame f - offset of the routine (a camera whose frame numbers run n ahead has offset n; gymtrack sync)"
    )

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: Any) -> Any:
        if isinstance(data, dict) and isinstance(data.get("planes"), str):
            if data["planes"] != "auto":
                raise ValueError(f"planes must be a list of planes or 'auto', got {data['planes']!r}")
            data = {k: v for k, v in data.items() if k != "planes"} | {"auto_planes": True}
        if not isinstance(data, dict) or data.get("apparatus") is None:
            return data
        name = data["apparatus"]
        if name not in APPARATUS_NAMES:
            raise ValueError(f"unknown apparatus {name!r}; choose one of {', '.join(APPARATUS_NAMES)}")
        app = get_apparatus(name)
        merged = {
            "performance_space": list(app.performance_space),
            "planes": [{"point": list(app.plane_point), "normal": list(app.plane_normal)}],
            "target": {"h_top": app.h_top, "h_bot": app.h_bot},
            "focus": list(app.focus),
        }
        if app.surfaces:
            merged["surfaces"] = [{"point": list(pt), "normal": list(nm)} for pt, nm in app.surfaces]
        merged.update({k: v for k, v in data.items()})
        half_depth = app.body_half_depth  # the preset's Eq. 14 body box, unless the scene's params say
        if half_depth != Params.model_fields["body_half_depth"].default and not isinstance(data.get("params"), Params):
            merged["params"] = {"body_half_depth": half_depth, **(data.get("params") or {})}
        if isinstance(data.get("target"), dict):  # partial override of the preset heights
            merged["target"] = {"h_top": app.h_top, "h_bot": app.h_bot, **data["target"]}
        return merged

    @field_validator("focus")
    @classmethod
    def _finite_focus(cls, v):
        if v is not None and not np.all(np.isfinite(v)):
            raise ValueError("must be finite numbers")
        return v

    @field_validator("performance_space")
    @classmethod
    def _box(cls, v):
        if not np.all(np.isfinite(v)):
            raise ValueError("must be finite numbers")
        if not (v[0] < v[3] and v[1] < v[4] and v[2] < v[5]):
            raise ValueError(f"must be [xmin, ymin, zmin, xmax, ymax, zmax] with min < max, got {list(v)}")
        return v

    @model_validator(mode="after")
    def _heights_in_space(self) -> "Scene":
        zmin = self.performance_space[2]
        for name in ("h_bot", "h_top"):
            if getattr(self.target, name) < zmin:
                raise ValueError(f"target.{name} ({getattr(self.target, name):g} m) lies below the tracking space's "
                                 f"floor (performance_space zmin {zmin:g} m): lower zmin to where the venue's floor is")
        return self

    # ------------------------------------------------------------------ derived
    @property
    def tracking_space(self) -> np.ndarray:
        """(6,) ``S_track``: ``S_perf`` grown by ``buffer`` in x and y (paper Sec. III-B)."""
        s = np.array(self.performance_space, dtype=np.float64)
        b = self.buffer
        return s + np.array([-b, -b, 0.0, b, b, 0.0])

    @property
    def focus_point(self) -> np.ndarray:
        """(3,) the point where camera pairs are judged opposite: ``focus`` or the centre of ``S_perf``."""
        if self.focus is not None:
            return np.array(self.focus, dtype=np.float64)
        s = np.array(self.performance_space, dtype=np.float64)
        return (s[:3] + s[3:]) / 2

    def to_yaml_dict(self) -> dict:
        """The plain mapping ``scene.yaml`` holds (:func:`gymtrack.formats.scene.save_scene` writes it)."""
        d = self.model_dump(mode="json")
        if d["first_frame"] == 1 and not d["video_offsets"]:  # files without videos stay as they were
            del d["first_frame"], d["video_offsets"]
        if not d["frame_offsets"]:  # (files without offsets stay as they were)
            del d["frame_offsets"]
        if not d["surfaces"]:  # (files without surfaces stay as they were)
            del d["surfaces"]
        if d.pop("auto_planes"):
            d["planes"] = "auto"
        return d


def in_box(points: np.ndarray, box: np.ndarray) -> np.ndarray:
    """(..., 3) points, (6,) box ``[xmin, ymin, zmin, xmax, ymax, zmax]`` -> (...) bool.

    Inside means on or within the box's faces; a NaN coordinate is outside.
    """
    p = np.asarray(points, dtype=np.float64)
    b = np.asarray(box, dtype=np.float64)
    return np.all((p >= b[:3]) & (p <= b[3:]), axis=-1)
