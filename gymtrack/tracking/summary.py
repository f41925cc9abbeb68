"""The streaming tracker's summary: what each stage used, made and dropped, and its timings.

Paper: Section III (Fig. 2), the counts of every stage of :class:`~.tracker.Tracker`; nothing the
user gave is dropped without being counted here. The counters of an ingredient beyond the paper
(:class:`gymtrack.modes.Method`) are reported only when the recipe has it, so the paper's modes'
summaries hold only the paper's counters. A recipe other than the named one of its name adds its
ingredients (``recipe``).
"""

from __future__ import annotations

from dataclasses import asdict

from ..modes import RECIPES
from .fusion import COUNTS as FUSION_COUNTS
from .single_view_motion import COUNTS as VIEW_COUNTS

__all__ = ["COUNTS", "INGREDIENT_COUNTS", "STAGES", "tracker_summary"]

#: the per-window counters of :meth:`Tracker.summary` (what was used, made, dropped)
COUNTS = ("windows", "segments", "segments_dropped_short", "clusters_triangulated", "segments_to_plane",
          "plane_tracklets", "segments_dropped_single", "tracklets_outliers", "links", "relinks", "plane_single_view",
          "plane_single_view_unlinked", "floor_tracklets", "segments_to_floor", "floor_ghosts",
          "segments_dropped_ghost", "plane_single_view_outside", "links_2d", "fused_plane", "fused_triangulated",
          "fused_to_plane_stage")
#: the counters of the ingredients beyond the paper, in the summary of a recipe that has them
INGREDIENT_COUNTS: dict[str, tuple[str, ...]] = {
    "image_motion": VIEW_COUNTS, "exclusion": ("points_suppressed",),
    "floor": ("floor_single_view",), "ghost_test": ("floor_ghosts_confirmed",), "keep_older": ("links_older",),
    "handover": ("target_handovers",), "ballistic": ("ballistic_handovers", "ballistic_points"),
    "regroup": ("segments_regrouped", "regrouped_left_out"), "rejoin": ("links_own",), "reidentify": ("target_reidentifications", "target_frames_taken_over"),
    "reach": ("target_points_out_of_reach",), "chain": ("target_frames_chained",), "lone": ("segments_lone",),
    "regain": ("target_regained_views",),
}
STAGES = ("single_view", "windows", "clustering", "triangulation", "plane", "linking", "finalise", "target", "venue")


def tracker_summary(t) -> dict:
    """Counts and timings so far: frames with boxes, detections read / used / dropped per
    camera, tracks, target frames and switches, seconds per stage, frames (with boxes) per second."""
    frames = t.frames
    total = sum(t.timings.values())
    names = t.names
    s = {
        "mode": t.mode,
        "association": t.association,
        "frames": frames,
        "first_frame": t.first_frame,
        "last_frame": t.last_frame,
        "detections_read": {n: int(v) for n, v in zip(names, t.read)},
        "detections_used": {n: int(v) for n, v in zip(names, t.used)},
        "tracks": int(t.linker.next_track_id),  # every track has at least one point
        "target_frames": int(t.target.frames),
        "target_switches": int(t.target.switches),
        "target_identifications": int(t.target.identifications),
        **{k: int(t.counts[k]) for k in COUNTS + _ingredient_counts(t.method)
           + (FUSION_COUNTS if t.fusion is not None else ())},
        "seconds": {k: round(v, 6) for k, v in t.timings.items()},
        "seconds_total": round(total, 6),
        "fps": round(frames / total, 1) if total > 0 else None,
    }
    if t.method.exclusion:
        s["points_superseded"] = int(t.records.dropped)
    if t.method != RECIPES.get(t.method.name):  # a recipe of its own: what it is
        s["recipe"] = asdict(t.method)
    if t.refiner is not None:
        s["plane_refinement"] = t.refiner.summary()
    if t.association == "oracle":
        s["detections_dropped_false_positive"] = {n: int(v) for n, v in zip(names, t.false_positives)}
        s["detections_dropped_duplicate"] = int(t.counts["duplicates"])
    s.update(t.venue.summary())  # a knocked or unsynchronised camera (only when there is one)
    return s


def _ingredient_counts(method) -> tuple[str, ...]:
    """The counter names of the recipe's ingredients beyond the paper, in a fixed order."""
    return sum((INGREDIENT_COUNTS[k] for k in INGREDIENT_COUNTS if getattr(method, k)), ())
