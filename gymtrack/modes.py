"""The tracker's modes: the paper's method, its ablation (Table 4) and the mode beyond it.

Paper: Section III-C and Table 4. ``cascade`` is the paper's method (triangulation, then the
vertical plane for single views and opposite pairs); ``triangulation`` and ``plane`` are its
ablation; ``cascade+`` goes beyond the paper (issue 12: the floor hypothesis, motion links,
duplicate exclusion, opt-in ray/plane fusion and online plane refinement; see
:mod:`gymtrack.tracking.tracker`). A plain module of constants, so that the command line can name
the default without importing the tracker.
"""

from __future__ import annotations

__all__ = ["MODES", "DEFAULT_MODE"]

MODES: tuple[str, ...] = ("cascade", "triangulation", "plane", "cascade+")
#: the mode a Tracker, the offline runners, batch and the command line use unless told otherwise:
#: ``cascade+`` since the benchmark met every target of issue 12 in one run (all people's MOTA /
#: IDF1, WILDTRACK, the target no worse than the cascade, >= 0.85 x triangulation's speed); the
#: paper's method stays ``mode="cascade"``
DEFAULT_MODE = "cascade+"
