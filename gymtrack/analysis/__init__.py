"""The judging layer: what judges, coaches and judging-support systems read off the 3D skeleton.

Paper: Section III-D, last paragraph and Fig. 8 -- the 3D pose sequence segmented and measured
against the Code of Points. Contract: ``shared/formats.md``, "Outputs of the analysis stage";
user documentation: ``docs/analysis.md``.

Modules: :mod:`.joints` (joints used, per-joint sigma), :mod:`.kinematics` (angles, de Leva
centre of mass), :mod:`.support` (floor / apparatus / airborne), :mod:`.filtering` (per support
segment), :mod:`.rotation` (somersault and twist), :mod:`.uncertainty` (Monte Carlo), :mod:`.flights`,
:mod:`.elements` (landings, holds, circles, turns), :mod:`.api` (:func:`analyse`, :class:`Analysis`).
"""

from .api import Analysis, analyse

__all__ = ["Analysis", "analyse"]
