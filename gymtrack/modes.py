"""The tracker's recipes: each choice the tracker makes, named, and the modes as rows of one table.

Paper: Section III-C and Table 4. A :class:`Method` is a frozen recipe: one field per choice the
:class:`~gymtrack.tracking.tracker.Tracker` makes (its *ingredients*); the stages get these
choices as plain arguments, so no stage tests a mode's name. :data:`RECIPES` names four of them:

* ``cascade``: the paper's method (triangulation, then the vertical plane for single views and
  opposite pairs);
* ``triangulation`` and ``plane``: its ablation (Table 4): no plane stage, or every segment to it;
* ``cascade+``: the cascade and every ingredient beyond the paper (the floor hypothesis, the
  floor's ghost test, Eq. 4 on the tracklet's mean, the image-motion tracker at low
  frame rates, duplicate exclusion, the older track kept, Eq. 12 over the best-observed estimates,
  one view alone only inside the performance space, the shorter end-box hold, the target's
  handover and its ballistic flights, a dropped cluster's opposite pairs regrouped on the plane and
  rejoining their track, Eq. 13
  counting a raised point away from the apparatus only for a flight's length, the identification's
  look-back following the track its target continues; ray/plane fusion and
  online plane refinement where the scene asks for them).

Ingredients built but not in cascade+ (:data:`OPTIONAL`: the benchmark showed no gain) are added
by name, e.g. ``cascade+ +surfaces``.

``gymtrack benchmark --ablation`` switches cascade+'s ingredients off one at a time and adds
each to the cascade (:data:`INGREDIENTS`). A plain module (no numpy), so that the command line can
name the recipes without importing the tracker.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

__all__ = ["Method", "RECIPES", "MODES", "DEFAULT_MODE", "INGREDIENTS", "OPTIONAL", "PLANE_CHOICES", "method_of", "recipe"]

#: which clusters go to the vertical plane (Eq. 5-9): none (triangulation only; single
#: tracklets dropped, opposite pairs triangulated), the single views and opposite pairs (the
#: cascade), or all segments (no clustering, no triangulation)
PLANE_CHOICES = ("none", "rest", "all")


@dataclass(frozen=True)
class Method:
    """One recipe of the tracker (every field a choice a stage makes; the paper's cascade by default).

    plane: ``none`` | ``rest`` | ``all`` (:data:`PLANE_CHOICES`).
    image_motion: the per-view tracker links by IoU *and* predicted image motion where the frame
        rate is low enough that people move more than the prediction noise between frames
        (:mod:`gymtrack.tracking.single_view_motion`); else the paper's IoU tracker.
    outliers_at_mean: Eq. 4's space test on the tracklet's mean position (else on every point);
        the speed test is the paper's either way.
    floor: the floor hypothesis (:mod:`gymtrack.tracking.floor`): people whose views agree on the
        floor z = 0 are put there before the apparatus plane; a floor tracklet whose 2D tracks all
        belonged to one track continues it.
    ghost_test: two-view triangulated clusters floating above the floor off the apparatus are
        dropped as wrong pairs (:func:`gymtrack.tracking.floor.drop_floor_ghosts`).
    fusion: two-view clusters fused with the plane by their uncertainty
        (:mod:`gymtrack.tracking.fusion`), where the scene asks for it (``params.fuse_plane``).
    keep_older: a track born beside an older one continues as the older one
        (:meth:`gymtrack.tracking.linking.WindowLinker.step`).
    exclusion: reported points superseded by a later window or within 0.5 m of an older track
        are left out (:mod:`gymtrack.tracking.exclusion`; the target keeps every point).
    best_estimates: Eq. 12 averages only a frame's best-observed window estimates.
    solo_inside: a one-view plane tracklet is kept only inside the performance space.
    refine_plane: the apparatus plane refitted online from the tracker's own points
        (:mod:`gymtrack.tracking.plane_refine`), where the scene asks for it
        (``params.refine_plane`` or ``planes: auto``).
    surfaces: the scene's surfaces (the preset's, e.g. the pommel horse's horizontal support
        surface) join the planes in the plane stage (Eq. 5-9 unchanged: a cluster is fused on the
        surface where its views agree best); without surfaces in the scene, nothing changes. Not in
        cascade+ (:data:`OPTIONAL`): a camera nearly level with the body meets a horizontal surface
        at a grazing angle, and an opposite pair always agrees best on the vertical plane.
    hold_seconds: how long a segment's end box is held beyond its last observation, capped at
        ``params.max_age`` frames; None: ``max_age`` frames (the paper's).
    handover: a track born where the target's track ended continues the target for Eq. 13
        (:mod:`gymtrack.tracking.handover`); else the target is re-identified by Eq. 13 alone.
    ballistic: in the air the target's centre is predicted by a parabola under g
        (:mod:`gymtrack.tracking.ballistic`): a target whose track ended in flight is held and
        continued by the track born where the parabola puts it; held frames get the predicted point.
    regroup: in a triangulated cluster that Eq. 4 or the ghost test drops, each pair of opposite
        views nearest each other by Eq. 2 goes on to the plane stage as a pair of its own
        (:mod:`gymtrack.tracking.regroup`): a third view's wrong segment no longer takes the
        gymnast's opposite pair down with it.
    rejoin: a regrouped pair continues the track its 2D tracks belonged to wherever the wrong
        cluster had put it (linked by its 2D tracks), and a pair's view whose partner did not
        fuse with it continues its own track alone where it looks like a gymnast on the
        apparatus (:mod:`gymtrack.tracking.regroup`).
    reidentify: the held target gives way to another track that qualified (Eq. 13) seen in
        more views than the target (triangulated or on the plane alike) in more than Delta / 2
        of the last Delta frames (:class:`gymtrack.tracking.identify.TargetSelector`):
        a phantom of association identified before the gymnast qualified is not held while the
        gymnast's own track qualifies; else the target is held until it ends or leaves.
    reach: Eq. 13 counts a point raised above ``h_bot`` more than 1.5 m from the apparatus's bars
        and blocks only for as long as a flight lasts, for identifying a track and for keeping
        the target (:mod:`gymtrack.tracking.reach`): a phantom standing still in the air at the
        edge of the performance space is not identified, or not held; a scene without an
        apparatus is unchanged.
    chain: an identification's look-back (the back-fill) goes on to the track its track
        continues: one that ended at most 0.5 s before it was born, where its horizontal motion
        points (:mod:`gymtrack.tracking.chain`): the vault's run-up, broken at the take-off, is
        the gymnast's too once she is identified in the air (the tracks unchanged).
    lone: a segment of a dropped cluster whose 2D track belonged to the target's track in the
        previous window goes on to the plane alone and continues its own track, as ``rejoin``'s
        lone view does (:func:`gymtrack.tracking.regroup.target_lone`): the gymnast's one view
        is kept where a coach's is not.
    regain: while the target's track is lost, a one-view segment whose 2D track was seen but never
        placed may continue a track alone on the plane when its box holds the target's predicted
        centre (:mod:`gymtrack.tracking.regain`).
    name: what results and reports call it.
    """

    plane: str = "rest"
    image_motion: bool = False
    outliers_at_mean: bool = False
    floor: bool = False
    ghost_test: bool = False
    fusion: bool = False
    keep_older: bool = False
    exclusion: bool = False
    best_estimates: bool = False
    solo_inside: bool = False
    refine_plane: bool = False
    surfaces: bool = False
    hold_seconds: float | None = None
    handover: bool = False
    ballistic: bool = False
    regroup: bool = False
    rejoin: bool = False
    reidentify: bool = False
    reach: bool = False
    chain: bool = False
    lone: bool = False
    regain: bool = False
    name: str = "custom"

    def __post_init__(self) -> None:
        if self.plane not in PLANE_CHOICES:
            raise ValueError(f"Method.plane must be one of {PLANE_CHOICES}, got {self.plane!r}")

    def without(self, ingredient: str) -> "Method":
        """This recipe with one ingredient switched off (named ``<name> -<ingredient>``)."""
        return replace(self, **{ingredient: _OFF[ingredient]}, name=f"{self.name} -{ingredient}")

    def adding(self, ingredient: str, like: "Method | None" = None) -> "Method":
        """This recipe with one ingredient as ``like`` (default: cascade+, or on for one of
        :data:`OPTIONAL`) has it (``<name> +<ingredient>``)."""
        value = OPTIONAL[ingredient] if like is None and ingredient in OPTIONAL else getattr(like or RECIPES["cascade+"], ingredient)
        return replace(self, **{ingredient: value}, name=f"{self.name} +{ingredient}")


#: the value of each ingredient when it is off (the paper's choice)
_OFF = {f.name: f.default for f in fields(Method) if f.name not in ("plane", "name")}
#: cascade+'s ingredients beyond the paper, in the ablation's order
INGREDIENTS: tuple[str, ...] = tuple(_OFF)
#: ingredients built but left out of cascade+ (the benchmark showed no gain), with their value when on
OPTIONAL: dict[str, object] = {"surfaces": True}

#: the named recipes; a Tracker, the offline runners, batch and the command line take these names
RECIPES: dict[str, Method] = {
    "cascade": Method(name="cascade"),
    "triangulation": Method(plane="none", name="triangulation"),
    "plane": Method(plane="all", name="plane"),
    "cascade+": Method(image_motion=True, outliers_at_mean=True, floor=True, ghost_test=True, fusion=True,
                       keep_older=True, exclusion=True, best_estimates=True, solo_inside=True,
                       refine_plane=True, hold_seconds=0.2, handover=True, ballistic=True, regroup=True,
                       rejoin=True, reidentify=True, reach=True, chain=True, lone=True, regain=True, name="cascade+"),
}
MODES: tuple[str, ...] = tuple(RECIPES)
#: the recipe a Tracker, the offline runners, batch and the command line use unless told
#: otherwise; the paper's method stays ``mode="cascade"``
DEFAULT_MODE = "cascade+"


def method_of(method: "Method | str") -> Method:
    """A recipe; the recipe of a name in :data:`RECIPES`; or a derived recipe rebuilt from its
    name, ``"<mode> -<ingredient> +<ingredient> ..."`` as :meth:`Method.without` and
    :meth:`Method.adding` name it (so a string carries a derived recipe to batch workers and
    output markers). ValueError naming an unknown mode or ingredient."""
    if isinstance(method, Method):
        return method
    base, *changes = str(method).split() if isinstance(method, str) else [method]
    if base not in RECIPES:
        raise ValueError(f"unknown mode {method!r}; choose one of {', '.join(MODES)}")
    if any(c[:1] not in "+-" or len(c) < 2 for c in changes):
        raise ValueError(f"unknown mode {method!r}: after the mode's name come only -<ingredient> and +<ingredient>")
    m = RECIPES[base]
    for c in changes:
        m = recipe(m, *(([c[1:]], ()) if c[0] == "-" else ((), [c[1:]])))
    return m


def recipe(mode: "Method | str", without: "tuple[str, ...] | list[str]" = (), adding: "tuple[str, ...] | list[str]" = ()) -> Method:
    """The recipe ``mode`` with the ingredients ``without`` switched off and those of ``adding``
    as cascade+ has them (the command line's ``--without`` / ``--adding``); ValueError naming an
    unknown mode or ingredient."""
    m = method_of(mode)
    for name in (*without, *adding):
        if name not in INGREDIENTS:
            raise ValueError(f"unknown ingredient {name!r}; choose from {', '.join(INGREDIENTS)}")
    for name in without:
        m = m.without(name)
    for name in adding:
        m = m.adding(name)
    return m
